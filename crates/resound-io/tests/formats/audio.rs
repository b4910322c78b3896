//! Audio decoding and writing.

use resound_io::{load_audio, write_wav, WavFormat};
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

fn tone(i: usize, fs: f64) -> f64 {
    let t = i as f64 / fs;
    0.5 * (-5.0 * t).exp() * (TAU * 1000.0 * t).sin()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn write_hound(path: &Path, bits: u16, float: bool, channels: u16, x: &[f64]) {
    let spec = hound::WavSpec {
        channels,
        sample_rate: 44100,
        bits_per_sample: bits,
        sample_format: if float {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let mut w = hound::WavWriter::create(path, spec).unwrap();
    for &v in x {
        for c in 0..channels {
            let v = if c == 1 { -v } else { v };
            if float {
                w.write_sample(v as f32).unwrap();
            } else {
                let full = ((1i64 << (bits - 1)) - 1) as f64;
                w.write_sample((v * full).round() as i32).unwrap();
            }
        }
    }
    w.finalize().unwrap();
}

/// A float64 WAV (format tag 3, 64 bits), which hound cannot write.
fn write_f64_wav(path: &Path, x: &[f64]) {
    let data_len = (x.len() * 8) as u32;
    let mut b = Vec::new();
    b.extend_from_slice(b"RIFF");
    b.extend_from_slice(&(36 + data_len).to_le_bytes());
    b.extend_from_slice(b"WAVEfmt ");
    b.extend_from_slice(&16u32.to_le_bytes());
    b.extend_from_slice(&3u16.to_le_bytes());
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&44100u32.to_le_bytes());
    b.extend_from_slice(&(44100u32 * 8).to_le_bytes());
    b.extend_from_slice(&8u16.to_le_bytes());
    b.extend_from_slice(&64u16.to_le_bytes());
    b.extend_from_slice(b"data");
    b.extend_from_slice(&data_len.to_le_bytes());
    for v in x {
        b.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, b).unwrap();
}

#[test]
fn wav_every_sample_format() {
    let dir = tempfile::tempdir().unwrap();
    let x: Vec<f64> = (0..4410).map(|i| tone(i, 44100.0)).collect();
    for (bits, float) in [
        (8, false),
        (16, false),
        (24, false),
        (32, false),
        (32, true),
    ] {
        let p = dir.path().join(format!("t{bits}{float}.wav"));
        write_hound(&p, bits, float, 1, &x);
        let clip = load_audio(&p).unwrap();
        assert_eq!(clip.sample_rate_hz, 44100);
        assert_eq!(clip.frames(), x.len());
        let step = if float {
            1e-7
        } else {
            1.0 / ((1i64 << (bits - 1)) - 1) as f64
        };
        for (a, b) in clip.channels[0].iter().zip(&x) {
            assert!(
                (f64::from(*a) - b).abs() <= 1.01 * step + 1e-7,
                "{bits} bit: {a} vs {b}"
            );
        }
    }
    let p = dir.path().join("f64.wav");
    write_f64_wav(&p, &x);
    let clip = load_audio(&p).unwrap();
    assert_eq!(clip.frames(), x.len());
    assert!(clip.channels[0]
        .iter()
        .zip(&x)
        .all(|(a, b)| (f64::from(*a) - b).abs() < 1e-7));
}

#[test]
fn stereo_mix_and_channel_pick() {
    let dir = tempfile::tempdir().unwrap();
    let x: Vec<f64> = (0..1000).map(|i| tone(i, 44100.0)).collect();
    let p = dir.path().join("st.wav");
    write_hound(&p, 32, true, 2, &x);
    let clip = load_audio(&p).unwrap();
    assert_eq!(clip.channels.len(), 2);
    // Channel 1 is the negated channel 0: the mix cancels.
    let mix = clip.mono(None, &p).unwrap();
    assert!(mix.iter().all(|v| v.abs() < 1e-7));
    let right = clip.mono(Some(1), &p).unwrap();
    assert!((right[100] + x[100]).abs() < 1e-6);
    let err = clip.mono(Some(2), &p).unwrap_err().to_string();
    assert!(err.contains("2 channel(s)"), "{err}");
}

fn correlation(a: &[f32], fs: f64, lag: usize) -> f64 {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (i, v) in a.iter().enumerate().skip(lag) {
        let r = tone(i - lag, fs);
        ab += f64::from(*v) * r;
        aa += f64::from(*v) * f64::from(*v);
        bb += r * r;
    }
    ab / (aa * bb).sqrt()
}

#[test]
fn flac_is_lossless() {
    let clip = load_audio(&fixture("tone.flac")).unwrap();
    assert_eq!(clip.sample_rate_hz, 44100);
    assert_eq!(clip.frames(), 13230);
    for (i, v) in clip.channels[0].iter().enumerate() {
        assert!(
            (f64::from(*v) - tone(i, 44100.0)).abs() < 1.5 / 32767.0,
            "sample {i}"
        );
    }
}

#[test]
fn vorbis_and_mp3_decode_to_the_tone() {
    for name in ["tone.ogg", "tone.mp3"] {
        let clip = load_audio(&fixture(name)).unwrap();
        assert_eq!(clip.sample_rate_hz, 44100, "{name}");
        let n = clip.frames();
        assert!((13230..13230 + 4000).contains(&n), "{name}: {n} frames");
        // Encoders add a delay (MP3: ~1100 samples); take the best lag.
        let best = (0..3000)
            .map(|lag| correlation(&clip.channels[0], 44100.0, lag))
            .fold(0.0, f64::max);
        assert!(best > 0.98, "{name}: correlation {best}");
    }
}

#[test]
fn bad_audio_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.wav");
    std::fs::write(&empty, b"").unwrap();
    assert!(load_audio(&empty).is_err());
    let junk = dir.path().join("junk.wav");
    std::fs::write(
        &junk,
        (0..5000u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let err = load_audio(&junk).unwrap_err().to_string();
    assert!(err.contains("junk.wav"), "{err}");
    // Truncated: the header promises more data than the file holds.
    let x: Vec<f64> = (0..44100).map(|i| tone(i, 44100.0)).collect();
    let full = dir.path().join("full.wav");
    write_hound(&full, 16, false, 1, &x);
    let bytes = std::fs::read(&full).unwrap();
    let cut = dir.path().join("cut.wav");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = load_audio(&cut).unwrap_err().to_string();
    assert!(err.contains("truncated"), "{err}");
    // Header only: no samples.
    let hdr = dir.path().join("hdr.wav");
    std::fs::write(&hdr, &bytes[..44]).unwrap();
    assert!(load_audio(&hdr).is_err());
    // NaN samples.
    let nan = dir.path().join("nan.wav");
    write_hound(&nan, 32, true, 1, &[0.1, f64::NAN, 0.2]);
    let err = load_audio(&nan).unwrap_err().to_string();
    assert!(err.contains("non-finite"), "{err}");
    // Missing file.
    assert!(load_audio(&dir.path().join("missing.wav")).is_err());
}

#[test]
fn wav_write_round_trip_is_atomic() {
    let dir = tempfile::tempdir().unwrap();
    let x: Vec<f32> = (0..2000).map(|i| tone(i, 48000.0) as f32).collect();
    for (fmt, tol) in [
        (WavFormat::Pcm16, 1.0 / 32768.0),
        (WavFormat::Pcm24, 1.0 / 8_388_608.0),
        (WavFormat::Float32, 0.0),
    ] {
        let p = dir.path().join("out.wav");
        write_wav(&p, &x, 48000, fmt).unwrap();
        let clip = load_audio(&p).unwrap();
        assert_eq!(clip.sample_rate_hz, 48000);
        assert_eq!(clip.frames(), x.len());
        for (a, b) in clip.channels[0].iter().zip(&x) {
            assert!((a - b).abs() <= tol as f32 * 0.51 + 1e-7, "{fmt:?}");
        }
    }
    // A refused write leaves nothing behind.
    let p = dir.path().join("bad.wav");
    assert!(write_wav(&p, &[0.0, f32::NAN], 48000, WavFormat::Float32).is_err());
    assert!(!p.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn material_library_round_trip() {
    use resound_core::SoundMaterial;
    use resound_io::library::{read_material, write_material, Library};
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("sub/materials.sqlite");
    let mut lib = Library::open(&db).unwrap();
    assert_eq!(
        lib.names().unwrap(),
        ["glass", "metal", "plastic", "porcelain", "wood"]
    );
    let wood = lib.get("wood").unwrap().unwrap();
    assert_eq!(wood.alpha, 2.1364);
    let oak = SoundMaterial::rayleigh("oak", 3.0, 2e-6, 7e5, 1e-6);
    lib.put(&oak).unwrap();
    drop(lib);
    // Reopening keeps what was written and does not seed again.
    let mut lib = Library::open(&db).unwrap();
    assert_eq!(lib.get("oak").unwrap().unwrap(), oak);
    assert_eq!(lib.names().unwrap().len(), 6);
    assert!(lib.remove("oak").unwrap());
    assert!(!lib.remove("oak").unwrap());
    assert!(lib.get("oak").unwrap().is_none());
    // Invalid materials are refused and leave the library unchanged.
    let bad = SoundMaterial {
        gamma: -1.0,
        ..oak.clone()
    };
    assert!(lib.put(&bad).is_err());
    assert_eq!(lib.names().unwrap().len(), 5);
    // Files.
    let f = dir.path().join("oak.json");
    write_material(&f, &oak).unwrap();
    assert_eq!(read_material(&f).unwrap(), oak);
    std::fs::write(&f, "{\"name\": \"x\"}").unwrap();
    assert!(read_material(&f)
        .unwrap_err()
        .to_string()
        .contains("not a material file"));
    // Not a library.
    let junk = dir.path().join("junk.sqlite");
    std::fs::write(&junk, vec![7u8; 4096]).unwrap();
    assert!(Library::open(&junk).is_err());
}

/// Issue 15: a WAV header that says 0 Hz (or 0 channels) made Symphonia panic in analyze,
/// estimate and grains.
#[test]
fn issue_15_a_wav_header_with_0_hz_or_0_channels_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    for (channels, rate) in [(1u16, 0u32), (0, 48_000)] {
        let data = [0u8; 2000];
        let mut fmt = Vec::new();
        fmt.extend_from_slice(&1u16.to_le_bytes()); // PCM
        fmt.extend_from_slice(&channels.to_le_bytes());
        fmt.extend_from_slice(&rate.to_le_bytes());
        fmt.extend_from_slice(&(rate * 2).to_le_bytes());
        fmt.extend_from_slice(&2u16.to_le_bytes());
        fmt.extend_from_slice(&16u16.to_le_bytes());
        let mut wav = b"RIFF".to_vec();
        wav.extend_from_slice(&((4 + 8 + fmt.len() + 8 + data.len()) as u32).to_le_bytes());
        wav.extend_from_slice(b"WAVEfmt ");
        wav.extend_from_slice(&(fmt.len() as u32).to_le_bytes());
        wav.extend_from_slice(&fmt);
        wav.extend_from_slice(b"data");
        wav.extend_from_slice(&(data.len() as u32).to_le_bytes());
        wav.extend_from_slice(&data);
        let p = dir.path().join("bad.wav");
        std::fs::write(&p, &wav).unwrap();
        let e = resound_io::load_audio(&p).unwrap_err().to_string();
        assert!(e.contains("WAV header"), "{e}");
    }
}

/// Fuzzing (`fuzz/`, target `audio`) found a WAVE_FORMAT_EXTENSIBLE header with 65 channels and
/// a 2-channel mask that overflows a shift inside Symphonia (a panic in debug builds, a wrong
/// mask in release). The crasher is kept as found (its first byte picked the extension).
#[test]
fn fuzz_audio_crash_83f2630f_a_channel_mask_that_cannot_be_completed_is_an_error() {
    let found = include_bytes!("fuzz/audio-crash-83f2630f.bin");
    let dir = tempfile::tempdir().unwrap();
    for ext in ["wav", "ogg"] {
        let p = dir.path().join(format!("crash.{ext}"));
        std::fs::write(&p, &found[1..]).unwrap();
        let e = resound_io::load_audio(&p).unwrap_err().to_string();
        assert!(e.contains("WAV header"), "{e}");
    }
    // The same shape with the mask's top bit set and one channel missing.
    let mut wav = found[1..].to_vec();
    // The crasher is "\0RIFF…": the format tag sits at 1 + 20.
    let fmt = 21;
    wav[fmt + 2..fmt + 4].copy_from_slice(&2u16.to_le_bytes());
    wav[fmt + 20..fmt + 24].copy_from_slice(&0x8000_0000u32.to_le_bytes());
    let p = dir.path().join("top.wav");
    std::fs::write(&p, &wav).unwrap();
    let e = resound_io::load_audio(&p).unwrap_err().to_string();
    assert!(e.contains("channel mask"), "{e}");
}

/// Fuzzing (`audio`) found a 900-byte file with a FLAC picture block whose media-type length
/// says 4 GiB: Symphonia allocated it before reading.
#[test]
fn fuzz_audio_oom_602fda4f_a_flac_picture_larger_than_its_block_is_an_error() {
    let found = include_bytes!("fuzz/audio-oom-602fda4f.bin");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("oom.ogg");
    std::fs::write(&p, &found[1..]).unwrap();
    let e = resound_io::load_audio(&p).unwrap_err().to_string();
    assert!(e.contains("picture block"), "{e}");
}

/// The same in a FLAC Vorbis-comment block (a 2 GiB comment length).
#[test]
fn fuzz_audio_oom_fc59051f_a_flac_comment_larger_than_its_block_is_an_error() {
    let found = include_bytes!("fuzz/audio-oom-fc59051f.bin");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("oom.flac");
    std::fs::write(&p, &found[1..]).unwrap();
    let e = resound_io::load_audio(&p).unwrap_err().to_string();
    assert!(e.contains("comment block"), "{e}");
}

/// The same guard for OGG Vorbis comment headers: a length that runs past the end of the file
/// is refused before Symphonia allocates it.
#[test]
fn a_vorbis_comment_length_past_the_end_of_the_file_is_an_error() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/recordings/default_dig_choppy.1.ogg");
    let mut ogg = std::fs::read(&path).unwrap();
    let at = ogg.windows(7).position(|w| w == b"\x03vorbis").unwrap() + 7;
    ogg[at..at + 4].copy_from_slice(&0x7fff_ffffu32.to_le_bytes());
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("lie.ogg");
    std::fs::write(&p, &ogg).unwrap();
    let e = resound_io::load_audio(&p).unwrap_err().to_string();
    assert!(e.contains("Vorbis comment"), "{e}");
    // The untouched file still decodes.
    assert!(resound_io::load_audio(&path).is_ok());
}
