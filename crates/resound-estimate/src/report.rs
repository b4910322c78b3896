//! How sure an estimate is: the fit report.
//!
//! The hybrid metric says how well the estimated sound matches, not how well the parameters
//! are pinned down. The report measures that from the modes themselves:
//!
//! - each recorded mode is paired with the estimated mode nearest in frequency (within
//!   [`PAIR_TOLERANCE`], one-to-one, strongest recorded modes first);
//! - **γ**: every pair implies `γ_i = γ (f_rec / f_est)²` (frequency scales with √γ); the
//!   standard error of their weighted mean is γ's uncertainty;
//! - **α, β**: the recorded dampings of the paired modes against the Rayleigh line
//!   `2d = α + β ω²`, by weighted least squares; the parameters' standard errors come from the
//!   scatter about the line (at least three pairs; with fewer, the uncertainty is unknown);
//! - **loudness share**: the share of the recording's perceptual weight (sone·s, the metric's
//!   own weights) carried by paired modes — how much of what is heard the estimate explains;
//! - **chance share**: the share the same estimated modes pair when all their frequencies are
//!   moved by one arbitrary factor (median over factors ½–2 away from the fit). An object with
//!   many modes pairs much of any recording by chance: a wrong mesh of 40 modes pairs about
//!   half of the bundled ramp recording's loudness wherever γ puts it, a right one a few
//!   percent. Only the share above it says the object is the recorded one.

use crate::features::FeaturePoint;
use crate::forward::RayleighParams;
use resound_core::DampedMode;
use serde::Serialize;
use std::f64::consts::TAU;

/// Largest relative frequency gap of a recorded/estimated pair.
pub const PAIR_TOLERANCE: f64 = 0.03;

/// The fit report of an estimate.
#[derive(Clone, Debug, Serialize, serde::Deserialize, PartialEq)]
pub struct FitReport {
    /// Recorded modes paired with an estimated one.
    pub paired_modes: usize,
    /// Recorded modes in all.
    pub recorded_modes: usize,
    /// Share of the recording's perceptual weight carried by paired modes, 0–1.
    pub loudness_share: f64,
    /// Standard error of α, 1/s (`None` with fewer than three pairs).
    pub alpha_sigma: Option<f64>,
    /// Standard error of β, s.
    pub beta_sigma: Option<f64>,
    /// Standard error of γ, m²/s² (`None` with fewer than two pairs).
    pub gamma_sigma: Option<f64>,
    /// Median relative frequency error of the pairs.
    pub median_freq_error: f64,
    /// The loudness share the same estimated modes reach by chance: the median share over
    /// every frequency scale from ½ to 2 that is not the fit's own (further than twice
    /// [`PAIR_TOLERANCE`] from 1). A share not well above it says the pairing is chance.
    #[serde(default)]
    pub chance_share: f64,
}

impl FitReport {
    /// The loudness share above what chance pairs: `loudness_share − chance_share` (it can be
    /// negative: the fit's scale pairs less than a typical other one).
    pub fn share_over_chance(&self) -> f64 {
        self.loudness_share - self.chance_share
    }

    /// Relative uncertainty of γ (σ_γ / γ).
    pub fn gamma_relative(&self, gamma: f64) -> Option<f64> {
        self.gamma_sigma.map(|s| s / gamma)
    }
}

/// The report of `params` whose forward modes are `estimated`, against the `recorded` modes
/// of a recording `duration_s` long.
pub fn fit_report(
    recorded: &[DampedMode],
    estimated: &[DampedMode],
    params: &RayleighParams,
    duration_s: f64,
) -> FitReport {
    pooled_fit_report(&[(recorded, estimated, duration_s)], params)
}

/// The report of one set of parameters against several recordings (each with the estimated
/// modes of its own object and hit): modes are paired within each take and the pairs pooled,
/// so γ, α and β rest on every take's modes. Shares and counts are over all takes.
pub fn pooled_fit_report(
    takes: &[(&[DampedMode], &[DampedMode], f64)],
    params: &RayleighParams,
) -> FitReport {
    let mut pairs: Vec<(DampedMode, DampedMode, f64)> = Vec::new();
    let mut total = 0.0;
    let mut recorded_modes = 0;
    for &(recorded, estimated, duration_s) in takes {
        let (p, t) = pair_modes(recorded, estimated, duration_s);
        pairs.extend(p);
        total += t;
        recorded_modes += recorded.len();
    }
    let mut report = report_from_pairs(&pairs, total, recorded_modes, params);
    report.chance_share = chance_share(takes);
    report
}

/// Frequency scales [`chance_share`] tries, log-spaced over ½–2.
const CHANCE_SCALES: usize = 97;

/// The median loudness share of `takes` when every estimated frequency is multiplied by a
/// scale from ½ to 2 not within twice [`PAIR_TOLERANCE`] of 1: what pairing reaches when the
/// estimated modes are put anywhere (0 without recorded loudness).
pub fn chance_share(takes: &[(&[DampedMode], &[DampedMode], f64)]) -> f64 {
    let mut shares: Vec<f64> = (0..CHANCE_SCALES)
        .map(|k| 2f64.powf(2.0 * k as f64 / (CHANCE_SCALES - 1) as f64 - 1.0))
        .filter(|s| s.ln().abs() > 2.0 * PAIR_TOLERANCE)
        .map(|s| {
            let (mut paired, mut total) = (0.0, 0.0);
            for &(recorded, estimated, duration_s) in takes {
                let moved: Vec<DampedMode> = estimated
                    .iter()
                    .map(|m| DampedMode {
                        freq_hz: m.freq_hz * s,
                        ..*m
                    })
                    .collect();
                let (p, t) = pair_modes(recorded, &moved, duration_s);
                paired += p.iter().map(|p| p.2).sum::<f64>();
                total += t;
            }
            if total > 0.0 {
                paired / total
            } else {
                0.0
            }
        })
        .collect();
    shares.sort_by(f64::total_cmp);
    shares.get(shares.len() / 2).copied().unwrap_or(0.0)
}

/// Pairs each recorded mode with the nearest estimated one within [`PAIR_TOLERANCE`]
/// (one-to-one, strongest recorded first): (recorded, estimated, perceptual weight), and the
/// recording's total weight.
pub(crate) fn pair_modes(
    recorded: &[DampedMode],
    estimated: &[DampedMode],
    duration_s: f64,
) -> (Vec<(DampedMode, DampedMode, f64)>, f64) {
    let weight = |m: &DampedMode| FeaturePoint::within(m, duration_s).weight.max(0.0);
    let mut order: Vec<usize> = (0..recorded.len()).collect();
    order.sort_by(|&a, &b| weight(&recorded[b]).total_cmp(&weight(&recorded[a])));
    let mut used = vec![false; estimated.len()];
    let mut pairs: Vec<(DampedMode, DampedMode, f64)> = Vec::new();
    for i in order {
        let r = &recorded[i];
        let best = estimated
            .iter()
            .enumerate()
            .filter(|(j, e)| !used[*j] && (e.freq_hz / r.freq_hz - 1.0).abs() <= PAIR_TOLERANCE)
            .min_by(|a, b| {
                (a.1.freq_hz - r.freq_hz)
                    .abs()
                    .total_cmp(&(b.1.freq_hz - r.freq_hz).abs())
            });
        if let Some((j, e)) = best {
            used[j] = true;
            pairs.push((*r, *e, weight(r)));
        }
    }
    (pairs, recorded.iter().map(weight).sum())
}

fn report_from_pairs(
    pairs: &[(DampedMode, DampedMode, f64)],
    total: f64,
    recorded_modes: usize,
    params: &RayleighParams,
) -> FitReport {
    let paired: f64 = pairs.iter().map(|p| p.2).sum();
    let mut errs: Vec<f64> = pairs
        .iter()
        .map(|(r, e, _)| (e.freq_hz / r.freq_hz - 1.0).abs())
        .collect();
    errs.sort_by(f64::total_cmp);
    let median_freq_error = errs.get(errs.len() / 2).copied().unwrap_or(f64::NAN);
    // γ from each pair, weighted (weights floored so one loud mode cannot stand alone).
    let gamma_sigma = (pairs.len() >= 2).then(|| {
        let w: Vec<f64> = pairs.iter().map(|p| p.2.max(1e-6 * paired)).collect();
        let g: Vec<f64> = pairs
            .iter()
            .map(|(r, e, _)| params.gamma * (r.freq_hz / e.freq_hz).powi(2))
            .collect();
        weighted_mean_error(&g, &w)
    });
    // α, β from the Rayleigh line through the recorded dampings.
    let (alpha_sigma, beta_sigma) = if pairs.len() >= 3 {
        let pts: Vec<(f64, f64, f64)> = pairs
            .iter()
            .map(|(r, _, w)| {
                (
                    (TAU * r.freq_hz).powi(2),
                    2.0 * r.damping_per_s,
                    w.max(1e-6 * paired),
                )
            })
            .collect();
        match line_errors(&pts) {
            Some((sa, sb)) => (Some(sa), Some(sb)),
            None => (None, None),
        }
    } else {
        (None, None)
    };
    FitReport {
        paired_modes: pairs.len(),
        recorded_modes,
        loudness_share: if total > 0.0 { paired / total } else { 0.0 },
        alpha_sigma,
        beta_sigma,
        gamma_sigma,
        median_freq_error,
        chance_share: 0.0,
    }
}

/// Standard error of the weighted mean of `x` (effective sample size from the weights).
fn weighted_mean_error(x: &[f64], w: &[f64]) -> f64 {
    let sw: f64 = w.iter().sum();
    let mean = x.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / sw;
    let var = x
        .iter()
        .zip(w)
        .map(|(a, b)| b * (a - mean).powi(2))
        .sum::<f64>()
        / sw;
    let n_eff = sw * sw / w.iter().map(|b| b * b).sum::<f64>();
    (var / (n_eff - 1.0).max(1.0)).sqrt()
}

/// Standard errors of intercept and slope of the weighted line `y = a + b x` through `pts`
/// (x, y, w): from the weighted residual variance, with the effective sample size.
fn line_errors(pts: &[(f64, f64, f64)]) -> Option<(f64, f64)> {
    let sw: f64 = pts.iter().map(|p| p.2).sum();
    let mx = pts.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
    let my = pts.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
    let sxx: f64 = pts.iter().map(|p| p.2 * (p.0 - mx).powi(2)).sum();
    if !(sxx > 0.0) {
        return None;
    }
    let b = pts
        .iter()
        .map(|p| p.2 * (p.0 - mx) * (p.1 - my))
        .sum::<f64>()
        / sxx;
    let a = my - b * mx;
    let n_eff = sw * sw / pts.iter().map(|p| p.2 * p.2).sum::<f64>();
    if n_eff <= 2.0 {
        return None;
    }
    let rss: f64 = pts.iter().map(|p| p.2 * (p.1 - a - b * p.0).powi(2)).sum();
    // Weighted residual variance per unit weight, scaled to the effective sample size.
    let s2 = rss / sw * n_eff / (n_eff - 2.0);
    let sb = (s2 / (sxx / sw) / n_eff).sqrt();
    let sa = (s2 * (1.0 / n_eff + mx * mx / (sxx / sw) / n_eff)).sqrt();
    // The line is 2d = α + βω²: a = α, b = β.
    Some((sa, sb))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(f: f64, d: f64) -> DampedMode {
        DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: 0.1,
            phase_rad: 0.0,
        }
    }

    #[test]
    fn exact_modes_have_zero_uncertainty_and_scatter_raises_it() {
        let p = RayleighParams {
            alpha: 2.0,
            beta: 1e-7,
            gamma: 2.6e7,
            sigma: 1.0,
        };
        let f = [500.0, 1300.0, 2700.0, 4100.0, 6000.0];
        let d = |f: f64| 0.5 * (p.alpha + p.beta * (TAU * f).powi(2));
        let exact: Vec<DampedMode> = f.iter().map(|&f| mode(f, d(f))).collect();
        let r = fit_report(&exact, &exact, &p, 1.0);
        assert_eq!(r.paired_modes, 5);
        assert!((r.loudness_share - 1.0).abs() < 1e-12);
        assert!(r.gamma_sigma.unwrap() < 1e-9 * p.gamma, "{r:?}");
        assert!(r.beta_sigma.unwrap() < 1e-6 * p.beta, "{r:?}");
        // Recorded frequencies ±1 % off and dampings ±20 %: a few-percent γ error, and β's
        // error grows accordingly.
        let noisy: Vec<DampedMode> = exact
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let s = if i % 2 == 0 { 1.0 } else { -1.0 };
                mode(
                    m.freq_hz * (1.0 + 0.01 * s),
                    m.damping_per_s * (1.0 + 0.2 * s),
                )
            })
            .collect();
        let r = fit_report(&noisy, &exact, &p, 1.0);
        let g = r.gamma_relative(p.gamma).unwrap();
        assert!((0.002..0.05).contains(&g), "{r:?}");
        assert!(r.beta_sigma.unwrap() > 0.01 * p.beta, "{r:?}");
        // A recorded mode the model has nowhere near lowers the share.
        let mut extra = exact.clone();
        extra.push(mode(9000.0, 5.0));
        let r = fit_report(&extra, &exact, &p, 1.0);
        assert_eq!(r.paired_modes, 5);
        assert!(r.loudness_share < 1.0);
    }

    #[test]
    fn a_dense_wrong_object_pairs_by_chance_and_a_right_one_does_not() {
        let p = RayleighParams {
            alpha: 2.0,
            beta: 1e-7,
            gamma: 2.6e7,
            sigma: 1.0,
        };
        let d = |f: f64| 0.5 * (p.alpha + p.beta * (TAU * f).powi(2));
        // Recorded: eight modes of irregular spacing, 300 Hz–9 kHz.
        let rec: Vec<DampedMode> = [311.0, 870.0, 1490.0, 2333.0, 3760.0, 5020.0, 6890.0, 8710.0]
            .iter()
            .map(|&f| mode(f, d(f)))
            .collect();
        let right = fit_report(&rec, &rec, &p, 1.0);
        assert!(right.chance_share < 0.1, "{right:?}");
        assert!(right.share_over_chance() > 0.9, "{right:?}");
        // A wrong object with 60 modes spread evenly in log frequency (2.4 % apart): nearly
        // every recorded mode finds one within 3 %, at its scale as at any other.
        let dense: Vec<DampedMode> = (0..60)
            .map(|k| {
                let f = 250.0 * 1.024f64.powi(k * 5 / 2) * (1.0 + 0.004 * (k % 3) as f64);
                mode(f, d(f))
            })
            .collect();
        let wrong = fit_report(&rec, &dense, &p, 1.0);
        assert!(wrong.loudness_share > 0.5, "{wrong:?}");
        assert!(wrong.chance_share > 0.5, "{wrong:?}");
        assert!(wrong.share_over_chance() < 0.25, "{wrong:?}");
    }
}
