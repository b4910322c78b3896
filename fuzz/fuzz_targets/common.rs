//! Shared by the file-reading targets: the readers take paths (they are what the CLI calls),
//! so each input is written to a per-process scratch file with the extension under test.

use std::path::PathBuf;

/// Writes `data` to `<tmp>/resound-fuzz-<pid>/input.<ext>` and returns the path.
pub fn scratch(ext: &str, data: &[u8]) -> PathBuf {
    let base = std::env::var_os("RESOUND_FUZZ_TMP")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir);
    let dir = base.join(format!("resound-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch directory");
    let path = dir.join(format!("input.{ext}"));
    std::fs::write(&path, data).expect("scratch file");
    path
}
