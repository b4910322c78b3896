//! Statistics and grain dictionaries kept in the material library beside the materials
//! (`materials list` and the studio's library show them): stored only after they are read
//! back as what they claim to be, never silently replaced.

use super::{open_library, read_library};
use crate::error::{invalid, Error, Result};
use resound_io::library::{FileKind, LibraryFile};
use std::path::Path;

/// What `data` is — a statistics file or a grain dictionary — with a one-line summary.
///
/// # Errors
/// Neither (both readers' messages).
pub fn identify_file(data: &[u8]) -> Result<(FileKind, String)> {
    let origin = "the file";
    let as_stats = std::str::from_utf8(data)
        .map_err(|_| invalid("not UTF-8 text"))
        .and_then(|t| crate::files::parse_stats(t, origin));
    match as_stats {
        Ok(s) => Ok((
            FileKind::Statistics,
            format!(
                "{}: {} modes from {} source(s){}",
                s.material,
                s.modes,
                s.sources,
                if s.transient.is_some() {
                    ", with transient bands"
                } else {
                    ""
                }
            ),
        )),
        Err(stats_err) => {
            let d = resound_io::grains_file::decode(data, Path::new("the file")).map_err(|e| {
                invalid(format!(
                    "neither a statistics file ({stats_err}) nor a grain dictionary ({e})"
                ))
            })?;
            let s = crate::grain_files::summary(&d, None)?;
            Ok((
                FileKind::Grains,
                format!(
                    "{} grains ({} impulsive, {} sinusoidal, {} transient) from {} recording(s) at {} Hz",
                    s.grains,
                    s.impulsive,
                    s.sinusoidal,
                    s.transient,
                    s.recordings.len(),
                    s.sample_rate_hz
                ),
            ))
        }
    }
}

/// Checks a name for a kept file: 1–128 printable characters.
fn check_name(name: &str) -> Result<()> {
    if name.trim().is_empty() || name.len() > 128 || name.chars().any(char::is_control) {
        return Err(invalid(format!(
            "file name {name:?} must be 1–128 printable characters"
        )));
    }
    Ok(())
}

/// Stores `data` (a statistics file or a grain dictionary, checked by reading it back with
/// [`identify_file`]) in the library at `path` (or the default one, created if need be) as
/// `name`; one of that kind and name is replaced only with `replace`.
///
/// # Errors
/// [`Error::Exists`]; a bad name; data that is neither kind; an unwritable library.
pub fn store_file(
    path: Option<&Path>,
    name: &str,
    data: &[u8],
    replace: bool,
) -> Result<LibraryFile> {
    check_name(name)?;
    let (kind, summary) = identify_file(data)?;
    let mut lib = open_library(path)?;
    if !lib.put_file(kind, name, &summary, data, replace)? {
        return Err(Error::Exists(format!("{} {name}", kind.name())));
    }
    lib.files()?
        .into_iter()
        .find(|f| f.kind == kind && f.name == name)
        .ok_or_else(|| invalid(format!("{} {name:?} was not stored", kind.name())))
}

/// The bytes of the kept `kind` file `name` (as stored: write them to
/// [`FileKind::file_name`] and any command reads them).
///
/// # Errors
/// [`Error::Missing`]; an unreadable library.
pub fn kept_file(path: Option<&Path>, kind: FileKind, name: &str) -> Result<Vec<u8>> {
    read_library(path)?
        .map(|l| l.file(kind, name))
        .transpose()?
        .flatten()
        .ok_or_else(|| Error::Missing(format!("no {} {name:?} in the library", kind.name())))
}

/// Removes the kept `kind` file `name`.
///
/// # Errors
/// [`Error::Missing`]; an unreadable library.
pub fn remove_file(path: Option<&Path>, kind: FileKind, name: &str) -> Result<()> {
    let missing = || Error::Missing(format!("no {} {name:?} in the library", kind.name()));
    if read_library(path)?.is_none() || !open_library(path)?.remove_file(kind, name)? {
        return Err(missing());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_stats::ModeStatistics;

    fn stats() -> Vec<u8> {
        let s = ModeStatistics {
            material: "tin".into(),
            modes: 1,
            mean: vec![7.0, -20.0, -60.0],
            covariance: vec![0.1, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 25.0],
            sources: 3,
            transient: None,
        };
        serde_json::to_vec(&s).unwrap()
    }

    fn grains() -> Vec<u8> {
        // Half a second of decaying clicks, cut into grains.
        let fs = 48_000.0;
        let x: Vec<f32> = (0..24_000)
            .map(|i| {
                let t = (i % 4800) as f64 / fs;
                ((-60.0 * t).exp() * (std::f64::consts::TAU * 900.0 * t).sin()) as f32 * 0.5
            })
            .collect();
        let r = crate::grain_files::recording_from_samples(
            "clicks".into(),
            x,
            fs,
            crate::grain_files::KindRule::Auto,
        )
        .unwrap();
        let (d, _) =
            resound_grains::analyze(&[r], fs, &Default::default(), &|_| {}).expect("grains");
        resound_io::grains_file::encode(&d)
    }

    #[test]
    fn kept_files_are_checked_listed_exported_byte_for_byte_and_never_silently_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let lib = dir.path().join("lib.sqlite");
        let lib = Some(lib.as_path());
        let (s, g) = (stats(), grains());
        let kept = store_file(lib, "tin", &s, false).unwrap();
        assert_eq!(kept.kind, FileKind::Statistics);
        assert!(kept.summary.contains("1 modes from 3"), "{}", kept.summary);
        let kept = store_file(lib, "clicks", &g, false).unwrap();
        assert_eq!(kept.kind, FileKind::Grains);
        assert_eq!(kept.bytes, g.len() as u64);
        // A second file of a kept name is refused, then replaces it only when asked.
        assert!(matches!(
            store_file(lib, "tin", &s, false),
            Err(Error::Exists(_))
        ));
        store_file(lib, "tin", &s, true).unwrap();
        // Same name, other kind: two entries.
        store_file(lib, "tin", &g, false).unwrap();
        // Anything else is refused with both readers' reasons.
        let e = store_file(lib, "junk", b"{\"material\": 1}", false).unwrap_err();
        assert!(e.to_string().contains("neither a statistics file"), "{e}");
        let mut bad = serde_json::from_slice::<serde_json::Value>(&s).unwrap();
        bad["covariance"] = serde_json::json!([1.0]);
        let e = store_file(lib, "bad", &serde_json::to_vec(&bad).unwrap(), false).unwrap_err();
        assert!(e.to_string().contains("inconsistent"), "{e}");
        assert!(store_file(lib, "", &s, false).is_err());

        let listing = super::super::list_library(lib).unwrap();
        let names: Vec<(FileKind, &str)> = listing
            .files
            .iter()
            .map(|f| (f.kind, f.name.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                (FileKind::Grains, "clicks"),
                (FileKind::Grains, "tin"),
                (FileKind::Statistics, "tin")
            ]
        );
        assert!(listing.to_string().contains("statistics"));
        // Exported bytes are the file: the readers take them back.
        let out = kept_file(lib, FileKind::Grains, "clicks").unwrap();
        assert_eq!(out, g);
        let p = dir.path().join(FileKind::Statistics.file_name("tin"));
        std::fs::write(&p, kept_file(lib, FileKind::Statistics, "tin").unwrap()).unwrap();
        assert_eq!(crate::files::load_stats(&p).unwrap().sources, 3);
        remove_file(lib, FileKind::Grains, "tin").unwrap();
        assert!(matches!(
            remove_file(lib, FileKind::Grains, "tin"),
            Err(Error::Missing(_))
        ));
        assert!(matches!(
            kept_file(lib, FileKind::Grains, "tin"),
            Err(Error::Missing(_))
        ));
        // A library that does not exist yet holds nothing and is not created by a read.
        let none = dir.path().join("none.sqlite");
        assert!(matches!(
            kept_file(Some(&none), FileKind::Grains, "x"),
            Err(Error::Missing(_))
        ));
        assert!(!none.exists());
    }
}
