//! Statistics fitted to recordings drawn from a known distribution recover it.
#![allow(clippy::unwrap_used)]

use rand::rngs::SmallRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use resound_core::damped::synthesize;
use resound_core::DampedMode;
use resound_signal::{analyze, AnalyzeParams};
use resound_stats::ModeStatistics;

const K: usize = 80;

#[test]
fn fitted_statistics_recover_the_generating_gaussian() {
    // Three modes: ln f, level (dB), decay (dB/s).
    let mean = [
        500f64.ln(),
        -12.0,
        40.0, //
        1300f64.ln(),
        -18.0,
        80.0, //
        3100f64.ln(),
        -24.0,
        150.0,
    ];
    let sd = [0.03, 1.5, 8.0, 0.03, 1.5, 8.0, 0.03, 1.5, 8.0];
    // Levels of modes 1 and 2 correlate with ρ = 0.6.
    let rho = 0.6;
    let fs = 44_100.0;
    let mut rng = SmallRng::seed_from_u64(11);
    let mut recordings = Vec::new();
    for _ in 0..K {
        let z: Vec<f64> = (0..9).map(|_| StandardNormal.sample(&mut rng)).collect();
        let mut x = [0.0; 9];
        for i in 0..9 {
            x[i] = mean[i] + sd[i] * z[i];
        }
        x[4] = mean[4] + sd[4] * (rho * z[1] + (1.0 - rho * rho).sqrt() * z[4]);
        let modes: Vec<DampedMode> = x
            .chunks(3)
            .map(|c| DampedMode::new(c[0].exp(), c[2] / 8.685_889_638, 10f64.powf(c[1] / 20.0)))
            .collect();
        let signal = synthesize(&modes, fs, 22_050);
        let found = analyze(&signal, fs, &AnalyzeParams::default()).unwrap();
        recordings.push(found.modes);
    }
    let s = ModeStatistics::fit("test", &recordings, 3).unwrap();
    assert_eq!(s.sources, K);
    let var = |i: usize| s.covariance[i * 9 + i];
    for i in 0..9 {
        let tol = 4.0 * sd[i] / (K as f64).sqrt();
        assert!(
            (s.mean[i] - mean[i]).abs() < tol,
            "mean {i}: {} vs {}",
            s.mean[i],
            mean[i]
        );
        let rel = var(i) / (sd[i] * sd[i]);
        assert!(
            (rel - 1.0).abs() < 3.0 * (2.0 / (K as f64 - 1.0)).sqrt(),
            "variance {i}: ratio {rel}"
        );
    }
    let r = s.covariance[9 + 4] / (var(1) * var(4)).sqrt();
    assert!((r - rho).abs() < 0.25, "correlation {r}");
    // Sampled IRs keep the mean spacing within 10 %, are reproducible, and vary.
    let target = (3100.0 - 500.0) / 2.0;
    let a = s.sample(1).unwrap();
    assert_eq!(a, s.sample(1).unwrap());
    assert_ne!(a, s.sample(2).unwrap());
    for seed in 0..50 {
        let m = s.sample(seed).unwrap();
        let spacing = (m[2].freq_hz - m[0].freq_hz) / 2.0;
        let mean_spacing = (s.mean[6].exp() - s.mean[0].exp()) / 2.0;
        assert!(
            (spacing / mean_spacing - 1.0).abs() <= 0.1 + 1e-12,
            "{spacing} vs {mean_spacing}"
        );
        assert!((mean_spacing / target - 1.0).abs() < 0.05);
    }
    assert!(ModeStatistics::fit("x", &recordings[..1], 3).is_err());
}
