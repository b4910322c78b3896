//! The audio decoder front (`load_audio`: the WAV header pre-check, then Symphonia) on WAV,
//! FLAC, OGG and MP3; the first byte picks the extension. Errors are fine; panics, hangs and
//! unbounded memory are not. A decoded clip must be consistent.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let ext = ["wav", "flac", "ogg", "mp3"][usize::from(pick) % 4];
    let path = common::scratch(ext, rest);
    if let Ok(clip) = resound_io::load_audio(&path) {
        assert!(clip.sample_rate_hz > 0);
        assert!(!clip.channels.is_empty());
        let n = clip.channels[0].len();
        assert!(clip.channels.iter().all(|c| c.len() == n));
        let _ = clip.mono(None, &path);
    }
});
