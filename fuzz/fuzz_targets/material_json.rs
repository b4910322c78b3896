//! Material files (JSON): a file that reads is valid, writes, and reads back equal.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let path = common::scratch("json", data);
    if let Ok(m) = resound_io::library::read_material(&path) {
        assert!(m.validate().is_ok());
        let out = path.with_file_name("roundtrip.json");
        resound_io::library::write_material(&out, &m).expect("a valid material writes");
        let back = resound_io::library::read_material(&out).expect("and reads back");
        assert_eq!(
            serde_json::to_value(&back).ok(),
            serde_json::to_value(&m).ok()
        );
    }
});
