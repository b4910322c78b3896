//! The benchmark's mixture generator against the analyser (a small, seeded run of
//! `resound bench analyze`'s protocol 2 that must stay green).
#![allow(clippy::unwrap_used)]

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use resound_bench::analysis::random_mixture;
use resound_core::{damped::synthesize, DampedMode};
use resound_signal::crb::cramer_rao;
use resound_signal::{analyze, AnalyzeParams};

const FS: f64 = 44100.0;

fn noisy(truth: &[DampedMode], n: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut x = synthesize(truth, FS, n);
    let mut rng = SmallRng::seed_from_u64(seed);
    let normal = Normal::new(0.0, sigma).unwrap();
    x.iter_mut().for_each(|v| *v += normal.sample(&mut rng));
    x
}

#[test]
fn seeded_mixtures_are_recovered() {
    let mut rng = SmallRng::seed_from_u64(11);
    let (mut total, mut found, mut spurious, mut reported) = (0, 0, 0, 0);
    for _ in 0..6 {
        let k = rng.random_range(4..=12);
        let truth = random_mixture(&mut rng, k);
        let strongest = truth.iter().map(|m| m.amplitude).fold(0.0, f64::max);
        let sigma = strongest * 1e-3;
        let x = noisy(&truth, 44100, sigma, rng.random());
        let res = analyze(&x, FS, &AnalyzeParams::default()).unwrap();
        let bounds = cramer_rao(&truth, FS, 44100, sigma).unwrap();
        let matches = |m: &DampedMode| {
            truth.iter().zip(&bounds).any(|(t, b)| {
                (m.freq_hz - t.freq_hz).abs() <= (10.0 * b.freq_hz).max(2e-3 * t.freq_hz)
            })
        };
        reported += res.modes.len();
        spurious += res.modes.iter().filter(|m| !matches(m)).count();
        for (t, b) in truth.iter().zip(&bounds) {
            if t.amplitude < 0.01 * strongest {
                continue;
            }
            total += 1;
            if res
                .modes
                .iter()
                .any(|m| (m.freq_hz - t.freq_hz).abs() <= (10.0 * b.freq_hz).max(2e-3 * t.freq_hz))
            {
                found += 1;
            }
        }
    }
    let recall = found as f64 / total as f64;
    let spurious = spurious as f64 / reported as f64;
    assert!(recall >= 0.9, "recall {recall} ({found}/{total})");
    assert!(spurious <= 0.1, "spurious {spurious}");
}

/// The wide protocol (20 Hz–22 kHz, d 0.1–1000 1/s, doublets, a noisy lead-in with a DC
/// offset) at 40 dB: every onset within 2 ms, and recall and spurious share no worse than
/// measured when the sub-band ESPRIT pass landed (0.87 and 0.03 over 40 cases; issue 16's
/// targets, 0.95 and 0.03, are not met yet).
#[test]
fn wide_range_cases_behind_a_noisy_lead_in() {
    let r = resound_bench::analysis::wide(40.0, 12, 3, &resound_signal::AnalyzeParams::default());
    eprintln!("{r:?}");
    assert_eq!(r.failed, 0, "{r:?}");
    assert!(r.onset_within_2ms >= 1.0, "{r:?}");
    assert!(r.recall >= 0.8, "{r:?}");
    assert!(r.spurious <= 0.08, "{r:?}");
}
