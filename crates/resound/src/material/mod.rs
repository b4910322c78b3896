//! Materials: finding one (file, library, preset) here, and estimating one from a recording
//! (Ren §5, with the §6.1 residual) in [`estimate_material`] and its kin.

mod estimation;
mod kept_files;
pub use estimation::*;
pub use kept_files::*;

use crate::error::{invalid, Error, Result};
use resound_core::{Material, SoundMaterial};
use resound_io::library::{default_library_path, read_material, Library};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The library at `path`, or the default one ($RESOUND_LIBRARY, else
/// ~/.local/share/resound/materials.sqlite).
///
/// # Errors
/// No home directory for the default; the library cannot be opened.
pub fn open_library(path: Option<&Path>) -> Result<Library> {
    let path: PathBuf = match path {
        Some(p) => p.to_path_buf(),
        None => default_library_path().ok_or_else(|| {
            invalid("no home directory for the default library; name a library file")
        })?,
    };
    Library::open(&path).map_err(|e| {
        Error::from(e).context(format!("opening the material library {}", path.display()))
    })
}

/// Refuses a `name` the library at `path` (or the default one) already holds, unless
/// `replace`: the check before a long estimate whose result will be stored under it.
///
/// # Errors
/// [`Error::Exists`]; an unreadable library.
pub fn check_name_free(path: Option<&Path>, name: &str, replace: bool) -> Result<()> {
    if replace {
        return Ok(());
    }
    match read_library(path)? {
        Some(lib) if lib.get(name)?.is_some() => Err(Error::Exists(name.to_string())),
        _ => Ok(()),
    }
}

/// Stores `material` in the library at `path` (or the default one, created if need be) under
/// its name; an existing entry of that name is replaced only with `replace` — never silently.
///
/// # Errors
/// [`Error::Exists`]; a library that cannot be opened or written.
pub fn store_material(path: Option<&Path>, material: &SoundMaterial, replace: bool) -> Result<()> {
    // The check and the insert are one transaction: of concurrent writers of a new name
    // exactly one stores it.
    if !open_library(path)?.insert(material, replace)? {
        return Err(Error::Exists(material.name.clone()));
    }
    Ok(())
}

/// The library at `path` (or the default one) for reading: `None` when it does not exist yet.
/// Never creates or changes a file.
///
/// # Errors
/// A file that is not a library; no home directory for the default.
pub fn read_library(path: Option<&Path>) -> Result<Option<Library>> {
    let path: PathBuf = match path {
        Some(p) => p.to_path_buf(),
        None => default_library_path().ok_or_else(|| {
            invalid("no home directory for the default library; name a library file")
        })?,
    };
    Ok(Library::open_read_only(&path)?)
}

/// A library entry by name, else the built-in of that name (with or without a library); a
/// missing name lists the known ones. A library entry holding Ren's Table I in mesh units (as
/// earlier versions seeded) is an error that says how to replace it.
///
/// # Errors
/// Unknown names, legacy entries, unreadable libraries.
pub fn library_material(lib: Option<&Library>, name: &str) -> Result<SoundMaterial> {
    if let Some(l) = lib {
        if let Some(m) = l.get(name)? {
            return not_legacy(m, l.path());
        }
    }
    // Every listed name is reachable ([`list_materials`]): the built-ins, then the presets
    // under their plain names.
    let preset = || {
        preset_sound_material(name).map(|m| SoundMaterial {
            name: name.to_string(),
            ..m
        })
    };
    SoundMaterial::builtin_named(name)
        .or_else(preset)
        .ok_or_else(|| {
            let mut known: Vec<String> = match lib {
                Some(l) => l.names().unwrap_or_default(),
                None => Vec::new(),
            };
            known.extend(SoundMaterial::builtin().into_iter().map(|m| m.name));
            known.extend(Material::PRESET_NAMES.iter().map(|n| n.to_string()));
            known.sort();
            known.dedup();
            invalid(format!(
                "no material {name:?} in the library (known: {})",
                known.join(", ")
            ))
        })
}

/// Where a listed material comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// Built in, not (or not differently) stored in the library.
    Builtin,
    /// Stored in the library without provenance (imported, or a seeded built-in).
    Library,
    /// Estimated from a recording.
    Estimated,
    /// Ren's Table I in mesh units, seeded by an earlier version: remove it.
    LegacyTable1,
    /// An elastic preset's E/ρ with the damping of the matching built-in
    /// ([`preset_sound_material`]).
    Preset,
}

impl Origin {
    /// A note for a listing (empty for a plain library entry).
    pub fn note(self) -> &'static str {
        match self {
            Origin::Builtin => "(built-in)",
            Origin::Library => "",
            Origin::Estimated => "(estimated)",
            Origin::LegacyTable1 => "(Ren Table I in mesh units, from an old library: remove it)",
            Origin::Preset => "(preset: its E/rho, a built-in's damping)",
        }
    }
}

/// Removes the entry `name` from the library at `path` (or the default one). Built-ins stay
/// reachable by name; only a library's own copy can go.
///
/// # Errors
/// [`Error::Missing`] when there is no library yet or no such entry; an unreadable library.
pub fn remove_material(path: Option<&Path>, name: &str) -> Result<()> {
    if read_library(path)?.is_none() {
        return Err(Error::Missing(
            "no material library yet (estimate --name or materials import creates one)".into(),
        ));
    }
    if !open_library(path)?.remove(name)? {
        return Err(Error::Missing(format!(
            "no material {name:?} in the library (built-ins cannot be removed)"
        )));
    }
    Ok(())
}

/// Renames the library entry `from` to `to`; an entry named `to` is replaced only when
/// `replace`.
///
/// # Errors
/// [`Error::Missing`] without such an entry; [`Error::Exists`] when `to` is taken; an invalid
/// name; an unreadable library.
pub fn rename_material(path: Option<&Path>, from: &str, to: &str, replace: bool) -> Result<()> {
    let missing = || Error::Missing(format!("no material {from:?} in the library"));
    read_library(path)?.ok_or_else(missing)?;
    match open_library(path)?.rename(from, to, replace)? {
        None => Err(missing()),
        Some(false) => Err(Error::Exists(to.to_string())),
        Some(true) => Ok(()),
    }
}

/// One line of a material listing (`materials list`): name, the four constants and the origin.
pub fn listing_line(m: &SoundMaterial, origin: Origin) -> String {
    let line = format!(
        "{:<16} alpha {:.4e}  beta {:.4e}  gamma {:.4e}  sigma {:.4e}  {}",
        m.name,
        m.alpha,
        m.beta,
        m.gamma,
        m.sigma,
        origin.note()
    );
    line.trim_end().to_string()
}

/// The materials a library (or the default one) lists, for `materials list` and the studio.
#[derive(Clone, Debug, Serialize)]
pub struct Listing {
    /// Every material a name can reach, by name, with its origin.
    pub materials: Vec<(SoundMaterial, Origin)>,
    /// The statistics and grain dictionaries kept beside them ([`store_file`]).
    pub files: Vec<resound_io::library::LibraryFile>,
    /// Why only the built-ins are listed (no library file yet).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl std::fmt::Display for Listing {
    /// One [`listing_line`] per material, then one line per kept file.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (m, origin) in &self.materials {
            writeln!(f, "{}", listing_line(m, *origin))?;
        }
        for k in &self.files {
            writeln!(
                f,
                "{:<16} {:<10} {} ({} bytes)",
                k.name,
                k.kind.name(),
                k.summary,
                k.bytes
            )?;
        }
        Ok(())
    }
}

/// Lists the library at `path` (or the default one): its entries and the built-ins; a library
/// that does not exist yet lists the built-ins with a note (nothing is created).
///
/// # Errors
/// A file that is not a library.
pub fn list_library(path: Option<&Path>) -> Result<Listing> {
    let lib = read_library(path)?;
    let note = lib.is_none().then(|| {
        let at = path
            .map(Path::to_path_buf)
            .or_else(default_library_path)
            .map_or_else(|| "the default path".into(), |p| p.display().to_string());
        format!(
            "no material library at {at} yet: the built-ins only (estimate --name or materials \
             import creates it)"
        )
    });
    Ok(Listing {
        materials: list_materials(lib.as_ref())?,
        files: lib
            .as_ref()
            .map(Library::files)
            .transpose()?
            .unwrap_or_default(),
        note,
    })
}

/// Every material a name can reach: the library's entries and the built-ins it does not hold,
/// sorted by name.
///
/// # Errors
/// Unreadable libraries.
pub fn list_materials(lib: Option<&Library>) -> Result<Vec<(SoundMaterial, Origin)>> {
    let mut out = Vec::new();
    if let Some(l) = lib {
        for n in l.names()? {
            let Some(m) = l.get(&n)? else { continue };
            let origin = if m.is_legacy_table_1() {
                Origin::LegacyTable1
            } else if m.provenance.is_some() {
                Origin::Estimated
            } else if SoundMaterial::builtin_named(&n).as_ref() == Some(&m) {
                Origin::Builtin
            } else {
                Origin::Library
            };
            out.push((m, origin));
        }
    }
    for b in SoundMaterial::builtin() {
        if !out.iter().any(|(m, _)| m.name == b.name) {
            out.push((b, Origin::Builtin));
        }
    }
    // The elastic presets a plain name reaches too (steel, aluminium, ceramic), as
    // `resolve_material` finds them: one vocabulary in every command.
    for &n in Material::PRESET_NAMES {
        if out.iter().any(|(m, _)| m.name == n) {
            continue;
        }
        if let Some(m) = preset_sound_material(n) {
            out.push((
                SoundMaterial {
                    name: n.to_string(),
                    ..m
                },
                Origin::Preset,
            ));
        }
    }
    out.sort_by(|a, b| a.0.name.cmp(&b.0.name));
    Ok(out)
}

fn not_legacy(m: SoundMaterial, library: &Path) -> Result<SoundMaterial> {
    if !m.is_legacy_table_1() {
        return Ok(m);
    }
    Err(invalid(format!(
        "library entry {:?} in {} holds Ren 2013 Table I as printed, in his meshes' units \
         (γ = {:.4e} m²/s², σ = {:.4e}): on a mesh in metres it renders several times too low \
         in pitch and near −150 dBFS. Earlier versions seeded libraries with it. Remove it \
         (`resound materials remove {}`) and the SI built-in of that name is used",
        m.name,
        library.display(),
        m.gamma,
        m.sigma,
        m.name
    )))
}

/// The Rayleigh α, β of the built-in (Ren Table I) material that matches an elastic preset.
fn table_damping(preset: &str) -> Option<(f64, f64)> {
    let ren = match preset {
        "steel" | "aluminium" => "metal",
        "ceramic" => "porcelain",
        "glass" => "glass",
        "wood" => "wood",
        "plastic" => "plastic",
        _ => return None,
    };
    SoundMaterial::builtin_named(ren).map(|m| (m.alpha, m.beta))
}

/// `preset:NAME` as a sound material: an elastic preset's γ = E/ρ with the Rayleigh damping of
/// the matching Ren 2013 Table I material (steel and aluminium → metal, ceramic → porcelain),
/// σ = [`resound_core::DEFAULT_SIGMA`].
pub fn preset_sound_material(name: &str) -> Option<SoundMaterial> {
    let m = Material::preset(name).ok()?;
    let (alpha, beta) = table_damping(&m.name)?;
    Some(SoundMaterial::rayleigh(
        &format!("preset:{name}"),
        alpha,
        beta,
        m.stiffness_density_ratio(),
        resound_core::DEFAULT_SIGMA,
    ))
}

/// Resolves a material reference: `preset:NAME`, a material file (relative to `base_dir`), a
/// library name, a built-in name ([`SoundMaterial::builtin`]) or a plain preset name. The
/// result is validated.
///
/// # Errors
/// Unknown references, unreadable files, invalid values, legacy library entries.
pub fn resolve_material(
    spec: &str,
    base_dir: &Path,
    library: Option<&Library>,
) -> Result<SoundMaterial> {
    let m = if let Some(p) = spec.strip_prefix("preset:") {
        preset_sound_material(p).ok_or_else(|| {
            invalid(format!(
                "unknown preset {p:?} ({})",
                Material::PRESET_NAMES.join(", ")
            ))
        })?
    } else {
        let path = base_dir.join(spec);
        if spec.to_ascii_lowercase().ends_with(".json") || path.is_file() {
            read_material(&path)?
        } else {
            let entry = match library {
                Some(l) => l.get(spec)?.map(|m| not_legacy(m, l.path())).transpose()?,
                None => None,
            };
            match entry
                .or_else(|| SoundMaterial::builtin_named(spec))
                .or_else(|| preset_sound_material(spec))
            {
                Some(m) => m,
                None => {
                    return Err(invalid(format!(
                        "no material {spec:?} in the library, no such file, and not a built-in \
                         name (wood, plastic, metal, glass, porcelain, steel, aluminium, \
                         ceramic); `materials list` shows every name"
                    )))
                }
            }
        }
    };
    m.validate().map_err(invalid)?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writers started at once against one library (`Library::insert`, what `store_material`
    /// calls), each storing its own material under one new name without `replace`: exactly
    /// one is stored, every other hears it exists (as it
    /// would run one after another), and what is stored is the winner's. Likewise two renames
    /// onto one free name.
    #[test]
    fn concurrent_writers_of_one_name_never_both_win() {
        let dir = tempfile::tempdir().unwrap();
        let lib = dir.path().join("lib.sqlite");
        let writers = 6;
        open_library(Some(&lib)).unwrap();
        // Every writer has its connection open before any writes (a barrier), so their
        // check-then-insert steps overlap as far as the library lets them.
        let barrier = std::sync::Barrier::new(writers);
        let results: Vec<(f64, Result<()>)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..writers)
                .map(|i| {
                    let (lib, barrier) = (lib.clone(), &barrier);
                    scope.spawn(move || {
                        let mut m = SoundMaterial::builtin_named("wood").unwrap();
                        m.name = "same".into();
                        m.alpha = 1.0 + i as f64;
                        let mut l = open_library(Some(&lib)).unwrap();
                        barrier.wait();
                        let r = match l.insert(&m, false) {
                            Ok(true) => Ok(()),
                            Ok(false) => Err(Error::Exists(m.name.clone())),
                            Err(e) => Err(e.into()),
                        };
                        (m.alpha, r)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let won: Vec<f64> = results
            .iter()
            .filter(|(_, r)| r.is_ok())
            .map(|(a, _)| *a)
            .collect();
        assert_eq!(won.len(), 1, "{results:?}");
        for (_, r) in &results {
            if let Err(e) = r {
                assert!(matches!(e, Error::Exists(_)), "{e}");
            }
        }
        let l = read_library(Some(&lib)).unwrap().unwrap();
        assert_eq!(l.get("same").unwrap().unwrap().alpha, won[0]);

        // Two entries renamed onto one free name at once: one rename lands, the other is
        // refused, and both materials still exist under some name.
        for n in ["a", "b"] {
            let mut m = SoundMaterial::builtin_named("glass").unwrap();
            m.name = n.into();
            store_material(Some(&lib), &m, false).unwrap();
        }
        let renames: Vec<Result<()>> = std::thread::scope(|scope| {
            let hs: Vec<_> = ["a", "b"]
                .into_iter()
                .map(|from| {
                    let lib = lib.clone();
                    scope.spawn(move || rename_material(Some(&lib), from, "c", false))
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(
            renames.iter().filter(|r| r.is_ok()).count(),
            1,
            "{renames:?}"
        );
        let names = read_library(Some(&lib)).unwrap().unwrap().names().unwrap();
        assert!(names.contains(&"c".to_string()));
        assert_eq!(
            names.iter().filter(|n| *n == "a" || *n == "b").count(),
            1,
            "{names:?}"
        );
    }
}
