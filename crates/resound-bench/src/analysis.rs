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

/// What the wide protocol (4) draws: the whole range users meet.
///
/// 1–24 modes, f log-uniform in 20 Hz–22 kHz at 48 kHz, d log-uniform in 0.1–1000 1/s (Ren's
/// single-mode range), amplitudes uniform in dB over 0 to −60 dB; with probability 0.25 a mode
/// gets a doublet partner 0.05–0.5 % above it with the same d and an amplitude within 6 dB;
/// other modes are at least 0.5 % and one mean line width apart. The strike starts after a
/// lead-in of 0.05–1 s that holds the same white noise as the rest of the file and a DC offset of
/// up to ±0.002 full scale on the whole file; 1 s follows the onset.
#[derive(Clone, Debug)]
pub struct WideCase {
    /// True modes (t = 0 at the onset).
    pub modes: Vec<DampedMode>,
    /// The recording: lead-in, then the strike.
    pub signal: Vec<f64>,
    /// Onset sample.
    pub onset: usize,
    /// Noise standard deviation.
    pub sigma: f64,
}

/// Sample rate of the wide protocol, Hz.
pub const WIDE_FS: f64 = 48000.0;

/// Draws one case of the wide protocol at `snr_db` (total strike energy over 1 s / noise).
pub fn wide_case(rng: &mut SmallRng, snr_db: f64) -> WideCase {
    let k = rng.random_range(1..=24usize);
    let mut modes: Vec<DampedMode> = Vec::with_capacity(k + 8);
    let mut guard = 0;
    let far = |modes: &[DampedMode], f: f64, d: f64| {
        modes.iter().all(|m| {
            let gap = (m.freq_hz - f).abs();
            gap >= 0.005 * f && gap >= (m.damping_per_s + d) / (2.0 * std::f64::consts::PI)
        })
    };
    while modes.len() < k && guard < 10_000 {
        guard += 1;
        let f = 20.0 * (22000.0f64 / 20.0).powf(rng.random_range(0.0..1.0));
        let d = 0.1 * 1e4f64.powf(rng.random_range(0.0..1.0));
        if !far(&modes, f, d) {
            continue;
        }
        let a = 0.3 * 10f64.powf(rng.random_range(-60.0..0.0) / 20.0);
        modes.push(DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: a,
            phase_rad: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        });
        // A beating doublet of a symmetric object: equal damping, 0.05–0.5 % apart. Only where
        // the pair can be told apart within the ring (the gap exceeds a tenth of the line width).
        if rng.random_range(0.0..1.0) < 0.25 {
            let f2 = f * (1.0 + 10f64.powf(rng.random_range(-3.3..-2.3)));
            if f2 < 22000.0
                && (f2 - f) > 0.1 * d / std::f64::consts::PI
                && far(&modes[..modes.len() - 1], f2, d)
            {
                modes.push(DampedMode {
                    freq_hz: f2,
                    damping_per_s: d,
                    amplitude: a * 10f64.powf(rng.random_range(-6.0..0.0) / 20.0),
                    phase_rad: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                });
            }
        }
    }
    modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let n = WIDE_FS as usize;
    let clean = synthesize(&modes, WIDE_FS, n);
    let energy: f64 = clean.iter().map(|v| v * v).sum();
    let sigma = (energy / n as f64 / 10f64.powf(snr_db / 10.0)).sqrt();
    let onset = (rng.random_range(0.05..1.0) * WIDE_FS) as usize;
    let dc = rng.random_range(-0.002..0.002);
    let normal =
        Normal::new(0.0, sigma).unwrap_or_else(|_| Normal::new(0.0, 1e-12).expect("valid"));
    let mut signal = vec![0.0; onset + n];
    for (i, v) in signal.iter_mut().enumerate() {
        *v = dc + normal.sample(rng) + if i >= onset { clean[i - onset] } else { 0.0 };
    }
    WideCase {
        modes,
        signal,
        onset,
        sigma,
    }
}

/// Result of the wide protocol at one SNR.
#[derive(Clone, Debug, Serialize)]
pub struct WideReport {
    /// Signal-to-noise ratio, dB.
    pub snr_db: f64,
    /// Cases analysed.
    pub trials: usize,
    /// Reference modes: within 60 dB of the strongest by level (RMS over the first 0.25 s, the
    /// measure `min_db` prunes by) and carrying energy Σ s² ≥ 100 σ² (a local SNR of 20 dB).
    pub reference_modes: usize,
    /// Fraction of the reference modes found.
    pub recall: f64,
    /// Fraction of found modes that match no true mode (any amplitude).
    pub spurious: f64,
    /// Recall of reference modes with d > 100 1/s.
    pub recall_damped: f64,
    /// Recall of reference modes below 300 Hz.
    pub recall_low: f64,
    /// Recall of reference modes that are half of a doublet.
    pub recall_doublet: f64,
    /// Median over recalled modes of |f error| / CRB.
    pub median_freq_error_over_crb: f64,
    /// Median over recalled modes of |d error| / CRB.
    pub median_damping_error_over_crb: f64,
    /// Cases whose onset was found within ±2 ms.
    pub onset_within_2ms: f64,
    /// Cases where the analysis failed (counted as all missed).
    pub failed: usize,
    /// Analysis seconds per second of audio (lead-in included).
    pub seconds_per_audio_second: f64,
}

/// Runs the wide protocol at `snr_db` with `trials` cases from `seed`.
pub fn wide(snr_db: f64, trials: usize, seed: u64, params: &AnalyzeParams) -> WideReport {
    wide_with(snr_db, trials, seed, |x, fs| {
        analyze(x, fs, params).ok().map(|a| (a.modes, a.onset_s))
    })
}

/// The wide protocol with any analysis: `analyse(signal, fs)` returns the modes and the onset
/// (seconds), or `None` when it fails.
pub fn wide_with(
    snr_db: f64,
    trials: usize,
    seed: u64,
    mut analyse: impl FnMut(&[f64], f64) -> Option<(Vec<DampedMode>, f64)>,
) -> WideReport {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut counts = [[0usize; 2]; 4]; // all, damped, low, doublet: [reference, recalled]
    let (mut found_total, mut spurious, mut failed, mut onset_ok) = (0, 0, 0, 0);
    let (mut rf, mut rd) = (Vec::new(), Vec::new());
    let (mut elapsed, mut audio) = (0.0, 0.0);
    for _ in 0..trials {
        let case = wide_case(&mut rng, snr_db);
        let n = case.signal.len() - case.onset;
        let t0 = Instant::now();
        let res = analyse(&case.signal, WIDE_FS);
        elapsed += t0.elapsed().as_secs_f64();
        audio += case.signal.len() as f64 / WIDE_FS;
        let (found, onset_s) = match res {
            Some(a) => a,
            None => {
                failed += 1;
                (Vec::new(), f64::NAN)
            }
        };
        if (onset_s - case.onset as f64 / WIDE_FS).abs() <= 2e-3 {
            onset_ok += 1;
        }
        let truth = &case.modes;
        let bounds = cramer_rao(truth, WIDE_FS, n, case.sigma.max(1e-12));
        let matched = match_modes(truth, &found, bounds.as_deref());
        found_total += found.len();
        spurious += found.len() - matched.iter().filter(|m| m.is_some()).count();
        let level = |m: &DampedMode| resound_signal::mode_level(m, resound_signal::LEVEL_WINDOW_S);
        let strongest = truth.iter().map(level).fold(0.0, f64::max);
        for (i, t) in truth.iter().enumerate() {
            let energy = t.amplitude
                * t.amplitude
                * WIDE_FS
                * (-(-2.0 * t.damping_per_s * n as f64 / WIDE_FS).exp_m1())
                / (4.0 * t.damping_per_s);
            if level(t) < strongest * 1e-3 || energy < 100.0 * case.sigma * case.sigma {
                continue;
            }
            let doublet = truth.iter().enumerate().any(|(j, u)| {
                j != i
                    && (u.freq_hz / t.freq_hz - 1.0).abs() < 0.0051
                    && u.damping_per_s == t.damping_per_s
            });
            let hit = matched[i].is_some();
            for (c, on) in [true, t.damping_per_s > 100.0, t.freq_hz < 300.0, doublet]
                .into_iter()
                .enumerate()
            {
                if on {
                    counts[c][0] += 1;
                    counts[c][1] += usize::from(hit);
                }
            }
            if let (Some(j), Some(b)) = (matched[i], bounds.as_ref()) {
                let f = &found[j];
                if case.sigma > 0.0 {
                    rf.push((f.freq_hz - t.freq_hz).abs() / b[i].freq_hz);
                    rd.push((f.damping_per_s - t.damping_per_s).abs() / b[i].damping_per_s);
                }
            }
        }
    }
    let ratio = |c: [usize; 2]| c[1] as f64 / c[0].max(1) as f64;
    WideReport {
        snr_db,
        trials,
        reference_modes: counts[0][0],
        recall: ratio(counts[0]),
        spurious: spurious as f64 / found_total.max(1) as f64,
        recall_damped: ratio(counts[1]),
        recall_low: ratio(counts[2]),
        recall_doublet: ratio(counts[3]),
        median_freq_error_over_crb: median(&mut rf),
        median_damping_error_over_crb: median(&mut rd),
        onset_within_2ms: onset_ok as f64 / trials.max(1) as f64,
        failed,
        seconds_per_audio_second: elapsed / audio.max(1e-9),
    }
}

/// Greedy one-to-one matching of found modes to true ones, closest first: a found mode matches
/// a true one within max(10 CRB, 0.2 % of f, a tenth of the gap to the true mode's nearest
/// neighbour is not enough to swap them). Returns, per true mode, the index of its match.
pub fn match_modes(
    truth: &[DampedMode],
    found: &[DampedMode],
    bounds: Option<&[resound_signal::crb::ModeBound]>,
) -> Vec<Option<usize>> {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, t) in truth.iter().enumerate() {
        // Within a doublet the tolerance must not reach the partner.
        let nearest = truth
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, u)| (u.freq_hz - t.freq_hz).abs())
            .fold(f64::INFINITY, f64::min);
        let tol = bounds
            .map(|b| 10.0 * b[i].freq_hz)
            .unwrap_or(0.0)
            .max(2e-3 * t.freq_hz)
            .min(0.5 * nearest.max(1e-9))
            .max(1e-6 * t.freq_hz);
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
    t_used
}
