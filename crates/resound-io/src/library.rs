//! The material library: an embedded SQLite database (rusqlite, bundled SQLite) of
//! [`SoundMaterial`]s, and material files (JSON).
//!
//! One table, `materials(name TEXT PRIMARY KEY, json TEXT NOT NULL, updated TEXT NOT NULL)`: the
//! JSON is the material file itself, so nothing is lost between file and library. Every write
//! is one transaction. A new library is seeded with the five built-in materials ([`SoundMaterial::builtin`]: Ren 2013
//! Table I damping, SI γ and σ).
//! A second table, `files(kind, name, summary, data BLOB, updated)`, keeps statistics
//! (`resound stats`) and grain dictionaries (`resound grains analyze`) beside the materials:
//! the bytes of the file as written, checked by the caller before they are stored.
//! Default location: `$RESOUND_LIBRARY`, else `$XDG_DATA_HOME/resound/materials.sqlite`, else
//! `~/.local/share/resound/materials.sqlite`.

use crate::{atomic::write_atomic, io_err, parse_err, Result};
use resound_core::SoundMaterial;
use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a file kept in the library holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FileKind {
    /// Mode statistics (`resound stats`, JSON).
    Statistics,
    /// A grain dictionary (`resound grains analyze`, `.grains`).
    Grains,
}

impl FileKind {
    /// The name used in the database and in messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Statistics => "statistics",
            Self::Grains => "grains",
        }
    }

    /// The kind called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "statistics" => Some(Self::Statistics),
            "grains" => Some(Self::Grains),
            _ => None,
        }
    }

    /// The file name an export of `name` gets (`name.stats.json`, `name.grains`).
    pub fn file_name(self, name: &str) -> String {
        match self {
            Self::Statistics => format!("{name}.stats.json"),
            Self::Grains => format!("{name}.grains"),
        }
    }
}

/// A statistics or grains file kept in the library (its bytes are read with
/// [`Library::file`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LibraryFile {
    /// What it holds.
    pub kind: FileKind,
    /// Its name in the library.
    pub name: String,
    /// One line on what it holds (written when it was stored).
    pub summary: String,
    /// Its size, bytes.
    pub bytes: u64,
    /// When it was stored (UTC, SQLite `datetime`).
    pub updated: String,
}

const FILES_TABLE: &str = "CREATE TABLE IF NOT EXISTS files (kind TEXT NOT NULL, name TEXT NOT NULL, summary TEXT NOT NULL, data BLOB NOT NULL, updated TEXT NOT NULL, PRIMARY KEY (kind, name))";

/// An open material library.
pub struct Library {
    conn: Connection,
    path: PathBuf,
}

fn db_err(path: &Path, e: rusqlite::Error) -> crate::IoError {
    parse_err(path, format!("material library: {e}"))
}

/// A directory is no library (SQLite said "disk I/O error" of one).
fn refuse_directory(path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(parse_err(
            path,
            "is a directory; a material library is a file (e.g. materials.sqlite)",
        ));
    }
    Ok(())
}

/// The default library path (see the module docs); `None` without a home directory.
pub fn default_library_path() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("RESOUND_LIBRARY") {
        return Some(PathBuf::from(p));
    }
    let base = std::env::var_os("XDG_DATA_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/share")))?;
    Some(base.join("resound").join("materials.sqlite"))
}

/// Whether the database holds Resound's materials table.
fn has_materials_table(conn: &Connection, path: &Path) -> Result<bool> {
    Ok(conn
        .query_row(
            "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'materials'",
            [],
            |r| r.get::<_, i64>(0),
        )
        .map_err(|e| db_err(path, e))?
        > 0)
}

impl Library {
    /// Opens (creating and seeding when new) the library at `path`.
    ///
    /// # Errors
    /// File-system and SQLite errors, or a file that is not a Resound library.
    pub fn open(path: &Path) -> Result<Self> {
        refuse_directory(path)?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| io_err(path, e))?;
        }
        let mut conn = Connection::open(path).map_err(|e| db_err(path, e))?;
        // Writers wait for each other (up to 30 s) instead of failing with "database is locked".
        conn.busy_timeout(std::time::Duration::from_secs(30))
            .map_err(|e| db_err(path, e))?;
        // Immediate: two processes creating one library never both seed it.
        let tx = conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(|e| db_err(path, e))?;
        let existed = has_materials_table(&tx, path)?;
        if !existed {
            tx.execute(
                "CREATE TABLE materials (name TEXT PRIMARY KEY, json TEXT NOT NULL, updated TEXT NOT NULL)",
                [],
            )
            .map_err(|e| db_err(path, e))?;
            for m in SoundMaterial::builtin() {
                let json = serde_json::to_string(&m).map_err(|e| parse_err(path, e.to_string()))?;
                tx.execute(
                    "INSERT INTO materials (name, json, updated) VALUES (?1, ?2, datetime('now'))",
                    params![m.name, json],
                )
                .map_err(|e| db_err(path, e))?;
            }
        }
        tx.execute(FILES_TABLE, []).map_err(|e| db_err(path, e))?;
        tx.commit().map_err(|e| db_err(path, e))?;
        Ok(Self {
            conn,
            path: path.to_path_buf(),
        })
    }

    /// Opens an existing library for reading only: `None` when there is no file at `path` (a
    /// read never creates one), an error for a file that is not a Resound library (it is left
    /// untouched).
    ///
    /// # Errors
    /// SQLite errors; a file without the materials table.
    pub fn open_read_only(path: &Path) -> Result<Option<Self>> {
        if !path.exists() {
            return Ok(None);
        }
        refuse_directory(path)?;
        let conn = Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
            .map_err(|e| db_err(path, e))?;
        let has_table = has_materials_table(&conn, path)?;
        if !has_table {
            return Err(parse_err(
                path,
                "not a Resound material library (no materials table)",
            ));
        }
        Ok(Some(Self {
            conn,
            path: path.to_path_buf(),
        }))
    }

    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The names of all materials, sorted.
    pub fn names(&self) -> Result<Vec<String>> {
        let mut st = self
            .conn
            .prepare("SELECT name FROM materials ORDER BY name")
            .map_err(|e| db_err(&self.path, e))?;
        let rows = st
            .query_map([], |r| r.get::<_, String>(0))
            .map_err(|e| db_err(&self.path, e))?;
        rows.collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|e| db_err(&self.path, e))
    }

    /// The material called `name`, if any.
    pub fn get(&self, name: &str) -> Result<Option<SoundMaterial>> {
        let json: Option<String> = self
            .conn
            .query_row(
                "SELECT json FROM materials WHERE name = ?1",
                params![name],
                |r| r.get(0),
            )
            .optional()
            .map_err(|e| db_err(&self.path, e))?;
        json.map(|j| {
            serde_json::from_str(&j)
                .map_err(|e| parse_err(&self.path, format!("material {name:?} is corrupt: {e}")))
        })
        .transpose()
    }

    /// Inserts or replaces `m` (validated first) in one transaction.
    pub fn put(&mut self, m: &SoundMaterial) -> Result<()> {
        m.validate().map_err(|e| parse_err(&self.path, e))?;
        let json = serde_json::to_string(m).map_err(|e| parse_err(&self.path, e.to_string()))?;
        let tx = self.conn.transaction().map_err(|e| db_err(&self.path, e))?;
        tx.execute(
            "INSERT OR REPLACE INTO materials (name, json, updated) VALUES (?1, ?2, datetime('now'))",
            params![m.name, json],
        )
        .map_err(|e| db_err(&self.path, e))?;
        tx.commit().map_err(|e| db_err(&self.path, e))
    }

    /// Inserts `m` (validated first), replacing an entry of its name only when `replace`:
    /// returns `false` (and changes nothing) when one exists and `replace` is not set. The
    /// check and the insert are one immediate transaction, so of several writers of a new name
    /// (threads or processes) exactly one stores it and the others hear it exists.
    pub fn insert(&mut self, m: &SoundMaterial, replace: bool) -> Result<bool> {
        m.validate().map_err(|e| parse_err(&self.path, e))?;
        let json = serde_json::to_string(m).map_err(|e| parse_err(&self.path, e.to_string()))?;
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(|e| db_err(&self.path, e))?;
        let exists = tx
            .query_row(
                "SELECT count(*) FROM materials WHERE name = ?1",
                params![m.name],
                |r| r.get::<_, i64>(0),
            )
            .map_err(|e| db_err(&self.path, e))?
            > 0;
        if exists && !replace {
            return Ok(false);
        }
        tx.execute(
            "INSERT OR REPLACE INTO materials (name, json, updated) VALUES (?1, ?2, datetime('now'))",
            params![m.name, json],
        )
        .map_err(|e| db_err(&self.path, e))?;
        tx.commit().map_err(|e| db_err(&self.path, e))?;
        Ok(true)
    }

    /// Renames entry `from` to `to` in one immediate transaction: `Ok(None)` when there is no
    /// `from`, `Ok(Some(false))` (nothing changed) when `to` exists and `replace` is not set.
    pub fn rename(&mut self, from: &str, to: &str, replace: bool) -> Result<Option<bool>> {
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(|e| db_err(&self.path, e))?;
        let json: Option<String> = tx
            .query_row(
                "SELECT json FROM materials WHERE name = ?1",
                params![from],
                |r| r.get(0),
            )
            .optional()
            .map_err(|e| db_err(&self.path, e))?;
        let Some(json) = json else { return Ok(None) };
        if from == to {
            return Ok(Some(true));
        }
        let taken = tx
            .query_row(
                "SELECT count(*) FROM materials WHERE name = ?1",
                params![to],
                |r| r.get::<_, i64>(0),
            )
            .map_err(|e| db_err(&self.path, e))?
            > 0;
        if taken && !replace {
            return Ok(Some(false));
        }
        let mut m: SoundMaterial = serde_json::from_str(&json)
            .map_err(|e| parse_err(&self.path, format!("material {from:?} is corrupt: {e}")))?;
        m.name = to.to_string();
        m.validate().map_err(|e| parse_err(&self.path, e))?;
        let json = serde_json::to_string(&m).map_err(|e| parse_err(&self.path, e.to_string()))?;
        tx.execute(
            "INSERT OR REPLACE INTO materials (name, json, updated) VALUES (?1, ?2, datetime('now'))",
            params![to, json],
        )
        .map_err(|e| db_err(&self.path, e))?;
        tx.execute("DELETE FROM materials WHERE name = ?1", params![from])
            .map_err(|e| db_err(&self.path, e))?;
        tx.commit().map_err(|e| db_err(&self.path, e))?;
        Ok(Some(true))
    }

    /// Removes `name`; returns whether it existed.
    pub fn remove(&mut self, name: &str) -> Result<bool> {
        let tx = self.conn.transaction().map_err(|e| db_err(&self.path, e))?;
        let n = tx
            .execute("DELETE FROM materials WHERE name = ?1", params![name])
            .map_err(|e| db_err(&self.path, e))?;
        tx.commit().map_err(|e| db_err(&self.path, e))?;
        Ok(n > 0)
    }
}

impl Library {
    /// Whether the files table exists (a library written by an earlier version, opened for
    /// reading, has none: it holds no files).
    fn has_files_table(&self) -> Result<bool> {
        Ok(self
            .conn
            .query_row(
                "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'files'",
                [],
                |r| r.get::<_, i64>(0),
            )
            .map_err(|e| db_err(&self.path, e))?
            > 0)
    }

    /// Every statistics and grains file kept, by kind then name.
    pub fn files(&self) -> Result<Vec<LibraryFile>> {
        if !self.has_files_table()? {
            return Ok(Vec::new());
        }
        let mut st = self
            .conn
            .prepare(
                "SELECT kind, name, summary, length(data), updated FROM files ORDER BY kind, name",
            )
            .map_err(|e| db_err(&self.path, e))?;
        let rows = st
            .query_map([], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, String>(2)?,
                    r.get::<_, i64>(3)?,
                    r.get::<_, String>(4)?,
                ))
            })
            .map_err(|e| db_err(&self.path, e))?;
        let mut out = Vec::new();
        for row in rows {
            let (kind, name, summary, bytes, updated) = row.map_err(|e| db_err(&self.path, e))?;
            let kind = FileKind::from_name(&kind).ok_or_else(|| {
                parse_err(
                    &self.path,
                    format!("file {name:?} has an unknown kind {kind:?}"),
                )
            })?;
            out.push(LibraryFile {
                kind,
                name,
                summary,
                bytes: bytes.max(0) as u64,
                updated,
            });
        }
        Ok(out)
    }

    /// The bytes of the `kind` file called `name`, if any.
    pub fn file(&self, kind: FileKind, name: &str) -> Result<Option<Vec<u8>>> {
        if !self.has_files_table()? {
            return Ok(None);
        }
        self.conn
            .query_row(
                "SELECT data FROM files WHERE kind = ?1 AND name = ?2",
                params![kind.name(), name],
                |r| r.get(0),
            )
            .optional()
            .map_err(|e| db_err(&self.path, e))
    }

    /// Stores `data` as the `kind` file `name` with its `summary`, replacing one of that kind
    /// and name only when `replace`: returns `false` (and changes nothing) when one exists
    /// and `replace` is not set. The check and the write are one transaction, so of two
    /// writers of a new name one wins and the other hears it exists. The caller checks that
    /// `data` is what `kind` says.
    pub fn put_file(
        &mut self,
        kind: FileKind,
        name: &str,
        summary: &str,
        data: &[u8],
        replace: bool,
    ) -> Result<bool> {
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(|e| db_err(&self.path, e))?;
        tx.execute(FILES_TABLE, [])
            .map_err(|e| db_err(&self.path, e))?;
        let existed: bool = tx
            .query_row(
                "SELECT count(*) FROM files WHERE kind = ?1 AND name = ?2",
                params![kind.name(), name],
                |r| r.get::<_, i64>(0),
            )
            .map_err(|e| db_err(&self.path, e))?
            > 0;
        if existed && !replace {
            return Ok(false);
        }
        tx.execute(
            "INSERT OR REPLACE INTO files (kind, name, summary, data, updated) VALUES (?1, ?2, ?3, ?4, datetime('now'))",
            params![kind.name(), name, summary, data],
        )
        .map_err(|e| db_err(&self.path, e))?;
        tx.commit().map_err(|e| db_err(&self.path, e))?;
        Ok(true)
    }

    /// Removes the `kind` file `name`; returns whether it existed.
    pub fn remove_file(&mut self, kind: FileKind, name: &str) -> Result<bool> {
        if !self.has_files_table()? {
            return Ok(false);
        }
        let tx = self.conn.transaction().map_err(|e| db_err(&self.path, e))?;
        let n = tx
            .execute(
                "DELETE FROM files WHERE kind = ?1 AND name = ?2",
                params![kind.name(), name],
            )
            .map_err(|e| db_err(&self.path, e))?;
        tx.commit().map_err(|e| db_err(&self.path, e))?;
        Ok(n > 0)
    }
}

/// Reads a material file (JSON) and validates it.
pub fn read_material(path: &Path) -> Result<SoundMaterial> {
    let text = std::fs::read_to_string(path).map_err(|e| io_err(path, e))?;
    let m: SoundMaterial = serde_json::from_str(&text)
        .map_err(|e| parse_err(path, format!("not a material file: {e}")))?;
    m.validate().map_err(|e| parse_err(path, e))?;
    Ok(m)
}

/// Writes a material file (pretty JSON), atomically.
pub fn write_material(path: &Path, m: &SoundMaterial) -> Result<()> {
    m.validate().map_err(|e| parse_err(path, e))?;
    let text = serde_json::to_string_pretty(m).map_err(|e| parse_err(path, e.to_string()))?;
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}
