//! Atomic file writes: never leave a half-written output behind.

use crate::{io_err, Result};
use std::io::Write;
use std::path::Path;

/// Writes `path` by calling `f` on a buffered temporary file in the same directory, then renames
/// it over `path`. On any error the temporary file is removed and `path` is untouched.
///
/// # Errors
/// [`crate::IoError::Io`] from creating, writing or renaming.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".resound-tmp-")
        .tempfile_in(dir)
        .map_err(|e| io_err(path, e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        f(&mut w).map_err(|e| io_err(path, e))?;
        w.flush().map_err(|e| io_err(path, e))?;
    }
    tmp.persist(path).map_err(|e| io_err(path, e.error))?;
    Ok(())
}
