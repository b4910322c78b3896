//! Shared by the targets: the readers take paths (they are what the CLI calls), so each input
//! is written to a per-process scratch file with the extension under test; the checksummed
//! formats get their checksum repaired. Each target uses part of it.
#![allow(dead_code)]

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

/// The input with its trailing FNV-1a checksum recomputed, so mutations get past the check
/// and reach the decoder proper.
pub fn with_checksum(data: &[u8]) -> Vec<u8> {
    let mut v = data.to_vec();
    if v.len() >= 20 {
        let n = v.len() - 8;
        let mut h = resound_io::model_file::Fnv1a::new();
        h.write(&v[..n]);
        v[n..].copy_from_slice(&h.finish().to_le_bytes());
    }
    v
}
