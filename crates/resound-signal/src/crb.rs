//! Cramér–Rao bounds for damped sinusoids in white Gaussian noise.
//!
//! For `s(t) = Σ a_i e^(−d_i t) sin(ω_i t + θ_i)` observed at `t = n/fs`, `n = 0..N`, with noise
//! variance σ², the Fisher information is `F = Jᵀ J / σ²` where `J` holds the partial derivatives
//! of the samples with respect to (f_i, d_i, a_i, θ_i). The bound on each parameter's standard
//! deviation is `sqrt((F⁻¹)_kk)`. All modes are treated jointly, so close pairs get the larger
//! bounds they deserve.

use crate::refine::cholesky_solve;
use resound_core::DampedMode;
use std::f64::consts::TAU;

/// Standard-deviation bounds of one mode's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeBound {
    /// Bound on the frequency, Hz.
    pub freq_hz: f64,
    /// Bound on the damping, 1/s.
    pub damping_per_s: f64,
    /// Bound on the amplitude.
    pub amplitude: f64,
    /// Bound on the phase, rad.
    pub phase_rad: f64,
}

/// Cramér–Rao bounds of all `modes` jointly over `n` samples with noise standard deviation
/// `noise_rms`. Returns `None` when the Fisher information is singular (e.g. two identical modes).
pub fn cramer_rao(
    modes: &[DampedMode],
    sample_rate_hz: f64,
    n: usize,
    noise_rms: f64,
) -> Option<Vec<ModeBound>> {
    let k = modes.len();
    let np = 4 * k;
    let mut fim = vec![0.0; np * np];
    let mut g = vec![0.0; np];
    // Samples beyond where every mode is below 1e-9 of its amplitude add nothing measurable.
    let t_end = modes
        .iter()
        .map(|m| m.time_to_floor_s(1e-9 * m.amplitude))
        .fold(0.0, f64::max);
    let n_used = n.min((t_end * sample_rate_hz).ceil() as usize + 1);
    for i in 0..n_used {
        let t = i as f64 / sample_rate_hz;
        for (j, m) in modes.iter().enumerate() {
            let e = (-m.damping_per_s * t).exp();
            let (s, c) = (TAU * m.freq_hz * t + m.phase_rad).sin_cos();
            g[4 * j] = m.amplitude * e * c * TAU * t;
            g[4 * j + 1] = -t * m.amplitude * e * s;
            g[4 * j + 2] = e * s;
            g[4 * j + 3] = m.amplitude * e * c;
        }
        for a in 0..np {
            for b in a..np {
                fim[a * np + b] += g[a] * g[b];
            }
        }
    }
    for a in 0..np {
        for b in 0..a {
            fim[a * np + b] = fim[b * np + a];
        }
    }
    // Invert column by column (F is small: 4 per mode).
    let scale = noise_rms * noise_rms;
    let mut diag = vec![0.0; np];
    for col in 0..np {
        let mut e = vec![0.0; np];
        e[col] = 1.0;
        let mut a = fim.clone();
        let x = cholesky_solve(&mut a, &e, np)?;
        diag[col] = (x[col] * scale).sqrt();
    }
    Some(
        diag.chunks(4)
            .map(|d| ModeBound {
                freq_hz: d[0],
                damping_per_s: d[1],
                amplitude: d[2],
                phase_rad: d[3],
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_undamped_tone_matches_textbook_bound() {
        // For an undamped tone the frequency bound (rad/sample) is ≈ sqrt(24 σ² / (A² N³))
        // when the damping is also estimated it grows; with tiny damping in a short record the
        // classic 12/(A²N³)·σ² bound for (ω, a, θ) is approached up to the damping coupling.
        let fs = 1000.0;
        let n = 1000;
        let m = DampedMode {
            freq_hz: 123.0,
            damping_per_s: 1e-6,
            amplitude: 1.0,
            phase_rad: 0.3,
        };
        let b = cramer_rao(&[m], fs, n, 0.01).unwrap();
        let sigma2 = 1e-4;
        let classic = (12.0 * sigma2 * 2.0 / (n as f64).powi(3)).sqrt() * fs / TAU;
        // Estimating d as well raises the frequency bound by a factor between 1 and 2.
        assert!(
            b[0].freq_hz >= 0.99 * classic && b[0].freq_hz < 2.0 * classic,
            "{} vs {classic}",
            b[0].freq_hz
        );
        // Amplitude bound of a tone with unknown decay: of order σ·sqrt(2/N)·2.
        assert!(
            b[0].amplitude > 0.01 * (2.0 / n as f64).sqrt()
                && b[0].amplitude < 0.01 * (2.0 / n as f64).sqrt() * 3.0
        );
    }
}
