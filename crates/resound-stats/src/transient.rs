//! The transient of Traer eq. 3: N noise bands of one ERB-number step each (N = 30 by default),
//! each with an onset level α_n (dB re full scale, band RMS at t = 0) and a decay β_n (dB/s).
//!
//! - [`fit_transient`]: band powers of a residual (recording minus its modes) in 46 ms frames (the lowest bands are a few tens of Hz wide);
//!   per band, a least-squares line of level (dB) against time from the band's loudest frame
//!   until it falls 40 dB or into the noise floor.
//! - [`synthesize_transient`]: white noise split into the bands (FFT masks), each scaled to unit
//!   RMS and shaped by its exponential envelope.

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};

/// ERB number of a frequency (Glasberg & Moore 1990).
pub fn erb_number(freq_hz: f64) -> f64 {
    21.4 * (1.0 + 0.004_37 * freq_hz).log10()
}

/// Frequency of an ERB number.
pub fn erb_frequency(e: f64) -> f64 {
    (10f64.powf(e / 21.4) - 1.0) / 0.004_37
}

/// Band edges (Hz) of `n` bands equally spaced in ERB number from 50 Hz to `top_hz`.
pub fn band_edges(n: usize, top_hz: f64) -> Vec<f64> {
    let (lo, hi) = (erb_number(50.0), erb_number(top_hz.max(100.0)));
    (0..=n)
        .map(|i| erb_frequency(lo + (hi - lo) * i as f64 / n as f64))
        .collect()
}

/// One transient: per-band onset level and decay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transient {
    /// Band edges, Hz (bands + 1 values).
    pub edges_hz: Vec<f64>,
    /// Onset level of each band, dB re full scale (RMS).
    pub onset_db: Vec<f64>,
    /// Decay of each band, dB/s.
    pub decay_db_per_s: Vec<f64>,
}

/// Onset level of a band that holds no transient (dB re full scale): it is not synthesized.
pub const ABSENT_DB: f64 = -120.0;

/// A band's transient must peak within this time of the onset (s): later peaks are room noise,
/// a later event or leakage, not the strike's transient (Traer's transients last tens of ms).
pub const MAX_PEAK_S: f64 = 0.1;

/// A band's transient must peak this far (dB) above the band's noise floor.
pub const MIN_SNR_DB: f64 = 10.0;

/// One band's (onset level dB, decay dB/s) from its frame levels `db` (hop `dt`, frame centre
/// `centre` after the frame start): a line from the loudest frame until it falls 40 dB or into
/// the noise, read at t = 0 but never above `cap_db` (the signal's own peak level: no band's
/// RMS exceeds it). A band without a clear peak near the onset is [`ABSENT_DB`].
fn fit_band(db: &[f64], dt: f64, centre: f64, cap_db: f64) -> (f64, f64) {
    let Some((peak, &top)) = db.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
        return (ABSENT_DB, 0.0);
    };
    let mut floor = db.to_vec();
    floor.sort_by(f64::total_cmp);
    let noise = floor[floor.len() / 10];
    if peak as f64 * dt > MAX_PEAK_S || top < noise + MIN_SNR_DB {
        return (ABSENT_DB, 0.0);
    }
    let stop = (top - 40.0).max(noise + 6.0);
    let end = db[peak..]
        .iter()
        .position(|&v| v < stop)
        .map_or(db.len(), |i| peak + i);
    let pts: Vec<(f64, f64)> = (peak..end).map(|i| (i as f64 * dt, db[i])).collect();
    if pts.len() < 3 {
        return (top.clamp(ABSENT_DB, cap_db.max(top).max(ABSENT_DB)), 0.0);
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let slope = sxy / sxx.max(1e-300);
    let at_onset = my - slope * (mx + centre);
    (
        // A residual that is all below ABSENT_DB (a near-perfect mode fit) is absent.
        at_onset.clamp(ABSENT_DB, cap_db.max(top).max(ABSENT_DB)),
        (-slope).max(0.0),
    )
}

/// Fits a transient with `bands` bands to `residual` (onset-aligned, at `sample_rate_hz`).
pub fn fit_transient(residual: &[f64], sample_rate_hz: f64, bands: usize) -> Transient {
    let edges = band_edges(bands, (0.45 * sample_rate_hz).min(20_000.0));
    let w = ((0.046 * sample_rate_hz) as usize)
        .next_power_of_two()
        .max(64);
    let hop = w / 4;
    let fft = resound_signal::stft::forward_plan(w);
    let window = resound_signal::stft::hann(w);
    let w2: f64 = window.iter().map(|v| v * v).sum();
    let frames = if residual.len() >= w {
        (residual.len() - w) / hop + 1
    } else {
        0
    };
    let bin_hz = sample_rate_hz / w as f64;
    // Mean square per band and frame (Parseval with the window's energy).
    let mut power = vec![vec![0.0f64; frames]; bands];
    let mut buf = fft.make_input_vec();
    let mut spec = fft.make_output_vec();
    for m in 0..frames {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = residual[m * hop + i] * window[i];
        }
        if fft.process(&mut buf, &mut spec).is_err() {
            continue;
        }
        for (k, c) in spec.iter().enumerate() {
            let f = k as f64 * bin_hz;
            let b = edges.partition_point(|&e| e <= f);
            if b >= 1 && b <= bands {
                power[b - 1][m] += 2.0 * c.norm_sqr() / (w as f64 * w2);
            }
        }
    }
    let dt = hop as f64 / sample_rate_hz;
    let mut onset_db = Vec::with_capacity(bands);
    let mut decay = Vec::with_capacity(bands);
    // Window centres sit W/2 after the frame start.
    let centre = 0.5 * w as f64 / sample_rate_hz;
    let peak = residual.iter().fold(0.0f64, |p, v| p.max(v.abs()));
    let cap_db = 20.0 * peak.max(1e-30).log10();
    for p in &power {
        let db: Vec<f64> = p.iter().map(|&v| 10.0 * v.max(1e-30).log10()).collect();
        let (onset, d) = fit_band(&db, dt, centre, cap_db);
        onset_db.push(onset);
        decay.push(d);
    }
    Transient {
        edges_hz: edges,
        onset_db,
        decay_db_per_s: decay,
    }
}

/// `samples` samples of the transient at `sample_rate_hz` (seeded noise).
pub fn synthesize_transient(
    t: &Transient,
    sample_rate_hz: f64,
    samples: usize,
    seed: u64,
) -> Vec<f64> {
    let n = samples.max(2).next_power_of_two();
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut noise: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * 2.0 - 1.0).collect();
    let mut spec = fwd.make_output_vec();
    if fwd.process(&mut noise, &mut spec).is_err() {
        return vec![0.0; samples];
    }
    let bin_hz = sample_rate_hz / n as f64;
    let mut out = vec![0.0; samples];
    let mut band = inv.make_input_vec();
    let mut x = inv.make_output_vec();
    for b in 0..t.onset_db.len() {
        if t.onset_db[b] <= ABSENT_DB {
            continue;
        }
        let (lo, hi) = (t.edges_hz[b], t.edges_hz[b + 1]);
        for (k, c) in band.iter_mut().enumerate() {
            let f = k as f64 * bin_hz;
            *c = if f >= lo && f < hi {
                spec[k]
            } else {
                Complex64::new(0.0, 0.0)
            };
        }
        band[0].im = 0.0;
        let last = band.len() - 1;
        band[last].im = 0.0;
        if inv.process(&mut band, &mut x).is_err() {
            continue;
        }
        let rms = (x.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
        if !(rms > 0.0) {
            continue;
        }
        let a0 = 10f64.powf(t.onset_db[b] / 20.0) / rms;
        let k = t.decay_db_per_s[b] / 20.0 * std::f64::consts::LN_10;
        for (i, o) in out.iter_mut().enumerate() {
            *o += x[i] * a0 * (-k * i as f64 / sample_rate_hz).exp();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_band_entirely_below_the_absent_level_is_absent_not_a_panic() {
        // A decaying band peaking at −123 dB with the signal's own peak below −120 dB (what a
        // near-perfect mode fit leaves as residual).
        let db: Vec<f64> = (0..40).map(|i| -123.0 - 2.0 * i as f64).collect();
        let (onset, decay) = fit_band(&db, 0.01, 0.02, -121.0);
        assert_eq!(onset, ABSENT_DB);
        assert!(decay >= 0.0);
        let (onset, _) = fit_band(&db[..2], 0.01, 0.02, -121.0);
        assert_eq!(onset, ABSENT_DB);
    }

    #[test]
    fn the_transient_alone_decays_at_the_fitted_rates() {
        let fs = 44_100.0;
        let edges = band_edges(30, 0.45 * fs);
        let truth = Transient {
            edges_hz: edges,
            onset_db: (0..30).map(|b| -20.0 - 0.5 * b as f64).collect(),
            decay_db_per_s: (0..30).map(|b| 150.0 + 15.0 * b as f64).collect(),
        };
        let x = synthesize_transient(&truth, fs, 22_050, 4);
        let fit = fit_transient(&x, fs, 30);
        let errs: Vec<f64> = (0..30)
            .map(|b| fit.decay_db_per_s[b] / truth.decay_db_per_s[b] - 1.0)
            .collect();
        // A narrow noise band's envelope fluctuates: each band within 15 %, on average 5 %.
        let mean_abs = errs.iter().map(|e| e.abs()).sum::<f64>() / 30.0;
        assert!(mean_abs < 0.05, "{errs:.3?}");
        for b in 0..30 {
            let (got, want) = (fit.decay_db_per_s[b], truth.decay_db_per_s[b]);
            assert!(
                (got / want - 1.0).abs() < 0.15,
                "band {b}: decay {got} vs {want}"
            );
            // Levels averaged in dB read low for narrow bands (the log of a fluctuating power).
            let (og, ow) = (fit.onset_db[b], truth.onset_db[b]);
            assert!((og - ow).abs() < 4.5, "band {b}: onset {og} vs {ow}");
        }
        let onset_err = (0..30)
            .map(|b| (fit.onset_db[b] - truth.onset_db[b]).abs())
            .sum::<f64>()
            / 30.0;
        assert!(onset_err < 2.0, "mean onset error {onset_err} dB");
        assert!((erb_number(erb_frequency(17.3)) - 17.3).abs() < 1e-9);
    }

    #[test]
    fn issue_15_a_band_that_peaks_late_or_in_the_noise_is_absent_and_onsets_never_exceed_the_peak()
    {
        let fs = 48_000.0;
        let n = 48_000;
        let mut rng = SmallRng::seed_from_u64(9);
        // Room noise at −80 dB everywhere, a second event at 0.6 s at 600–800 Hz that decays
        // fast (extrapolated back to t = 0 it would claim +100 dB), and a real transient at
        // 5 kHz from t = 0.
        let mut x: Vec<f64> = (0..n).map(|_| 1e-4 * (rng.random::<f64>() - 0.5)).collect();
        for (i, v) in x.iter_mut().enumerate() {
            let t = i as f64 / fs;
            *v += 0.2 * (-t * 60.0).exp() * (std::f64::consts::TAU * 5000.0 * t).sin();
            if t > 0.6 {
                let u = t - 0.6;
                *v += 0.3 * (-u * 40.0).exp() * (std::f64::consts::TAU * 700.0 * u).sin();
            }
        }
        let fit = fit_transient(&x, fs, 30);
        let band = |f: f64| fit.edges_hz.partition_point(|&e| e <= f) - 1;
        assert_eq!(fit.onset_db[band(700.0)], ABSENT_DB, "{:?}", fit.onset_db);
        assert_eq!(fit.onset_db[band(100.0)], ABSENT_DB, "{:?}", fit.onset_db);
        let b5k = band(5000.0);
        // 0.2 amplitude: RMS −17 dB; within 6 dB (85 ms frames on a 520 dB/s decay), and no
        // band above the signal's peak.
        assert!(
            (fit.onset_db[b5k] + 17.0).abs() < 6.0,
            "{}",
            fit.onset_db[b5k]
        );
        let cap = 20.0 * x.iter().fold(0.0f64, |p, v| p.max(v.abs())).log10();
        assert!(fit.onset_db.iter().all(|&v| v <= cap), "{:?}", fit.onset_db);
        // Absent bands add nothing.
        let only_absent = Transient {
            edges_hz: fit.edges_hz.clone(),
            onset_db: vec![ABSENT_DB; 30],
            decay_db_per_s: vec![0.0; 30],
        };
        assert!(synthesize_transient(&only_absent, fs, 1000, 1)
            .iter()
            .all(|&v| v == 0.0));
    }
}
