//! Feature-domain metric: the Match Ratio Product of Ren 2013 eqs. 20–26.
//!
//! The paper's Appendix B (its constants and function forms) is not available; these are ours:
//!
//! - **Transformed space** (eqs. 21–22): `x = Z(f) / 0.5` (critical-band rate in half-Bark
//!   units: two tones half a critical band apart are clearly distinct) and `y = 20 / d`
//!   (the e-folding duration `1/d` in units of 50 ms: decays that differ by less than that are
//!   hard to tell apart for the short sounds of strikes).
//! - **Point-to-point score** `k = exp(−D²/2)` with `D` the Euclidean distance there: 1 when the
//!   points coincide, 0.61 at one unit, below 0.01 beyond three.
//! - **Weights** `w`: a mode's loudness-time product, its initial loudness in sone (ISO 226, SPL
//!   calibration of [`crate::psycho`]) times its e-folding duration capped at 1 s — what a
//!   listener integrates.
//! - **Point-to-set weights** `ũ_ij = w̃_j · k_ij` (plus a tiny floor): the ratio of a point is
//!   then a soft nearest-neighbour score, 1 when some well-weighted point coincides with it, and
//!   far-away points neither help nor hurt it.
//!
//! `R` (eq. 23) averages the reference points' ratios with their weights, `R̃` (eq. 25) the
//! estimated points', and the Match Ratio Product is `−R·R̃` (eq. 26): in [−1, 0], −1 for a
//! perfect match, and extra estimated modes that match nothing lower `R̃`.

use resound_core::DampedMode;
pub use resound_signal::psycho::sine_sone;
use resound_signal::psycho::{bark, perceptual_weight};

/// A mode in the transformed feature space with its weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeaturePoint {
    /// Critical-band rate in half-Bark units.
    pub x: f64,
    /// E-folding duration in units of 50 ms.
    pub y: f64,
    /// Perceptual weight (sone · s).
    pub weight: f64,
}

impl FeaturePoint {
    /// The point of `mode`.
    pub fn of(mode: &DampedMode) -> Self {
        Self::within(mode, 1.0)
    }

    /// The point of `mode` heard for at most `max_duration_s` (the recording's length: a mode
    /// that barely decays within a short recording must not outweigh the rest).
    pub fn within(mode: &DampedMode, max_duration_s: f64) -> Self {
        Self {
            x: bark(mode.freq_hz) / 0.5,
            y: 20.0 / mode.damping_per_s.max(1e-6),
            weight: perceptual_weight(mode, max_duration_s),
        }
    }
}

/// Point-to-point match score `exp(−D²/2)`.
pub fn match_score(a: &FeaturePoint, b: &FeaturePoint) -> f64 {
    let d2 = (a.x - b.x).powi(2) + (a.y - b.y).powi(2);
    (-0.5 * d2).exp()
}

/// Point-to-set match ratio of `p` against `to` (eq. 24): a soft nearest-neighbour score in
/// [0, 1], 1 when a well-weighted point of `to` coincides with `p`.
pub fn point_ratio(p: &FeaturePoint, to: &[FeaturePoint]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for q in to {
        let k = match_score(p, q);
        let u = q.weight * k + 1e-12 * q.weight;
        num += u * k;
        den += u;
    }
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}

/// Set-to-set match ratio of `from` against `to` (eqs. 23–24). Zero when either set carries no
/// weight.
pub fn match_ratio(from: &[FeaturePoint], to: &[FeaturePoint]) -> f64 {
    let total: f64 = from.iter().map(|p| p.weight).sum();
    if !(total > 0.0) {
        return 0.0;
    }
    from.iter()
        .map(|p| p.weight * point_ratio(p, to))
        .sum::<f64>()
        / total
}

/// How well each reference mode is represented by the estimated modes: its point-to-set
/// match ratio (Ren §6.1 weights the reference features by these to form the represented
/// sound).
pub fn represented_ratios(reference: &[DampedMode], estimated: &[DampedMode]) -> Vec<f64> {
    let e: Vec<FeaturePoint> = estimated.iter().map(FeaturePoint::of).collect();
    reference
        .iter()
        .map(|m| point_ratio(&FeaturePoint::of(m), &e))
        .collect()
}

/// The Match Ratio Product `−R·R̃` of reference and estimated modes (eq. 26), in [−1, 0].
pub fn match_ratio_product(reference: &[DampedMode], estimated: &[DampedMode]) -> f64 {
    let r: Vec<FeaturePoint> = reference.iter().map(FeaturePoint::of).collect();
    let e: Vec<FeaturePoint> = estimated.iter().map(FeaturePoint::of).collect();
    -match_ratio(&r, &e) * match_ratio(&e, &r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn modes() -> Vec<DampedMode> {
        [
            (440.0, 5.0, 0.3),
            (1320.0, 12.0, 0.1),
            (2900.0, 40.0, 0.05),
            (7100.0, 90.0, 0.02),
        ]
        .iter()
        .map(|&(f, d, a)| DampedMode::new(f, d, a))
        .collect()
    }

    #[test]
    fn perfect_match_is_minus_one_and_disjoint_sets_zero() {
        let m = modes();
        assert!((match_ratio_product(&m, &m) + 1.0).abs() < 1e-9);
        let far: Vec<DampedMode> = m
            .iter()
            .map(|x| DampedMode {
                freq_hz: x.freq_hz * 3.0 + 5000.0,
                ..*x
            })
            .collect();
        assert!(match_ratio_product(&m, &far).abs() < 1e-3);
    }

    #[test]
    fn worse_with_distance_and_with_unmatched_extra_modes() {
        let m = modes();
        let mut last = -1.0 - 1e-12;
        for shift in [1.0, 1.02, 1.05, 1.1, 1.2, 1.5] {
            let s: Vec<DampedMode> = m
                .iter()
                .map(|x| DampedMode {
                    freq_hz: x.freq_hz * shift,
                    ..*x
                })
                .collect();
            let v = match_ratio_product(&m, &s);
            assert!(v > last, "shift {shift}: {v} after {last}");
            last = v;
        }
        // Loud extra modes where the reference has none lower R̃ but not R.
        let mut extra = m.clone();
        extra.push(DampedMode::new(15_000.0, 3.0, 0.3));
        let r: Vec<FeaturePoint> = m.iter().map(FeaturePoint::of).collect();
        let e: Vec<FeaturePoint> = extra.iter().map(FeaturePoint::of).collect();
        assert!((match_ratio(&r, &e) - 1.0).abs() < 1e-6);
        assert!(match_ratio(&e, &r) < 0.9);
        // Damping matters too: much shorter decays match worse.
        let short: Vec<DampedMode> = m
            .iter()
            .map(|x| DampedMode {
                damping_per_s: x.damping_per_s * 4.0,
                ..*x
            })
            .collect();
        let v = match_ratio_product(&m, &short);
        assert!(v > -0.8, "{v}");
    }

    #[test]
    fn weights_follow_loudness_and_duration() {
        let loud = FeaturePoint::of(&DampedMode::new(1000.0, 5.0, 0.3));
        let soft = FeaturePoint::of(&DampedMode::new(1000.0, 5.0, 0.03));
        let short = FeaturePoint::of(&DampedMode::new(1000.0, 50.0, 0.3));
        // −20 dB is about a quarter of the loudness (Stevens: −10 phon halves it).
        assert!(
            (soft.weight / loud.weight - 0.25).abs() < 0.03,
            "{}",
            soft.weight / loud.weight
        );
        assert!((short.weight / loud.weight - 0.1).abs() < 1e-9);
        assert_eq!(sine_sone(1000.0, 0.0), 0.0);
    }
}
