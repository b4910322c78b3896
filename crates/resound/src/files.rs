//! Small files the pipeline reads and writes that belong to no one crate's format: mode
//! statistics (JSON), analysed modes (`resound analyze --json`), and JSON/JSON-lines outputs.

use crate::error::{invalid, Error, Result};
use resound_core::DampedMode;
use resound_io::atomic::write_atomic;
use resound_stats::ModeStatistics;
use serde::{Deserialize, Serialize};
use std::path::Path;

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| {
        Error::from(resound_io::IoError::Io {
            path: path.to_path_buf(),
            error: e,
        })
    })
}

/// Writes `value` as pretty JSON, atomically.
///
/// # Errors
/// The write fails.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| invalid(e.to_string()))?;
    write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// Writes one JSON line per item, atomically.
///
/// # Errors
/// The write fails.
pub fn write_json_lines<T: Serialize>(path: &Path, items: &[T]) -> Result<()> {
    let mut text = String::new();
    for e in items {
        text.push_str(&serde_json::to_string(e).map_err(|e| invalid(e.to_string()))?);
        text.push('\n');
    }
    write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// Reads a statistics file (`resound stats`), checking its dimensions.
///
/// # Errors
/// Unreadable, not a statistics file, inconsistent.
pub fn load_stats(path: &Path) -> Result<ModeStatistics> {
    parse_stats(&read_text(path)?, &path.display().to_string())
}

/// Parses the text of a statistics file named `origin` (for messages), checking its
/// dimensions as [`load_stats`] does.
///
/// # Errors
/// Not a statistics file, inconsistent.
pub fn parse_stats(text: &str, origin: &str) -> Result<ModeStatistics> {
    let s: ModeStatistics = serde_json::from_str(text)
        .map_err(|e| invalid(format!("{origin}: not a statistics file: {e}")))?;
    let dim = 3 * s.modes;
    if s.modes == 0 || s.mean.len() != dim || s.covariance.len() != dim * dim {
        return Err(invalid(format!(
            "{origin}: inconsistent statistics ({} modes)",
            s.modes
        )));
    }
    if s.mean.iter().chain(&s.covariance).any(|v| !v.is_finite()) {
        return Err(invalid(format!("{origin}: non-finite statistics")));
    }
    if let Some(t) = &s.transient {
        t.validate()
            .map_err(|e| invalid(format!("{origin}: {e}")))?;
    }
    Ok(s)
}

#[derive(Deserialize)]
struct ModesFile {
    modes: Vec<DampedMode>,
}

/// Reads the `modes` list of an analysis file (`resound analyze --json`).
///
/// # Errors
/// Unreadable, no modes list, an empty list.
pub fn load_modes(path: &Path) -> Result<Vec<DampedMode>> {
    let f: ModesFile = serde_json::from_str(&read_text(path)?).map_err(|e| {
        invalid(format!(
            "{}: no \"modes\" list of {{freq_hz, damping_per_s, amplitude, phase_rad}}: {e}",
            path.display()
        ))
    })?;
    if f.modes.is_empty() {
        return Err(invalid(format!(
            "{}: the modes list is empty",
            path.display()
        )));
    }
    Ok(f.modes)
}

/// Fits mode statistics (Traer 2019) of `material` to recordings of it (the first strike of
/// each, high-passed at `highpass_hz`): `modes` modes per impulse response, plus the transient
/// bands of what the modes leave (eq. 3). `progress` hears [`Stage::Analyzing`](crate::Stage::Analyzing) for every
/// analysed file (labelled with it and its mode count).
///
/// # Errors
/// Unreadable or silent recordings; too few recordings or modes for the fit.
pub fn fit_stats(
    recordings: &[std::path::PathBuf],
    material: &str,
    modes: usize,
    highpass_hz: Option<f64>,
    progress: crate::ProgressFn<'_>,
) -> Result<ModeStatistics> {
    let mut all = Vec::new();
    let mut transients = Vec::new();
    let params = resound_signal::AnalyzeParams {
        highpass_hz,
        ..Default::default()
    };
    for (i, p) in recordings.iter().enumerate() {
        let (_, r) = crate::recording::analyze_file(p, &Default::default(), &params)?;
        progress(
            crate::Progress::fraction(
                crate::Stage::Analyzing,
                (i + 1) as f64 / recordings.len() as f64,
            )
            .with_label(format!("{}: {} modes", p.display(), r.modes.len())),
        );
        let fs = r.sample_rate_hz;
        let modal = resound_core::damped::synthesize(&r.modes, fs, r.segment.len());
        let residual: Vec<f64> = r.segment.iter().zip(&modal).map(|(a, b)| a - b).collect();
        transients.push(resound_stats::transient::fit_transient(&residual, fs, 30));
        all.push(r.modes);
    }
    let mut s = ModeStatistics::fit(material, &all, modes)?;
    s.transient = Some(resound_stats::TransientStats::fit(&transients)?);
    Ok(s)
}

/// Reads every PyImpact material table (`<material>_<size>_mm.json`) in `dir`: their names
/// (`<material>_<size>`) and statistics, sorted by file name.
///
/// # Errors
/// An unreadable directory or table; no tables.
pub fn import_pyimpact(dir: &Path) -> Result<Vec<(String, ModeStatistics)>> {
    let io = |e: std::io::Error| {
        Error::from(resound_io::IoError::Io {
            path: dir.to_path_buf(),
            error: e,
        })
    };
    let mut entries: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    entries.sort();
    if entries.is_empty() {
        return Err(invalid(format!(
            "{}: no PyImpact tables (*.json)",
            dir.display()
        )));
    }
    let mut out = Vec::new();
    for p in entries {
        let stem = p
            .file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned());
        let name = stem.strip_suffix("_mm").unwrap_or(&stem).to_string();
        let s = ModeStatistics::from_pyimpact_json(&name, &read_text(&p)?)
            .map_err(|e| Error::from(e).at(&p))?;
        out.push((name, s));
    }
    Ok(out)
}

/// Makes an output directory, as every command treats one (`batch --out`, `--export-matrices`,
/// `stats import`, `demo --out-dir`): the directory itself may be new, its parent must exist
/// like every output file's ([`check_outputs`]), so a mistyped path is refused instead of
/// created. Concurrent makers (batch shards) all succeed.
///
/// # Errors
/// A missing parent; a path that is a file; an unwritable parent.
pub fn make_output_dir(dir: &Path) -> Result<()> {
    if dir.is_dir() {
        return Ok(());
    }
    check_outputs(&[], &[dir])?;
    match std::fs::create_dir(dir) {
        Err(e) if !(e.kind() == std::io::ErrorKind::AlreadyExists && dir.is_dir()) => {
            Err(Error::from(resound_io::IoError::Io {
                path: dir.to_path_buf(),
                error: e,
            }))
        }
        _ => Ok(()),
    }
}

/// Imports every PyImpact table in `dir` ([`import_pyimpact`]) as `<name>.stats.json` files
/// in `out_dir` ([`make_output_dir`]); returns the files written.
///
/// # Errors
/// As [`import_pyimpact`]; an unwritable directory.
pub fn import_pyimpact_into(dir: &Path, out_dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    let tables = import_pyimpact(dir)?;
    make_output_dir(out_dir)?;
    let mut written = Vec::new();
    for (name, s) in &tables {
        let p = out_dir.join(format!("{name}.stats.json"));
        write_json(&p, s)?;
        written.push(p);
    }
    Ok(written)
}

/// Checks output paths before any work (so nothing is half done when one is bad): each output's directory exists, no output is one of
/// the inputs (an `analyze x.wav --plot x.wav` would destroy the recording), and no two outputs
/// coincide. `-` (stdout) is not a path.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<()> {
    let canon = |p: &Path| std::fs::canonicalize(p).ok();
    // The default material library is never an output either: `materials export x
    // "$RESOUND_LIBRARY"` replaced every entry with one JSON document (callers with their own
    // library path pass it as an input).
    let library = resound_io::library::default_library_path();
    let outputs: Vec<&Path> = outputs
        .iter()
        .copied()
        .filter(|o| o.as_os_str() != "-")
        .collect();
    for (k, o) in outputs.iter().enumerate() {
        let dir = o
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        if !dir.is_dir() {
            return Err(invalid(format!(
                "cannot write {}: the directory {} does not exist",
                o.display(),
                dir.display()
            )));
        }
        let same = |a: &Path, b: &Path| a == b || canon(a).is_some_and(|c| Some(c) == canon(b));
        if let Some(l) = library.as_deref().filter(|l| same(l, o)) {
            return Err(invalid(format!(
                "{} is the material library ({}); refusing to overwrite it",
                o.display(),
                l.display()
            )));
        }
        if let Some(i) = inputs.iter().find(|i| same(i, o)) {
            return Err(invalid(format!(
                "{} is both an input and an output; refusing to overwrite {}",
                o.display(),
                i.display()
            )));
        }
        if outputs[k + 1..].iter().any(|o2| same(o2, o)) {
            return Err(invalid(format!(
                "{} is given as two different outputs",
                o.display()
            )));
        }
    }
    Ok(())
}
