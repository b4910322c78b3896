//! Modal model files (`.rmodal`): decode; a decoded model re-encodes to a file that decodes
//! to the same model.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let repaired = common::with_checksum(data);
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
        assert_eq!(again.shapes.len(), m.shapes.len());
        assert!(again.eigenvalues.iter().zip(&m.eigenvalues).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}
