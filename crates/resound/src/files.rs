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
            source: e,
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
    let s: ModeStatistics = serde_json::from_str(&read_text(path)?)
        .map_err(|e| invalid(format!("{}: not a statistics file: {e}", path.display())))?;
    let dim = 3 * s.modes;
    if s.modes == 0 || s.mean.len() != dim || s.covariance.len() != dim * dim {
        return Err(invalid(format!(
            "{}: inconsistent statistics ({} modes)",
            path.display(),
            s.modes
        )));
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
