//! Modal model files (`.rmodal`): decode; a decoded model re-encodes to a file that decodes
//! to the same model.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// The input with its trailing FNV-1a checksum recomputed, so mutations get past the check
/// and reach the decoder proper.
fn with_checksum(data: &[u8]) -> Vec<u8> {
    let mut v = data.to_vec();
    if v.len() >= 20 {
        let n = v.len() - 8;
        let mut h = resound_io::model_file::Fnv1a::new();
        h.write(&v[..n]);
        v[n..].copy_from_slice(&h.finish().to_le_bytes());
    }
    v
}

fuzz_target!(|data: &[u8]| {
    let repaired = with_checksum(data);
    for data in [data, repaired.as_slice()] {
        check(data);
    }
});

fn check(data: &[u8]) {
    let p = Path::new("fuzz.rmodal");
    if let Ok(m) = resound_io::model_file::decode(data, p) {
        let again = resound_io::model_file::decode(&resound_io::model_file::encode(&m), p)
            .expect("a decoded model re-encodes");
        assert_eq!(again.eigenvalues.len(), m.eigenvalues.len());
    }
}
