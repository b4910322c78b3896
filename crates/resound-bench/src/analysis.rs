//! The analysis benchmark behind `resound bench analyze` (and, at reduced size, the tests).
//!
//! 1. Ren 2013's protocol: single damped sinusoids, f uniform in [20, 22000] Hz, d log-uniform
//!    in [0.1, 1000] 1/s, noise-free, 44.1 kHz, 1 s: mean relative error of f and d.
//! 2. Mixtures of 1–24 modes (f log-uniform in 60 Hz–18 kHz, at least 0.5 % apart; d log-uniform
//!    in 0.5–400 1/s, no two closer than the mean of their line widths (d/π); amplitudes uniform in dB over 0 to −50 dB; random phases) in white noise at
//!    a given SNR (total signal energy over 1 s / noise energy): recall of the modes within 40 dB
//!    of the strongest, fraction of spurious modes, and the median of |error| / Cramér–Rao bound
//!    of f and d over the recalled modes.
//! 3. Analysis time per second of audio.

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use resound_core::{damped::synthesize, DampedMode};
use resound_signal::analyze::{analyze, AnalyzeParams};
use resound_signal::crb::cramer_rao;
use serde::Serialize;
use std::time::Instant;

/// Result of the single-sinusoid protocol.
#[derive(Clone, Debug, Serialize)]
pub struct SingleReport {
    /// Signals analysed.
    pub trials: usize,
    /// Mean relative frequency error, percent.
    pub mean_freq_error_pct: f64,
    /// Mean relative damping error, percent.
    pub mean_damping_error_pct: f64,
    /// Largest relative frequency error, percent.
    pub max_freq_error_pct: f64,
    /// Largest relative damping error, percent.
    pub max_damping_error_pct: f64,
    /// Trials where no mode was found (counted as 100 % error).
    pub missed: usize,
    /// Analysis seconds per second of audio.
    pub seconds_per_audio_second: f64,
}

/// Result of the mixture protocol at one SNR.
#[derive(Clone, Debug, Serialize)]
pub struct MixtureReport {
    /// Signal-to-noise ratio, dB.
    pub snr_db: f64,
    /// Mixtures analysed.
    pub trials: usize,
    /// True modes within 40 dB of the strongest, in all.
    pub reference_modes: usize,
    /// Fraction of those found.
    pub recall: f64,
    /// Of those, the ones standing clearly above the noise (energy Σ s² ≥ 100 σ², a local
    /// SNR of 20 dB), and the fraction of them found.
    pub detectable_modes: usize,
    /// Recall over the detectable modes.
    pub recall_detectable: f64,
    /// Fraction of found modes that match no true mode.
    pub spurious: f64,
    /// Median over recalled modes of |f error| / CRB standard deviation of f.
    pub median_freq_error_over_crb: f64,
    /// Median over recalled modes of |d error| / CRB standard deviation of d.
    pub median_damping_error_over_crb: f64,
    /// Median over recalled modes of relative frequency error, percent.
    pub median_freq_error_pct: f64,
    /// Analysis seconds per second of audio.
    pub seconds_per_audio_second: f64,
}

const FS: f64 = 44100.0;

/// Runs protocol 1 with `trials` signals from `seed`.
pub fn single_sinusoids(trials: usize, seed: u64, params: &AnalyzeParams) -> SingleReport {
    let mut rng = SmallRng::seed_from_u64(seed);
    let n = FS as usize;
    let (mut ef, mut ed, mut mf, mut md, mut missed) = (0.0, 0.0, 0.0f64, 0.0f64, 0);
    let mut elapsed = 0.0;
    for _ in 0..trials {
        let truth = DampedMode {
            freq_hz: rng.random_range(20.0..22000.0),
            damping_per_s: 10f64.powf(rng.random_range(-1.0..3.0)),
            amplitude: 0.5,
            phase_rad: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        };
        let x = synthesize(&[truth], FS, n);
        let t0 = Instant::now();
        let res = analyze(&x, FS, params);
        elapsed += t0.elapsed().as_secs_f64();
        let best = res.ok().and_then(|a| {
            a.modes
                .into_iter()
                .max_by(|p, q| p.amplitude.total_cmp(&q.amplitude))
        });
        let (rf, rd) = match best {
            Some(m) => (
                (m.freq_hz / truth.freq_hz - 1.0).abs(),
                (m.damping_per_s / truth.damping_per_s - 1.0).abs(),
            ),
            None => {
                missed += 1;
                (1.0, 1.0)
            }
        };
        ef += rf;
        ed += rd;
        mf = mf.max(rf);
        md = md.max(rd);
    }
    let t = trials.max(1) as f64;
    SingleReport {
        trials,
        mean_freq_error_pct: 100.0 * ef / t,
        mean_damping_error_pct: 100.0 * ed / t,
        max_freq_error_pct: 100.0 * mf,
        max_damping_error_pct: 100.0 * md,
        missed,
        seconds_per_audio_second: elapsed / (t * n as f64 / FS),
    }
}

/// Draws one mixture of `k` modes.
pub fn random_mixture(rng: &mut SmallRng, k: usize) -> Vec<DampedMode> {
    let mut modes: Vec<DampedMode> = Vec::with_capacity(k);
    let mut guard = 0;
    while modes.len() < k && guard < 10_000 {
        guard += 1;
        let f = 60.0 * (18000.0f64 / 60.0).powf(rng.random_range(0.0..1.0));
        let d = 0.5 * 800f64.powf(rng.random_range(0.0..1.0));
        // Resolvable pairs only: 0.5 % apart and at least the mean of the two line widths
        // (FWHM d/π each).
        if modes.iter().any(|m| {
            let gap = (m.freq_hz - f).abs();
            gap < 0.005 * f || gap < (m.damping_per_s + d) / (2.0 * std::f64::consts::PI)
        }) {
            continue;
        }
        modes.push(DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: 0.3 * 10f64.powf(rng.random_range(-50.0..0.0) / 20.0),
            phase_rad: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        });
    }
    modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    modes
}

/// Runs protocol 2 at `snr_db` with `trials` mixtures from `seed`.
pub fn mixtures(snr_db: f64, trials: usize, seed: u64, params: &AnalyzeParams) -> MixtureReport {
    let mut rng = SmallRng::seed_from_u64(seed);
    let n = FS as usize;
    let (mut reference, mut recalled, mut found_total, mut spurious) =
        (0usize, 0usize, 0usize, 0usize);
    let (mut detectable, mut recalled_detectable) = (0usize, 0usize);
    let (mut rf, mut rd, mut pf) = (Vec::new(), Vec::new(), Vec::new());
    let mut elapsed = 0.0;
    for _ in 0..trials {
        let k = rng.random_range(1..=24);
        let truth = random_mixture(&mut rng, k);
        let clean = synthesize(&truth, FS, n);
        let energy: f64 = clean.iter().map(|v| v * v).sum();
        let sigma = (energy / n as f64 / 10f64.powf(snr_db / 10.0)).sqrt();
        let normal =
            Normal::new(0.0, sigma).unwrap_or_else(|_| Normal::new(0.0, 1e-12).expect("valid"));
        let x: Vec<f64> = clean.iter().map(|v| v + normal.sample(&mut rng)).collect();
        let t0 = Instant::now();
        let found = analyze(&x, FS, params).map(|a| a.modes).unwrap_or_default();
        elapsed += t0.elapsed().as_secs_f64();
        let bounds = cramer_rao(&truth, FS, n, sigma);
        let strongest = truth.iter().map(|m| m.amplitude).fold(0.0, f64::max);
        // Greedy matching: closest pairs first, each mode used once.
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (i, t) in truth.iter().enumerate() {
            let tol = bounds
                .as_ref()
                .map(|b| 10.0 * b[i].freq_hz)
                .unwrap_or(0.0)
                .max(2e-3 * t.freq_hz);
            for (j, f) in found.iter().enumerate() {
                let e = (f.freq_hz - t.freq_hz).abs();
                if e <= tol {
                    pairs.push((e / tol, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut t_used = vec![None; truth.len()];
        let mut f_used = vec![false; found.len()];
        for (_, i, j) in pairs {
            if t_used[i].is_none() && !f_used[j] {
                t_used[i] = Some(j);
                f_used[j] = true;
            }
        }
        found_total += found.len();
        spurious += f_used.iter().filter(|u| !**u).count();
        for (i, t) in truth.iter().enumerate() {
            if t.amplitude < strongest * 0.01 {
                continue;
            }
            reference += 1;
            let energy = t.amplitude
                * t.amplitude
                * FS
                * (-(-2.0 * t.damping_per_s * n as f64 / FS).exp_m1())
                / (4.0 * t.damping_per_s);
            let clear = energy >= 100.0 * sigma * sigma;
            detectable += usize::from(clear);
            if let Some(j) = t_used[i] {
                recalled += 1;
                recalled_detectable += usize::from(clear);
                let f = &found[j];
                if let Some(b) = bounds.as_ref() {
                    rf.push((f.freq_hz - t.freq_hz).abs() / b[i].freq_hz);
                    rd.push((f.damping_per_s - t.damping_per_s).abs() / b[i].damping_per_s);
                }
                pf.push(100.0 * (f.freq_hz / t.freq_hz - 1.0).abs());
            }
        }
    }
    MixtureReport {
        snr_db,
        trials,
        reference_modes: reference,
        recall: recalled as f64 / reference.max(1) as f64,
        detectable_modes: detectable,
        recall_detectable: recalled_detectable as f64 / detectable.max(1) as f64,
        spurious: spurious as f64 / found_total.max(1) as f64,
        median_freq_error_over_crb: median(&mut rf),
        median_damping_error_over_crb: median(&mut rd),
        median_freq_error_pct: median(&mut pf),
        seconds_per_audio_second: elapsed / (trials.max(1) as f64 * n as f64 / FS),
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
