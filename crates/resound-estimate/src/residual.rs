//! Ren 2013 §6.1: the residual of a recording — what it holds beyond what the estimated modes
//! represent.
//!
//! Each reference mode (feature) of the recording is weighted by how well the estimated modes
//! represent it (its point-to-set match ratio R_i, eq. 24): the represented sound is
//! `Σ R_i · feature_i` (amplitudes weighted, synthesized exactly). The residual power is
//! `max(P_rec − P_rep − 2 N, 0)` per STFT cell, where `N` is the recording's steady noise per bin
//! (its 10th percentile over frames; a room's hiss is not part of the object and must not follow
//! every synthesized hit). It is stored as audio — magnitudes with the recording's phases, inverse
//! STFT — trimmed where it has decayed by 60 dB: Algorithm 1's input (the transfer, in
//! `resound-synth`) is residual audio.

use crate::features::represented_ratios;
use realfft::num_complex::Complex32;
use resound_core::damped::synthesize;
use resound_core::{DampedMode, Residual};
use resound_signal::sine_stft::{window_len_for, Stft};

/// Computes the residual of `recording` (onset-aligned, full scale = 1) against its analysed
/// `reference` modes and the `estimated` modes of the material on the recorded object at the
/// recorded hit (see the module docs).
pub fn compute_residual(
    recording: &[f64],
    sample_rate_hz: f64,
    reference: &[DampedMode],
    estimated: &[DampedMode],
) -> Residual {
    let mut stft = Stft::new(window_len_for(sample_rate_hz));
    let n = recording.len();
    let x: Vec<f32> = recording.iter().map(|&v| v as f32).collect();
    let ratios = represented_ratios(reference, estimated);
    let represented: Vec<DampedMode> = reference
        .iter()
        .zip(&ratios)
        .map(|(m, r)| DampedMode {
            amplitude: m.amplitude * r,
            ..*m
        })
        .collect();
    let rep: Vec<f32> = synthesize(&represented, sample_rate_hz, n)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let (mut sx, mut sr) = (Vec::new(), Vec::new());
    stft.forward(&x, &mut sx);
    stft.forward(&rep, &mut sr);
    let bins = stft.bins();
    let frames = sx.len() / bins;
    // Steady noise per bin: the 10th percentile over frames.
    let noise: Vec<f32> = (0..bins)
        .map(|k| {
            let mut p: Vec<f32> = (0..frames).map(|m| sx[m * bins + k].norm_sqr()).collect();
            if p.len() < 10 {
                return 0.0;
            }
            let i = p.len() / 10;
            *p.select_nth_unstable_by(i, f32::total_cmp).1
        })
        .collect();
    let cells: Vec<Complex32> = sx
        .iter()
        .zip(&sr)
        .enumerate()
        .map(|(i, (c, r))| {
            let p = (c.norm_sqr() - r.norm_sqr() - 2.0 * noise[i % bins]).max(0.0);
            let n = c.norm();
            if n > 0.0 {
                *c * (p.sqrt() / n)
            } else {
                Complex32::new(0.0, 0.0)
            }
        })
        .collect();
    // Trim frames after the residual has decayed by 60 dB.
    let energy: Vec<f32> = (0..frames)
        .map(|m| {
            cells[m * bins..(m + 1) * bins]
                .iter()
                .map(|c| c.norm_sqr())
                .sum()
        })
        .collect();
    let peak = energy.iter().copied().fold(0.0f32, f32::max);
    let last = energy
        .iter()
        .rposition(|&e| e > 1e-6 * peak)
        .map_or(0, |m| m + 1);
    let samples = (last * stft.hop()).min(n);
    let mut out = Vec::new();
    stft.inverse(&cells, n, &mut out);
    out.truncate(samples);
    // A short fade-out where it was cut.
    let fade = (stft.hop()).min(out.len());
    let len = out.len();
    for (i, v) in out[len - fade..].iter_mut().enumerate() {
        *v *= 1.0 - (i as f32 + 1.0) / fade as f32;
    }
    Residual {
        sample_rate_hz,
        samples: out,
        source_modes: estimated.to_vec(),
    }
}
