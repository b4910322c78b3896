//! The `.grains` dictionary file: grains and correlation patterns (Picard 2009 §5.1).
//!
//! Little-endian binary, version 1:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `RSGRAIN\0` |
//! | 4 | format version (u32) = 1 |
//! | 8 | sample rate (f64, Hz) |
//! | 4 + n | recordings as JSON (`[{name, contact, samples}]`, u32 length) |
//! | 4 | grains G (u32) |
//! | 24 G | per grain: part (u8: 0 impulsive, 1 sinusoidal, 2 transient), onset (u8), 2 zero bytes, recording, start, length, fade-in, fade-out (u32) |
//! | 4 G | per grain: its scale (f32): sample = i16 · scale |
//! | 2 Σ length | grain samples (i16) |
//! | 4 | patterns P (u32) |
//! | per pattern | recording (u32), part (u8), 3 zero bytes, length (u32), peaks k (u32), then k × (grain u32, time u32, correlation f32, gain f32) |
//! | 8 | FNV-1a 64 checksum of all preceding bytes |
//!
//! Grains are stored as 16-bit PCM with one scale per grain (the loudest sample maps to
//! 32767), as Picard counts the grain bytes of 16-bit assets.

use crate::atomic::write_atomic;
use crate::model_file::{fnv1a, open};
use crate::{parse_err, Result};
use resound_grains::{Dictionary, Grain, Part, Pattern, Peak, RecordingInfo};
use std::path::Path;

const MAGIC: &[u8; 8] = b"RSGRAIN\0";
/// Current format version.
pub const VERSION: u32 = 1;

fn part_code(p: Part) -> u8 {
    match p {
        Part::Impulsive => 0,
        Part::Sinusoidal => 1,
        Part::Transient => 2,
    }
}

fn part_of(c: u8) -> Option<Part> {
    match c {
        0 => Some(Part::Impulsive),
        1 => Some(Part::Sinusoidal),
        2 => Some(Part::Transient),
        _ => None,
    }
}

/// Encodes a dictionary (grains quantized to 16 bits).
pub fn encode(d: &Dictionary) -> Vec<u8> {
    let mut b = Vec::with_capacity(64 + d.grain_bytes() + d.pattern_bytes() + 28 * d.grains.len());
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&VERSION.to_le_bytes());
    b.extend_from_slice(&d.sample_rate_hz.to_le_bytes());
    let json = serde_json::to_vec(&d.recordings).unwrap_or_default();
    b.extend_from_slice(&(json.len() as u32).to_le_bytes());
    b.extend_from_slice(&json);
    b.extend_from_slice(&(d.grains.len() as u32).to_le_bytes());
    for g in &d.grains {
        b.extend_from_slice(&[part_code(g.part), u8::from(g.onset), 0, 0]);
        for x in [
            g.recording,
            g.start,
            g.samples.len() as u32,
            g.fade_in,
            g.fade_out,
        ] {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    let scales: Vec<f32> = d
        .grains
        .iter()
        .map(|g| g.samples.iter().fold(0.0f32, |m, v| m.max(v.abs())) / 32767.0)
        .collect();
    for s in &scales {
        b.extend_from_slice(&s.to_le_bytes());
    }
    for (g, &s) in d.grains.iter().zip(&scales) {
        let inv = if s > 0.0 { 1.0 / s } else { 0.0 };
        for &v in &g.samples {
            let q = (v * inv).round().clamp(-32767.0, 32767.0) as i16;
            b.extend_from_slice(&q.to_le_bytes());
        }
    }
    b.extend_from_slice(&(d.patterns.len() as u32).to_le_bytes());
    for p in &d.patterns {
        b.extend_from_slice(&p.recording.to_le_bytes());
        b.extend_from_slice(&[part_code(p.part), 0, 0, 0]);
        b.extend_from_slice(&p.len.to_le_bytes());
        b.extend_from_slice(&(p.peaks.len() as u32).to_le_bytes());
        for k in &p.peaks {
            b.extend_from_slice(&k.grain.to_le_bytes());
            b.extend_from_slice(&k.time.to_le_bytes());
            b.extend_from_slice(&k.corr.to_le_bytes());
            b.extend_from_slice(&k.gain.to_le_bytes());
        }
    }
    let h = fnv1a(&b);
    b.extend_from_slice(&h.to_le_bytes());
    b
}

fn f32_of(s: &[u8]) -> f32 {
    f32::from_le_bytes(s.try_into().unwrap_or([0; 4]))
}

fn u32_of(s: &[u8]) -> u32 {
    u32::from_le_bytes(s.try_into().unwrap_or([0; 4]))
}

/// Decodes a dictionary; `path` is for messages.
///
/// # Errors
/// [`crate::IoError::Parse`] for a wrong magic, unknown version, truncation, checksum mismatch
/// or an inconsistent dictionary.
pub fn decode(data: &[u8], path: &Path) -> Result<Dictionary> {
    let bad = |m: &str| parse_err(path, format!("grain dictionary: {m}"));
    let mut r = open(data, MAGIC, VERSION, "not a .grains file (bad magic)", &bad)?;
    let body_len = data.len() - 8;
    let trunc = || bad("truncated");
    let sample_rate_hz = r.f64s(1).ok_or_else(trunc)?[0];
    let jlen = r.u32().ok_or_else(trunc)? as usize;
    let recordings: Vec<RecordingInfo> = serde_json::from_slice(r.take(jlen).ok_or_else(trunc)?)
        .map_err(|e| bad(&format!("recording list: {e}")))?;
    let ng = r.u32().ok_or_else(trunc)? as usize;
    let heads = r
        .take(ng.checked_mul(24).ok_or_else(trunc)?)
        .ok_or_else(trunc)?;
    let scales = r.take(ng * 4).ok_or_else(trunc)?;
    let mut grains = Vec::with_capacity(ng);
    for (i, h) in heads.chunks_exact(24).enumerate() {
        let part =
            part_of(h[0]).ok_or_else(|| bad(&format!("grain {i}: unknown kind {}", h[0])))?;
        let len = u32_of(&h[12..16]) as usize;
        let scale = f32_of(&scales[4 * i..4 * i + 4]);
        let raw = r
            .take(len.checked_mul(2).ok_or_else(trunc)?)
            .ok_or_else(trunc)?;
        grains.push(Grain {
            samples: raw
                .chunks_exact(2)
                .map(|c| f32::from(i16::from_le_bytes([c[0], c[1]])) * scale)
                .collect(),
            part,
            recording: u32_of(&h[4..8]),
            start: u32_of(&h[8..12]),
            fade_in: u32_of(&h[16..20]),
            fade_out: u32_of(&h[20..24]),
            onset: h[1] != 0,
        });
    }
    let np = r.u32().ok_or_else(trunc)? as usize;
    let mut patterns = Vec::with_capacity(np.min(1 << 20));
    for i in 0..np {
        let head = r.take(16).ok_or_else(trunc)?;
        let part = part_of(head[4])
            .ok_or_else(|| bad(&format!("pattern {i}: unknown kind {}", head[4])))?;
        let k = u32_of(&head[12..16]) as usize;
        let raw = r
            .take(k.checked_mul(16).ok_or_else(trunc)?)
            .ok_or_else(trunc)?;
        patterns.push(Pattern {
            recording: u32_of(&head[0..4]),
            part,
            len: u32_of(&head[8..12]),
            peaks: raw
                .chunks_exact(16)
                .map(|c| Peak {
                    grain: u32_of(&c[0..4]),
                    time: u32_of(&c[4..8]),
                    corr: f32_of(&c[8..12]),
                    gain: f32_of(&c[12..16]),
                })
                .collect(),
        });
    }
    if r.p != body_len {
        return Err(bad("trailing bytes"));
    }
    let d = Dictionary {
        sample_rate_hz,
        recordings,
        grains,
        patterns,
    };
    d.validate().map_err(|e| bad(&e.to_string()))?;
    Ok(d)
}

/// Writes a dictionary atomically; returns its size in bytes.
///
/// # Errors
/// [`crate::IoError::Io`] when the file cannot be written.
pub fn save(path: &Path, d: &Dictionary) -> Result<usize> {
    let bytes = encode(d);
    write_atomic(path, |w| w.write_all(&bytes))?;
    Ok(bytes.len())
}

/// Reads a dictionary.
///
/// # Errors
/// [`crate::IoError::Io`] when the file cannot be read, [`crate::IoError::Parse`] when it is not
/// a valid dictionary.
pub fn load(path: &Path) -> Result<Dictionary> {
    let data = std::fs::read(path).map_err(|e| crate::io_err(path, e))?;
    decode(&data, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_grains::{Contact, Recording};

    fn dict() -> Dictionary {
        let x: Vec<f32> = (0..20_000)
            .map(|i| {
                let t = i as f32 / 44_100.0;
                let k = i % 5000;
                (0.5 * (-(k as f32) / 400.0).exp() * (6283.0 * t * (1.0 + (i / 5000) as f32)).sin())
                    .clamp(-1.0, 1.0)
            })
            .collect();
        resound_grains::analyze(
            &[Recording {
                name: "knocks".into(),
                contact: Contact::Impact,
                samples: x,
            }],
            44_100.0,
            &Default::default(),
            &|_| {},
        )
        .expect("analysis")
        .0
    }

    #[test]
    fn round_trip_within_16_bits() {
        let d = dict();
        let bytes = encode(&d);
        let back = decode(&bytes, Path::new("x.grains")).expect("decode");
        assert_eq!(back.recordings, d.recordings);
        assert_eq!(back.patterns, d.patterns);
        assert_eq!(back.grains.len(), d.grains.len());
        for (a, b) in back.grains.iter().zip(&d.grains) {
            let peak = b.samples.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            assert!(a
                .samples
                .iter()
                .zip(&b.samples)
                .all(|(x, y)| (x - y).abs() <= peak / 32767.0));
            assert_eq!(
                (a.start, a.fade_in, a.fade_out, a.onset),
                (b.start, b.fade_in, b.fade_out, b.onset)
            );
        }
    }

    #[test]
    fn corrupt_and_truncated_files_are_refused() {
        let bytes = encode(&dict());
        let p = Path::new("x.grains");
        for cut in [0, 7, 20, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut], p).is_err(), "cut at {cut}");
        }
        let mut flipped = bytes.clone();
        flipped[bytes.len() / 3] ^= 0x40;
        let e = decode(&flipped, p).expect_err("corrupt").to_string();
        assert!(e.contains("checksum"), "{e}");
    }
}
