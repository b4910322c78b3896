//! Scene files (TOML): parse and validate; never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = resound_io::scene::parse_scene(text, "fuzz.toml");
    }
});
