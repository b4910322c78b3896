//! Modal model files (`.rmodal`): decode; a decoded model re-encodes to a file that decodes
//! to the same model.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let p = Path::new("fuzz.rmodal");
    if let Ok(m) = resound_io::model_file::decode(data, p) {
        let again = resound_io::model_file::decode(&resound_io::model_file::encode(&m), p)
            .expect("a decoded model re-encodes");
        assert_eq!(again.eigenvalues.len(), m.eigenvalues.len());
    }
});
