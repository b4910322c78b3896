//! Grain dictionaries (`.grains`): decode; a decoded dictionary re-encodes and decodes again.
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
    let p = Path::new("fuzz.grains");
    if let Ok(d) = resound_io::grains_file::decode(data, p) {
        resound_io::grains_file::decode(&resound_io::grains_file::encode(&d), p)
            .expect("a decoded dictionary re-encodes");
    }
}
