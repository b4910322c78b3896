//! Cramér–Rao bounds for damped sinusoids in white Gaussian noise.
//!
//! For `s(t) = Σ a_i e^(−d_i t) sin(ω_i t + θ_i)` observed at `t = n/fs`, `n = 0..N`, with noise
//! variance σ², the Fisher information is `F = Jᵀ J / σ²` where `J` holds the partial derivatives
//! of the samples with respect to (f_i, d_i, a_i, θ_i). The bound on each parameter's standard
//! deviation is `sqrt((F⁻¹)_kk)`. All modes are treated jointly, so close pairs get the larger
//! bounds they deserve.

use crate::refine::cholesky_solve;
use resound_core::DampedMode;

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
    let fim = fisher_information(modes, sample_rate_hz, n);
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

/// `JᵀJ` of `modes` over `n` samples in (f, d, a, θ) per mode, full and row-major: the
/// closed-form `JᵀJ` of the fit's (f, d, u = a cos θ, v = a sin θ) columns
/// ([`crate::refine::gram`], O(k² log N)), taken to (a, θ) by the chain rule
/// `F_aθ = Tᵀ F_uv T` with `T = ∂(u, v)/∂(a, θ)`.
fn fisher_information(modes: &[DampedMode], sample_rate_hz: f64, n: usize) -> Vec<f64> {
    let np = 4 * modes.len();
    let mut uv = vec![0.0; np * np];
    crate::refine::gram(&crate::refine::to_params(modes), n, sample_rate_hz, &mut uv);
    for a in 0..np {
        for b in 0..a {
            uv[a * np + b] = uv[b * np + a];
        }
    }
    // T: identity for f and d, [[cos θ, −a sin θ], [sin θ, a cos θ]] for (u, v) by (a, θ).
    let mut t = vec![0.0; np * np];
    for (j, m) in modes.iter().enumerate() {
        let o = 4 * j;
        let (s, c) = m.phase_rad.sin_cos();
        t[o * np + o] = 1.0;
        t[(o + 1) * np + o + 1] = 1.0;
        t[(o + 2) * np + o + 2] = c;
        t[(o + 2) * np + o + 3] = -m.amplitude * s;
        t[(o + 3) * np + o + 2] = s;
        t[(o + 3) * np + o + 3] = m.amplitude * c;
    }
    // Tᵀ F T, using T's block structure (two non-zeros or fewer per column within a block).
    let nz = |col: usize| -> Vec<(usize, f64)> {
        let o = col / 4 * 4;
        (o..o + 4)
            .filter(|&r| t[r * np + col] != 0.0)
            .map(|r| (r, t[r * np + col]))
            .collect()
    };
    let cols: Vec<Vec<(usize, f64)>> = (0..np).map(nz).collect();
    let mut ft = vec![0.0; np * np];
    for r in 0..np {
        for (c, col) in cols.iter().enumerate() {
            ft[r * np + c] = col.iter().map(|&(q, w)| uv[r * np + q] * w).sum();
        }
    }
    let mut out = vec![0.0; np * np];
    for (r, row) in cols.iter().enumerate() {
        for c in 0..np {
            out[r * np + c] = row.iter().map(|&(q, w)| w * ft[q * np + c]).sum();
        }
    }
    out
}

/// How sure one analysed mode is: standard deviations of its frequency and damping.
pub use resound_core::damped::ModeSigma;

/// The noise level near each frequency, from what a fit leaves: the standard deviation of
/// the white noise with the residual's mean power density within ±max(25 Hz, 2 %) of the
/// frequency. Rolling, rumble and a model that misses part of a mode make the noise coloured;
/// a bound at the broadband level would then be too tight where the residual is strong and
/// too loose where it is weak.
#[derive(Clone, Debug)]
pub struct NoiseProfile {
    /// Prefix sums of `|X_k|² / N` over the bins (white noise of variance σ² gives σ² a bin).
    cumulative: Vec<f64>,
    bin_hz: f64,
    white_rms: f64,
}

impl NoiseProfile {
    /// White noise of standard deviation `rms` at every frequency.
    pub fn white(rms: f64) -> Self {
        Self {
            cumulative: Vec::new(),
            bin_hz: 1.0,
            white_rms: rms,
        }
    }

    /// The profile of `residual` sampled at `sample_rate_hz`.
    pub fn of_residual(residual: &[f64], sample_rate_hz: f64) -> Self {
        let n = residual.len();
        let rms = crate::refine::robust_rms(residual);
        if n < 64 || !residual.iter().all(|v| v.is_finite()) {
            return Self::white(rms);
        }
        let mut planner = realfft::RealFftPlanner::<f64>::new();
        let fft = planner.plan_fft_forward(n);
        let mut input = residual.to_vec();
        let mut spectrum = fft.make_output_vec();
        if fft.process(&mut input, &mut spectrum).is_err() {
            return Self::white(rms);
        }
        let mut cumulative = Vec::with_capacity(spectrum.len() + 1);
        cumulative.push(0.0);
        let mut acc = 0.0;
        for z in &spectrum {
            acc += z.norm_sqr() / n as f64;
            cumulative.push(acc);
        }
        Self {
            cumulative,
            bin_hz: sample_rate_hz / n as f64,
            white_rms: rms,
        }
    }

    /// The noise's standard deviation as seen near `freq_hz`.
    pub fn rms_at(&self, freq_hz: f64) -> f64 {
        let bins = self.cumulative.len().saturating_sub(1);
        if bins < 2 || !freq_hz.is_finite() {
            return self.white_rms;
        }
        let half = (0.02 * freq_hz).max(25.0);
        let lo = (((freq_hz - half) / self.bin_hz).floor().max(0.0) as usize).min(bins - 1);
        let hi = (((freq_hz + half) / self.bin_hz).ceil().max(0.0) as usize).clamp(lo + 1, bins);
        let mean = (self.cumulative[hi] - self.cumulative[lo]) / (hi - lo) as f64;
        if mean > 0.0 && mean.is_finite() {
            mean.sqrt()
        } else {
            self.white_rms
        }
    }
}

/// Longest group of overlapping modes bounded jointly (4 parameters each); a longer run of
/// overlapping modes is cut into groups of this size (the cut ignores a little coupling).
const MAX_GROUP: usize = 6;

/// The Cramér–Rao bound of each of `modes` over `n` samples at `sample_rate_hz` with the noise
/// `noise` has near each group of modes (the loudest of the group's levels): every mode is bounded jointly with the modes whose peaks
/// overlap its own (closer than three resolution widths `1/T` plus both half-power bandwidths),
/// so an isolated mode gets its single-mode bound and a close pair the larger bound it has.
/// The result is parallel to `modes`; a singular group (two identical modes) gives `None`s.
pub fn mode_sigmas(
    modes: &[DampedMode],
    sample_rate_hz: f64,
    n: usize,
    noise: &NoiseProfile,
) -> Vec<Option<ModeSigma>> {
    let mut out = vec![None; modes.len()];
    if n == 0 {
        return out;
    }
    let mut order: Vec<usize> = (0..modes.len()).collect();
    order.sort_by(|&a, &b| modes[a].freq_hz.total_cmp(&modes[b].freq_hz));
    let resolution_hz = sample_rate_hz / n as f64;
    let overlaps = |a: &DampedMode, b: &DampedMode| {
        (b.freq_hz - a.freq_hz).abs()
            < 3.0 * resolution_hz + (a.damping_per_s + b.damping_per_s) / std::f64::consts::PI
    };
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len()
            && end - start < MAX_GROUP
            && overlaps(&modes[order[end - 1]], &modes[order[end]])
        {
            end += 1;
        }
        let group: Vec<DampedMode> = order[start..end].iter().map(|&i| modes[i]).collect();
        let noise_rms = group
            .iter()
            .map(|m| noise.rms_at(m.freq_hz))
            .fold(0.0, f64::max);
        if !(noise_rms.is_finite() && noise_rms >= 0.0) {
            start = end;
            continue;
        }
        if let Some(b) = cramer_rao(&group, sample_rate_hz, n, noise_rms) {
            for (k, &i) in order[start..end].iter().enumerate() {
                out[i] = Some(ModeSigma {
                    freq_hz: b[k].freq_hz,
                    damping_per_s: b[k].damping_per_s,
                });
            }
        }
        start = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::sigma_tests::mode;
    use super::*;
    use std::f64::consts::TAU;

    /// `JᵀJ` in (f, d, a, θ) summed sample by sample from the analytic derivatives of
    /// `a e^(−dt) sin(ωt + θ)`: the reference the closed form must equal.
    fn fisher_by_samples(modes: &[DampedMode], fs: f64, n: usize) -> Vec<f64> {
        let np = 4 * modes.len();
        let mut fim = vec![0.0; np * np];
        let mut g = vec![0.0; np];
        for i in 0..n {
            let t = i as f64 / fs;
            for (j, m) in modes.iter().enumerate() {
                let e = (-m.damping_per_s * t).exp();
                let (s, c) = (TAU * m.freq_hz * t + m.phase_rad).sin_cos();
                g[4 * j] = m.amplitude * e * c * TAU * t;
                g[4 * j + 1] = -t * m.amplitude * e * s;
                g[4 * j + 2] = e * s;
                g[4 * j + 3] = m.amplitude * e * c;
            }
            for a in 0..np {
                for b in 0..np {
                    fim[a * np + b] += g[a] * g[b];
                }
            }
        }
        fim
    }

    #[test]
    fn closed_form_fisher_information_equals_the_sum_over_samples() {
        let fs = 8000.0;
        let n = 6000;
        // A lightly damped close pair, a heavily damped mode and one near Nyquist.
        let modes = [
            mode(440.0, 0.3, 1.0),
            DampedMode {
                phase_rad: 2.1,
                ..mode(440.4, 0.5, 0.3)
            },
            DampedMode {
                phase_rad: -1.2,
                ..mode(1250.0, 300.0, 2.0)
            },
            mode(3990.0, 12.0, 0.05),
        ];
        let want = fisher_by_samples(&modes, fs, n);
        let got = fisher_information(&modes, fs, n);
        let np = 16;
        for a in 0..np {
            for b in 0..np {
                let scale = (want[a * np + a] * want[b * np + b]).sqrt();
                let err = (got[a * np + b] - want[a * np + b]).abs() / scale;
                assert!(
                    err < 1e-8,
                    "F[{a}][{b}]: {} vs {}",
                    got[a * np + b],
                    want[a * np + b]
                );
            }
        }
    }

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

#[cfg(test)]
mod sigma_tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A mode at phase 0.4 rad.
    pub(super) fn mode(f: f64, d: f64, a: f64) -> DampedMode {
        DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: a,
            phase_rad: 0.4,
        }
    }

    #[test]
    fn isolated_modes_get_their_single_mode_bound_and_a_close_pair_a_larger_one() {
        let (fs, n, noise) = (44_100.0, 44_100, 1e-3);
        let modes = [mode(440.0, 3.0, 0.5), mode(2000.0, 20.0, 0.2)];
        let s = mode_sigmas(&modes, fs, n, &NoiseProfile::white(noise));
        for (m, s) in modes.iter().zip(&s) {
            let alone = cramer_rao(&[*m], fs, n, noise).unwrap()[0];
            let s = s.expect("a bound");
            assert!((s.freq_hz - alone.freq_hz).abs() <= 1e-9 * alone.freq_hz);
            assert!((s.damping_per_s - alone.damping_per_s).abs() <= 1e-9 * alone.damping_per_s);
        }
        // A partner 0.5 Hz away (inside the 1 Hz resolution) makes both harder to pin down.
        let pair = [mode(440.0, 3.0, 0.5), mode(440.5, 3.0, 0.5)];
        let p = mode_sigmas(&pair, fs, n, &NoiseProfile::white(noise));
        assert!(
            p[0].unwrap().freq_hz > 3.0 * s[0].unwrap().freq_hz,
            "{p:?} vs {s:?}"
        );
        // The phasor recursion agrees with the direct formula: the bound scales with the noise.
        let twice = mode_sigmas(&modes, fs, n, &NoiseProfile::white(2.0 * noise));
        assert!((twice[0].unwrap().freq_hz / s[0].unwrap().freq_hz - 2.0).abs() < 1e-9);
        // Two identical modes are singular: no bound rather than a made-up one.
        assert!(
            mode_sigmas(&[modes[0], modes[0]], fs, n, &NoiseProfile::white(noise))[0].is_none()
        );
    }

    /// The σ the analysis reports is what its errors scatter by: over noisy takes of one mode,
    /// the spread of the fitted f and d is within a factor 2.5 of the reported σ (the bound is
    /// reached by a good estimator, and a reported σ 10× too small or too large fails).
    #[test]
    fn reported_sigma_matches_the_scatter_of_the_analysis() {
        let fs = 44_100.0;
        let n = 22_050;
        let truth = mode(1234.5, 12.0, 0.3);
        let mut rng = rand::rngs::SmallRng::seed_from_u64(11);
        let normal = Normal::new(0.0, 3e-3).unwrap();
        let (mut ef, mut ed, mut sf, mut sd) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for _ in 0..12 {
            let mut x = vec![0.0; 2205];
            x.extend((0..n).map(|i| truth.value(i as f64 / fs)));
            for v in &mut x {
                *v += normal.sample(&mut rng);
            }
            let a = crate::analyze(&x, fs, &Default::default()).expect("analysis");
            let (k, m) = a
                .modes
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    (a.1.freq_hz - truth.freq_hz)
                        .abs()
                        .total_cmp(&(b.1.freq_hz - truth.freq_hz).abs())
                })
                .expect("a mode");
            let s = a.sigma[k].expect("a bound");
            ef.push(m.freq_hz - truth.freq_hz);
            ed.push(m.damping_per_s - truth.damping_per_s);
            sf.push(s.freq_hz);
            sd.push(s.damping_per_s);
        }
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (rf, rd) = (rms(&ef) / mean(&sf), rms(&ed) / mean(&sd));
        eprintln!("error rms / σ: f {rf:.2}, d {rd:.2}");
        assert!((0.4..2.5).contains(&rf), "f error rms / σ = {rf}");
        assert!((0.4..2.5).contains(&rd), "d error rms / σ = {rd}");
    }
}
