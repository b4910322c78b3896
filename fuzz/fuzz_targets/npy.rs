//! NumPy `.npy` surface profiles: parse; never a panic or an allocation the file cannot back.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(v) = resound_io::npy::parse_npy_f64(data) {
        // At least 4 bytes (float32) back every value.
        assert!(v.len() <= data.len() / 4 + 1);
    }
});
