//! A textbook ESPRIT, the baseline row of `bench analyze --wide`.
//!
//! What a careful reader of Roy & Kailath (1989) writes in an afternoon, with no part of
//! Resound's estimator in it: from the onset (found by `resound_signal::onset::scan`, the only
//! shared piece, so the row measures the estimator and not the strike detector) and with the
//! lead-in's mean removed,
//! 1. the `M × M` sample covariance of the full-band Hankel rows of the whole segment
//!    (`M` = [`ROWS`]);
//! 2. its eigen-decomposition and the model order by Rissanen's minimum description length
//!    (Wax & Kailath 1985) on the eigenvalues;
//! 3. least-squares ESPRIT on the signal subspace: poles `z = e^{(−d + iω)/fs}` as the
//!    eigenvalues of `Φ = (U₁ᵀU₁)⁻¹U₁ᵀU₂`;
//! 4. each pole with positive frequency that passes the same plausibility test as ours
//!    (`resound_signal::plausible`, damping below the transient limit) is a mode.
//!
//! No amplitude step: the benchmark's measures (recall, spurious, error over CRB) use poles
//! only, so the baseline is spared that cost.

use resound_core::DampedMode;

/// Rows of the Hankel covariance (the ESPRIT aperture, 10.7 ms at 48 kHz).
pub const ROWS: usize = 512;

/// Largest model order (complex exponentials; two per real mode).
pub const MAX_ORDER: usize = 160;

/// The modes textbook ESPRIT finds in `x`, and the onset it used (seconds).
pub fn textbook_esprit(x: &[f64], fs: f64) -> (Vec<DampedMode>, f64) {
    let onset = resound_signal::onset::scan(x, fs)
        .onsets
        .first()
        .copied()
        .unwrap_or(0);
    let dc = if onset > 0 {
        x[..onset].iter().sum::<f64>() / onset as f64
    } else {
        0.0
    };
    let seg: Vec<f64> = x[onset..].iter().map(|v| v - dc).collect();
    (poles(&seg, fs), onset as f64 / fs)
}

fn poles(y: &[f64], fs: f64) -> Vec<DampedMode> {
    let mut out: Vec<DampedMode> =
        resound_signal::subspace::fullband_esprit(y, fs, ROWS, MAX_ORDER)
            .into_iter()
            .map(|p| DampedMode {
                freq_hz: p.freq_hz,
                damping_per_s: p.damping_per_s,
                amplitude: 1.0,
                phase_rad: 0.0,
            })
            .filter(|m| {
                resound_signal::plausible(m.freq_hz, m.damping_per_s, fs)
                    && m.damping_per_s < resound_signal::analyze::TRANSIENT_DAMPING_PER_S
            })
            .collect();
    out.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::SmallRng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    #[test]
    fn finds_three_well_separated_modes_in_noise_and_no_more() {
        let fs = 48000.0;
        let truth = [(440.0, 3.0, 0.5), (2500.0, 20.0, 0.3), (9000.0, 60.0, 0.2)];
        let modes: Vec<DampedMode> = truth
            .iter()
            .map(|&(f, d, a)| DampedMode {
                freq_hz: f,
                damping_per_s: d,
                amplitude: a,
                phase_rad: 0.3,
            })
            .collect();
        let mut x = vec![0.0; 2400];
        x.extend(resound_core::damped::synthesize(&modes, fs, 24000));
        let mut rng = SmallRng::seed_from_u64(5);
        let noise = Normal::new(0.0, 1e-4).unwrap();
        x.iter_mut().for_each(|v| *v += noise.sample(&mut rng));
        let (found, onset_s) = textbook_esprit(&x, fs);
        assert!((onset_s - 0.05).abs() < 2e-3, "onset {onset_s}");
        for &(f, d, _) in &truth {
            let m = found
                .iter()
                .min_by(|a, b| (a.freq_hz - f).abs().total_cmp(&(b.freq_hz - f).abs()))
                .expect("a mode");
            assert!((m.freq_hz / f - 1.0).abs() < 1e-3, "{f}: {}", m.freq_hz);
            assert!(
                (m.damping_per_s / d - 1.0).abs() < 0.2,
                "{d}: {}",
                m.damping_per_s
            );
        }
        assert!(found.len() == 3, "{} modes: {found:?}", found.len());
    }

    #[test]
    fn mdl_counts_the_eigenvalues_above_a_flat_floor() {
        let mut lam = vec![1.0; 64];
        lam[..5].copy_from_slice(&[1e4, 5e3, 800.0, 300.0, 90.0]);
        assert_eq!(resound_signal::subspace::mdl_order(&lam, 10_000, 100), 5);
    }
}
