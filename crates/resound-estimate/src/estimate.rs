//! Parameter estimation (Ren 2013 §5.3): multi-start Nelder–Mead on the hybrid metric
//! `Π_psycho / |Π_MRP|` (eq. 27).
//!
//! Starting points: for every pair of the `dominant` reference modes (by perceptual weight), the Rayleigh
//! circle through them (eq. 8) gives (α, β); for every "no cheaper, louder" eigenvalue (no other
//! has both a smaller λ⁰ and a larger a⁰), γ and σ put that mode on the frequency and amplitude
//! of the most dominant reference mode. Each start is refined by Nelder–Mead (argmin) over
//! (α, ln β, ln γ, ln σ), in parallel (rayon); the lowest metric wins.
//!
//! One metric evaluation is cheap because the estimated image is computed in closed form
//! ([`crate::image::image_of_modes`]) against a reference image computed once.

use crate::features::{match_ratio, FeaturePoint};
use crate::forward::{forward_modes, RayleighParams};
use crate::image::{
    audible_samples, audible_signal, image_of_modes, image_of_signal, ImageGrid, LoudnessImage,
};
use argmin::core::{CostFunction, Error as ArgminError, Executor};
use argmin::solver::neldermead::NelderMead;
use rayon::prelude::*;
use resound_core::DampedMode;
use std::f64::consts::TAU;

/// The object side of the estimation: a modal model's eigenvalues at the reference material and
/// its unit-impulse amplitudes at the hit point.
#[derive(Clone, Debug)]
pub struct ModalSide {
    /// λ⁰ in rad²/s², ascending.
    pub eigenvalues0: Vec<f64>,
    /// a⁰ per mode.
    pub gains0: Vec<f64>,
    /// γ₀ = E₀/ρ₀ of the reference material.
    pub gamma0: f64,
}

/// Settings of [`estimate`].
#[derive(Clone, Debug)]
pub struct EstimateParams {
    /// Reference modes used for starting circles (Ren's N_dominant).
    pub dominant: usize,
    /// Nelder–Mead iterations per start.
    pub max_iterations: u64,
    /// Cells quieter than this many dB below the loudest reference cell count as the floor.
    pub floor_db: f64,
    /// How the estimated loudness image is computed.
    pub route: ImageRoute,
    /// A known estimate to refine (a first estimate on fewer modes of the same object): it is
    /// refined first, beside only the [`WARM_OTHER_STARTS`] most promising of the usual starts.
    pub warm_start: Option<RayleighParams>,
}

/// How [`Objective::hybrid`] computes the estimated loudness image. Both routes give the same
/// image (to about 1e-6); they differ in cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageRoute {
    /// Per evaluation, whichever of the two costs less by the estimates below (the default):
    /// the closed form wins for light damping and few modes, synthesis + FFT for many heavily
    /// damped modes, whose closed-form cells spread over hundreds of bins.
    Auto,
    /// In closed form from the modes (fast; the default).
    Analytic,
    /// The straightforward way: synthesize the modes, STFT, band sums (for comparison).
    Synthesized,
}

impl Default for EstimateParams {
    fn default() -> Self {
        Self {
            dominant: 5,
            max_iterations: 400,
            floor_db: 50.0,
            route: ImageRoute::Auto,
            warm_start: None,
        }
    }
}

/// Result of [`estimate`].
#[derive(Clone, Debug)]
pub struct Estimate {
    /// Best parameters.
    pub params: RayleighParams,
    /// Hybrid metric at the best parameters.
    pub metric: f64,
    /// Number of starting points.
    pub starts: usize,
    /// Metric evaluations in all.
    pub evaluations: usize,
}

/// Why estimation cannot run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum EstimateError {
    /// No reference modes.
    #[error("the recording gave no modes to match")]
    NoReferenceModes,
    /// Recording too short for one image frame.
    #[error("the recording is too short for the loudness image ({0} samples)")]
    TooShort(usize),
    /// No eigenvalue of the model can reach the recording's band.
    #[error("the modal model has no usable modes (need positive eigenvalues and non-zero gains)")]
    NoModelModes,
    /// The recording's loudness image holds nothing above its floor: every estimate matches it
    /// equally (metric 0).
    #[error("the recording's loudness image holds nothing above its floor (too short or too quiet): any material matches it")]
    Uninformative,
    /// Every start was invalid.
    #[error("no valid starting point: the dominant reference modes admit no Rayleigh circle with α, β ≥ 0")]
    NoStart,
}

/// The hybrid metric against a precomputed reference (image and feature points).
pub struct Objective<'a> {
    side: &'a ModalSide,
    grid: ImageGrid,
    reference_image: LoudnessImage,
    reference_points: Vec<FeaturePoint>,
    max_freq_hz: f64,
    route: ImageRoute,
    samples: usize,
}

impl<'a> Objective<'a> {
    /// Prepares the reference: `signal` (onset-aligned) and its analysed `modes`.
    pub fn new(
        side: &'a ModalSide,
        signal: &[f64],
        sample_rate_hz: f64,
        reference_modes: &[DampedMode],
        floor_db: f64,
        route: ImageRoute,
    ) -> Result<Self, EstimateError> {
        let grid = ImageGrid::new(sample_rate_hz, signal.len())
            .ok_or(EstimateError::TooShort(signal.len()))?;
        let raw = image_of_signal(signal, &grid);
        let grid = grid.with_floor_below(&raw, floor_db);
        let reference_image = image_of_signal(signal, &grid);
        Ok(Self {
            side,
            grid,
            reference_image,
            reference_points: reference_modes
                .iter()
                .map(|m| FeaturePoint::within(m, signal.len() as f64 / sample_rate_hz))
                .collect(),
            max_freq_hz: 0.5 * sample_rate_hz,
            route,
            samples: signal.len(),
        })
    }

    /// Estimated modes for `p`.
    pub fn modes(&self, p: &RayleighParams) -> Vec<DampedMode> {
        forward_modes(
            &self.side.eigenvalues0,
            &self.side.gains0,
            self.side.gamma0,
            p,
            self.max_freq_hz,
        )
    }

    /// The recording's loudness image.
    pub fn reference_image(&self) -> &LoudnessImage {
        &self.reference_image
    }

    /// The loudness image of the modes of `p` (closed form).
    pub fn image(&self, p: &RayleighParams) -> LoudnessImage {
        image_of_modes(&self.modes(p), &self.grid)
    }

    /// `Π_psycho / |Π_MRP|` (eq. 27); infinite for invalid parameters or no match at all.
    pub fn hybrid(&self, p: &RayleighParams) -> f64 {
        if !p.is_valid() {
            return f64::INFINITY;
        }
        let modes = self.modes(p);
        let route = match self.route {
            ImageRoute::Auto => {
                if analytic_cost(&modes, &self.grid)
                    < synthesized_cost(&modes, self.samples, &self.grid)
                {
                    ImageRoute::Analytic
                } else {
                    ImageRoute::Synthesized
                }
            }
            r => r,
        };
        let image = match route {
            ImageRoute::Analytic | ImageRoute::Auto => image_of_modes(&modes, &self.grid),
            ImageRoute::Synthesized => image_of_signal(
                &audible_signal(&modes, &self.grid, self.samples),
                &self.grid,
            ),
        };
        let psycho = image.distance(&self.reference_image);
        let duration = self.samples as f64 / self.grid.sample_rate_hz;
        let points: Vec<FeaturePoint> = modes
            .iter()
            .map(|m| FeaturePoint::within(m, duration))
            .collect();
        let mrp = match_ratio(&self.reference_points, &points)
            * match_ratio(&points, &self.reference_points);
        if !(mrp > 1e-12) {
            return f64::INFINITY;
        }
        psycho / mrp
    }
}

/// Rough cost (ns, calibrated on this machine by `resound bench estimate`) of [`image_of_modes`]:
/// a column set-up per bin and a complex update per cell, while the mode stands above the floor.
fn analytic_cost(modes: &[DampedMode], grid: &ImageGrid) -> f64 {
    let bin_hz = grid.sample_rate_hz / (2 * grid.window_len) as f64;
    let frames_per_s = grid.sample_rate_hz / grid.hop as f64;
    modes
        .iter()
        .map(|m| {
            let width = (16.0 + 8.0 * m.damping_per_s / TAU / bin_hz).min(600.0);
            let frames = (grid.audible_s(m) * frames_per_s + 2.0).min(grid.frames as f64);
            (2.0 * width + 1.0) * (60.0 + 3.0 * frames)
        })
        .sum::<f64>()
        + 2.0 * (grid.frames * (grid.window_len + 1)) as f64
}

/// Rough cost (ns) of synthesis ([`audible_signal`]: each mode while it is audible) +
/// [`image_of_signal`].
fn synthesized_cost(modes: &[DampedMode], samples: usize, grid: &ImageGrid) -> f64 {
    let fft = (2 * grid.window_len) as f64 * ((2 * grid.window_len) as f64).log2();
    let synthesis: usize = modes
        .iter()
        .map(|m| audible_samples(m, grid, samples))
        .sum();
    synthesis as f64 + 0.5 * grid.frames as f64 * fft
}

/// Parameters ↔ the optimizer's unconstrained vector (α, ln β, ln γ, ln σ); α is folded to ≥ 0.
pub(crate) fn to_vec(p: &RayleighParams) -> Vec<f64> {
    vec![p.alpha, p.beta.max(1e-15).ln(), p.gamma.ln(), p.sigma.ln()]
}

pub(crate) fn from_vec(v: &[f64]) -> RayleighParams {
    RayleighParams {
        alpha: v[0].abs(),
        beta: v[1].exp(),
        gamma: v[2].exp(),
        sigma: v[3].exp(),
    }
}

struct Cost<'a, 'b>(&'b Objective<'a>);

impl CostFunction for Cost<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, v: &Self::Param) -> Result<f64, ArgminError> {
        let m = self.0.hybrid(&from_vec(v));
        Ok(if m.is_finite() { m } else { 1e300 })
    }
}

/// (α, β) of the Rayleigh circle through two (f, d) points (eq. 8), if both are ≥ 0.
pub fn circle_through(a: &DampedMode, b: &DampedMode) -> Option<(f64, f64)> {
    let (w1, w2) = (TAU * a.freq_hz, TAU * b.freq_hz);
    let (d1, d2) = (a.damping_per_s, b.damping_per_s);
    if (d1 - d2).abs() < 1e-12 * (d1 + d2).max(1e-300) {
        return None;
    }
    // ω² + (d − y_c)² = R², y_c = 1/β, R² = (1 − αβ)/β².
    let yc = (w1 * w1 - w2 * w2 + d1 * d1 - d2 * d2) / (2.0 * (d1 - d2));
    if !(yc > 0.0) {
        return None;
    }
    let beta = 1.0 / yc;
    let r2 = w1 * w1 + (d1 - yc).powi(2);
    let alpha = (1.0 - r2 * beta * beta) / beta;
    (alpha >= -1e-9 * yc && beta.is_finite()).then_some((alpha.max(0.0), beta))
}

/// The starting points of §5.3 (dominance judged over up to 1 s).
pub fn starting_points(
    side: &ModalSide,
    reference: &[DampedMode],
    dominant: usize,
) -> Vec<RayleighParams> {
    starting_points_within(side, reference, dominant, 1.0)
}

/// [`starting_points`] for a recording `duration_s` long.
pub fn starting_points_within(
    side: &ModalSide,
    reference: &[DampedMode],
    dominant: usize,
    duration_s: f64,
) -> Vec<RayleighParams> {
    // Dominance is perceptual: the feature weight (loudness × duration). Raw energy would
    // crown the strike's click, a loud, near-Nyquist burst of a few milliseconds.
    let mut by_energy: Vec<&DampedMode> = reference.iter().collect();
    let energy = |m: &DampedMode| FeaturePoint::within(m, duration_s).weight;
    by_energy.sort_by(|a, b| energy(b).total_cmp(&energy(a)));
    by_energy.truncate(dominant.max(2));
    let Some(top) = by_energy.first().copied() else {
        return Vec::new();
    };
    // "No cheaper, louder" eigenvalues.
    let mut pareto: Vec<(f64, f64)> = Vec::new();
    let mut best_gain = 0.0f64;
    for (&l, &g) in side.eigenvalues0.iter().zip(&side.gains0) {
        if l > 0.0 && g.abs() > best_gain {
            best_gain = g.abs();
            pareto.push((l, g.abs()));
        }
    }
    let mut circles: Vec<(f64, f64)> = Vec::new();
    for i in 0..by_energy.len() {
        for j in i + 1..by_energy.len() {
            circles.extend(circle_through(by_energy[i], by_energy[j]));
        }
    }
    if circles.is_empty() {
        // One usable mode (or no valid circle): the family of circles through the dominant
        // mode, d = (α + βλ)/2 split between α and β in five ways.
        let lambda = (TAU * top.freq_hz).powi(2) + top.damping_per_s.powi(2);
        for share in [0.0, 0.25, 0.5, 0.75, 0.95] {
            let beta = share * 2.0 * top.damping_per_s / lambda;
            circles.push((2.0 * top.damping_per_s * (1.0 - share), beta));
        }
    }
    // Put eigenvalue λ⁰ (gain g⁰) on reference mode `target` for damping (α, β):
    // ω_d² = λ − d², d = (α + βλ)/2, solved for λ by a few fixed-point steps from λ = ω².
    let align = |alpha: f64, beta: f64, target: &DampedMode, l0: f64, g0: f64| {
        let w2 = (TAU * target.freq_hz).powi(2);
        let mut lambda = w2;
        for _ in 0..20 {
            let d = 0.5 * (alpha + beta * lambda);
            lambda = w2 + d * d;
        }
        let p = RayleighParams {
            alpha,
            beta,
            gamma: side.gamma0 * lambda / l0,
            sigma: target.amplitude / g0,
        };
        p.is_valid().then_some(p)
    };
    let mut out = Vec::new();
    for &(alpha, beta) in &circles {
        for &(l0, g0) in &pareto {
            out.extend(align(alpha, beta, top, l0, g0));
        }
    }
    // Real objects rarely match their mesh mode for mode: also try the next dominant reference
    // modes against the first audible eigenvalues, on the first circle. `estimate` keeps the
    // most promising starts.
    let loudest = side.gains0.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    let first: Vec<(f64, f64)> = side
        .eigenvalues0
        .iter()
        .zip(&side.gains0)
        .filter(|(&l, &g)| l > 0.0 && g.abs() > 1e-2 * loudest)
        .take(5)
        .map(|(&l, &g)| (l, g.abs()))
        .collect();
    if let Some(&(alpha, beta)) = circles.first() {
        for target in by_energy.iter().take(3) {
            for &(l0, g0) in &first {
                out.extend(align(alpha, beta, target, l0, g0));
            }
        }
    }
    out
}

/// Starts kept for Nelder–Mead: the rest are judged hopeless by their metric at the start.
pub const MAX_STARTS: usize = 12;

/// Usual starts kept beside a warm start ([`EstimateParams::warm_start`]): a guard against a
/// first estimate that paired the wrong modes, at a third of the usual cost. Only starts whose
/// metric at the start already beats the warm start's by more than 1 %, at a γ another pairing
/// gives (more than [`RIVAL_GAMMA_RATIO`] away), run: a warm start that is the optimum of a
/// search on fewer modes needs no rival in its own basin (there it differs from the usual
/// starts by its polished α, β only, which the refinement revisits anyway).
pub const WARM_OTHER_STARTS: usize = 3;

/// γ ratio beyond which a usual start lies in another basin than the warm start.
pub const RIVAL_GAMMA_RATIO: f64 = 1.02;

/// Estimates {α, β, γ, σ} from an onset-aligned recording `signal`, its analysed modes and the
/// object's modal side.
pub fn estimate(
    side: &ModalSide,
    signal: &[f64],
    sample_rate_hz: f64,
    reference_modes: &[DampedMode],
    params: &EstimateParams,
    on_start_done: &(dyn Fn() + Sync),
) -> Result<Estimate, EstimateError> {
    if reference_modes.is_empty() {
        return Err(EstimateError::NoReferenceModes);
    }
    if !side
        .eigenvalues0
        .iter()
        .zip(&side.gains0)
        .any(|(&l, &g)| l > 0.0 && g != 0.0)
    {
        return Err(EstimateError::NoModelModes);
    }
    let objective = Objective::new(
        side,
        signal,
        sample_rate_hz,
        reference_modes,
        params.floor_db,
        params.route,
    )?;
    let starts = starting_points_within(
        side,
        reference_modes,
        params.dominant,
        signal.len() as f64 / sample_rate_hz,
    );
    let warm = params.warm_start.filter(RayleighParams::is_valid);
    if starts.is_empty() && warm.is_none() {
        return Err(EstimateError::NoStart);
    }
    // Prune hopeless starts: one metric evaluation each, keep the best.
    let mut starts = starts;
    let (kept, to_beat) = match &warm {
        Some(w) => (
            WARM_OTHER_STARTS,
            Some(objective.hybrid(w))
                .filter(|m| !m.is_nan())
                .unwrap_or(f64::INFINITY),
        ),
        None => (MAX_STARTS, f64::INFINITY),
    };
    if starts.len() > kept || to_beat.is_finite() {
        let mut scored: Vec<(f64, RayleighParams)> = starts
            .par_iter()
            .map(|p| (objective.hybrid(p), *p))
            .collect();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        starts = scored
            .into_iter()
            .take(kept)
            // Without a warm start every kept start runs, whatever its metric (a take with
            // nothing to fit is left out later by its result, not here).
            // A warm start whose metric is not finite has no basin to guard: every kept
            // start runs beside it.
            .filter(|(m, p)| {
                warm.is_none_or(|w| {
                    !to_beat.is_finite()
                        || (*m < 0.99 * to_beat
                            && (p.gamma / w.gamma).ln().abs() > RIVAL_GAMMA_RATIO.ln())
                })
            })
            .map(|(_, p)| p)
            .collect();
    }
    starts.splice(0..0, warm);
    // Successive halving: every start gets a quarter of the iterations; of those still moving,
    // only the most promising quarter (at least two) goes on with the rest. Starts that end up best
    // are already ahead by then, and heavily damped cases spend most of their cost on the
    // others (wood-like on Spot: 5521 → ~3300 evaluations, same result).
    let first_iterations = (params.max_iterations / 4).max(20);
    let mut results: Vec<(RayleighParams, f64, usize, bool)> = starts
        .par_iter()
        .map(|p0| refine_start(&objective, p0, first_iterations, 0.1))
        .collect();
    let mut order: Vec<usize> = (0..results.len()).collect();
    order.sort_by(|&a, &b| results[a].1.total_cmp(&results[b].1));
    let keep = results.len().div_ceil(4).max(2).min(results.len());
    let going_on: Vec<usize> = order[..keep]
        .iter()
        .copied()
        .filter(|&i| !results[i].3)
        .collect();
    for _ in going_on.len()..results.len() {
        on_start_done();
    }
    let rest = params.max_iterations.saturating_sub(first_iterations);
    let continued: Vec<(usize, (RayleighParams, f64, usize, bool))> = going_on
        .par_iter()
        .map(|&i| {
            // Near its optimum already: a smaller simplex.
            let r = refine_start(&objective, &results[i].0, rest, 0.02);
            on_start_done();
            (i, r)
        })
        .collect();
    for (i, (p, m, e, c)) in continued {
        let evals = results[i].2 + e;
        if m <= results[i].1 {
            results[i] = (p, m, evals, c);
        } else {
            results[i].2 = evals;
        }
    }
    let evaluations: usize = results.iter().map(|r| r.2).sum();
    let best = results
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .ok_or(EstimateError::NoStart)?;
    let (params, metric) = polish_damping(
        &objective,
        reference_modes,
        signal.len() as f64 / sample_rate_hz,
        best.0,
        best.1,
    );
    Ok(Estimate {
        params,
        metric,
        starts: starts.len(),
        evaluations: evaluations + 1,
    })
}

/// Largest relative rise of the hybrid metric [`polish_damping`] accepts.
pub const POLISH_TOLERANCE: f64 = 0.02;

/// Pairs must carry this share of the recording's perceptual weight, with a median frequency
/// error within [`POLISH_MAX_FREQ_ERROR`], for [`polish_damping`] to trust them over the metric.
pub const POLISH_MIN_SHARE: f64 = 0.5;
/// See [`POLISH_MIN_SHARE`].
pub const POLISH_MAX_FREQ_ERROR: f64 = 0.005;
/// Even on the recorded object, a polish that makes the metric this many times worse is
/// refused: the dampings it rests on were not measured well (a decay the analysis split or
/// merged).
pub const POLISH_MAX_RISE_SAME_OBJECT: f64 = 3.0;

/// The loudness image pins γ and the damping of the loud modes, but it is nearly flat along
/// the Rayleigh curve's intercept (α moves the decay of a wood-like object's modes by a few
/// per cent only), and it is biased by the excitation: a finite contact filters the high
/// modes, which the impulse forward model can only mimic by raising β. The recorded dampings
/// pin both directly: with the modes paired (as in [`crate::report`]), `2d = α + βλ` holds for
/// each pair, λ the estimated mode's own eigenvalue. (α, β) by weighted least squares on it
/// (relative errors weighted by their precision a²/d; α, β ≥ 0) replace the metric's when at least three
/// pairs exist and either the metric rises by no more than [`POLISH_TOLERANCE`] or (by less
/// than [`POLISH_MAX_RISE_SAME_OBJECT`]×) the pairing shows the object is the recorded one (pairs carry ≥ [`POLISH_MIN_SHARE`] of the loudness at
/// a median frequency error ≤ [`POLISH_MAX_FREQ_ERROR`]). Where the pairs are another
/// object's modes, neither holds and the metric's (α, β) stand.
pub fn polish_damping(
    objective: &Objective<'_>,
    reference_modes: &[DampedMode],
    duration_s: f64,
    best: RayleighParams,
    best_metric: f64,
) -> (RayleighParams, f64) {
    let estimated = objective.modes(&best);
    let (pairs, weight) = crate::report::pair_modes(reference_modes, &estimated, duration_s);
    if pairs.len() < 3 {
        return (best, best_metric);
    }
    let share = pairs.iter().map(|p| p.2).sum::<f64>() / weight.max(1e-300);
    let mut errs: Vec<f64> = pairs
        .iter()
        .map(|(r, e, _)| (e.freq_hz / r.freq_hz - 1.0).abs())
        .collect();
    errs.sort_by(f64::total_cmp);
    let same_object = share >= POLISH_MIN_SHARE && errs[errs.len() / 2] <= POLISH_MAX_FREQ_ERROR;
    // In a dense spectrum the nearest estimated mode within 3 % may be a neighbour: the line
    // rests on close pairs only.
    let pairs: Vec<_> = pairs
        .into_iter()
        .filter(|(r, e, _)| (e.freq_hz / r.freq_hz - 1.0).abs() <= POLISH_MAX_FREQ_ERROR)
        .collect();
    if pairs.len() < 3 {
        return (best, best_metric);
    }
    // Rows (1, λ) → 2d, each divided by 2d (relative errors), weighted by the precision of a
    // measured damping: its relative variance in white noise goes as d / a² (the Cramér–Rao
    // bound), so a quick, quiet decay — also the one most disturbed by what the model leaves
    // out — counts least.
    let info: Vec<f64> = pairs
        .iter()
        .map(|(r, _, _)| r.amplitude * r.amplitude / r.damping_per_s.max(1e-3))
        .collect();
    let top = info.iter().copied().fold(0.0, f64::max);
    let rows: Vec<(f64, f64, f64, f64)> = pairs
        .iter()
        .zip(&info)
        .map(|((r, e, _), &w)| {
            let lambda = (TAU * e.freq_hz).powi(2) + e.damping_per_s.powi(2);
            let y = 2.0 * r.damping_per_s;
            (1.0 / y, lambda / y, 1.0, w.max(1e-9 * top))
        })
        .collect();
    let fit = |use_a: bool, use_b: bool| -> Option<(f64, f64)> {
        let (mut s11, mut s12, mut s22, mut t1, mut t2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(a, b, y, w) in &rows {
            let (a, b) = (if use_a { a } else { 0.0 }, if use_b { b } else { 0.0 });
            s11 += w * a * a;
            s12 += w * a * b;
            s22 += w * b * b;
            t1 += w * a * y;
            t2 += w * b * y;
        }
        match (use_a, use_b) {
            (true, true) => {
                let det = s11 * s22 - s12 * s12;
                (det.abs() > 1e-12 * s11 * s22)
                    .then(|| ((s22 * t1 - s12 * t2) / det, (s11 * t2 - s12 * t1) / det))
            }
            (true, false) => (s11 > 0.0).then(|| (t1 / s11, 0.0)),
            (false, true) => (s22 > 0.0).then(|| (0.0, t2 / s22)),
            _ => None,
        }
    };
    let (alpha, beta) = match fit(true, true) {
        Some((a, b)) if a >= 0.0 && b >= 0.0 => (a, b),
        Some((a, _)) if a < 0.0 => match fit(false, true) {
            Some(v) => v,
            None => return (best, best_metric),
        },
        Some(_) => match fit(true, false) {
            Some(v) => v,
            None => return (best, best_metric),
        },
        None => return (best, best_metric),
    };
    let polished = RayleighParams {
        alpha,
        beta,
        ..best
    };
    let m = objective.hybrid(&polished);
    let rise = m / best_metric.max(1e-300);
    if m.is_finite()
        && (rise <= 1.0 + POLISH_TOLERANCE || (same_object && rise <= POLISH_MAX_RISE_SAME_OBJECT))
    {
        (polished, m)
    } else {
        (best, best_metric)
    }
}

/// Nelder–Mead from one start; returns the best parameters, their metric and the evaluations.
fn refine_start(
    objective: &Objective<'_>,
    p0: &RayleighParams,
    max_iterations: u64,
    step: f64,
) -> (RayleighParams, f64, usize, bool) {
    let v0 = to_vec(p0);
    let mut simplex = vec![v0.clone()];
    for i in 0..4 {
        let mut v = v0.clone();
        v[i] += step * if i == 0 { 2.0 * p0.alpha.max(1.0) } else { 1.0 };
        simplex.push(v);
    }
    let start_metric = objective.hybrid(p0);
    let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(1e-9) else {
        return (*p0, start_metric, 1, true);
    };
    match Executor::new(Cost(objective), solver)
        .configure(|s| s.max_iters(max_iterations))
        .run()
    {
        Ok(res) => {
            let evals = res.state.counts.values().sum::<u64>() as usize;
            let converged = res.state.iter < max_iterations;
            match res.state.best_param.clone() {
                Some(v) => {
                    let p = from_vec(&v);
                    (p, objective.hybrid(&p), evals.max(1), converged)
                }
                None => (*p0, start_metric, evals.max(1), true),
            }
        }
        Err(_) => (*p0, start_metric, 1, true),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::damped::synthesize;

    /// A plate-like spectrum: 40 modes from 300 Hz, growing roughly like n^1.3, with gains that
    /// fall and vary.
    fn side() -> ModalSide {
        let gamma0 = 1.0e7;
        let eigenvalues0: Vec<f64> = (0..40)
            .map(|n| (TAU * 300.0 * (1.0 + n as f64).powf(1.3)).powi(2))
            .collect();
        let gains0: Vec<f64> = (0..40)
            .map(|n| 1e-5 / (1.0 + n as f64) * (1.0 + 0.6 * ((n * 7 % 5) as f64 - 2.0) / 2.0))
            .collect();
        ModalSide {
            eigenvalues0,
            gains0,
            gamma0,
        }
    }

    #[test]
    fn circle_through_recovers_rayleigh_parameters() {
        let p = RayleighParams {
            alpha: 8.0,
            beta: 3e-7,
            gamma: 1.0,
            sigma: 1.0,
        };
        let l: Vec<f64> = [(TAU * 500.0f64).powi(2), (TAU * 4000.0f64).powi(2)].to_vec();
        let m = forward_modes(&l, &[1.0, 1.0], 1.0, &p, 1e9);
        let (a, b) = circle_through(&m[0], &m[1]).unwrap();
        assert!(
            (a / 8.0 - 1.0).abs() < 1e-6 && (b / 3e-7 - 1.0).abs() < 1e-6,
            "{a} {b}"
        );
    }

    /// A metal-like material and the 0.5 s sound it gives [`side`] at 44.1 kHz: its modes
    /// and samples.
    fn own_sound(s: &ModalSide) -> (RayleighParams, Vec<DampedMode>, Vec<f64>) {
        let truth = RayleighParams {
            alpha: 6.0,
            beta: 2e-7,
            gamma: 2.3e7,
            sigma: 4.0e3,
        };
        let modes = forward_modes(&s.eigenvalues0, &s.gains0, s.gamma0, &truth, 0.5 * 44100.0);
        let x = synthesize(&modes, 44100.0, 22050);
        (truth, modes, x)
    }

    #[test]
    fn recovers_known_parameters_from_their_own_sound() {
        let s = side();
        let fs = 44100.0;
        let (truth, modes, x) = own_sound(&s);
        let est = estimate(&s, &x, fs, &modes, &EstimateParams::default(), &|| {}).unwrap();
        let p = est.params;
        for (name, got, want) in [
            ("alpha", p.alpha, truth.alpha),
            ("beta", p.beta, truth.beta),
            ("gamma", p.gamma, truth.gamma),
            ("sigma", p.sigma, truth.sigma),
        ] {
            assert!(
                (got / want - 1.0).abs() < 0.01,
                "{name}: {got} vs {want} ({est:?})"
            );
        }
        assert!(est.starts >= 1);
    }

    #[test]
    fn a_warm_start_runs_alone_only_while_no_usual_start_beats_it() {
        let s = side();
        let fs = 44100.0;
        let (truth, modes, x) = own_sound(&s);
        let run = |warm: RayleighParams| {
            let p = EstimateParams {
                warm_start: Some(warm),
                ..EstimateParams::default()
            };
            estimate(&s, &x, fs, &modes, &p, &|| {}).unwrap()
        };
        // At the optimum (a search on fewer modes found it): no usual start is better at the
        // start, so it runs alone.
        let near = run(truth);
        assert_eq!(near.starts, 1);
        assert!((near.params.gamma / truth.gamma - 1.0).abs() < 1e-3);
        // Two octaves off (another pairing): usual starts beat it and run beside it, and
        // the estimate still finds the truth.
        let far = run(RayleighParams {
            gamma: truth.gamma * 16.0,
            ..truth
        });
        assert!(far.starts > 1, "{far:?}");
        assert!(
            (far.params.gamma / truth.gamma - 1.0).abs() < 1e-3,
            "{far:?}"
        );
    }

    #[test]
    fn polish_puts_alpha_and_beta_on_the_recorded_dampings_of_the_same_object_only() {
        let s = side();
        let truth = RayleighParams {
            alpha: 3.0,
            beta: 5e-7,
            gamma: 2.3e7,
            sigma: 4.0e3,
        };
        let fs = 44100.0;
        let modes = forward_modes(&s.eigenvalues0, &s.gains0, s.gamma0, &truth, 0.5 * fs);
        let x = synthesize(&modes, fs, 22050);
        let o = Objective::new(&s, &x, fs, &modes, 50.0, ImageRoute::Auto).unwrap();
        let off = RayleighParams {
            alpha: 1.5,
            beta: 5.1e-7,
            ..truth
        };
        let (p, m) = polish_damping(&o, &modes, 0.5, off, o.hybrid(&off));
        assert!((p.alpha / truth.alpha - 1.0).abs() < 1e-3, "{p:?}");
        assert!((p.beta / truth.beta - 1.0).abs() < 1e-4, "{p:?}");
        assert!(m <= o.hybrid(&off));
        // Another object's modes (every recorded mode 2 % away): nothing is paired closely
        // enough, and the parameters stand.
        let other: Vec<DampedMode> = modes
            .iter()
            .map(|m| DampedMode {
                freq_hz: m.freq_hz * 1.02,
                ..*m
            })
            .collect();
        let (q, _) = polish_damping(&o, &other, 0.5, off, o.hybrid(&off));
        assert_eq!(q, off);
    }

    #[test]
    fn refuses_what_it_cannot_do() {
        let s = side();
        let x = vec![0.1; 4410];
        assert_eq!(
            estimate(&s, &x, 44100.0, &[], &EstimateParams::default(), &|| {}).unwrap_err(),
            EstimateError::NoReferenceModes
        );
        let empty = ModalSide {
            eigenvalues0: vec![0.0],
            gains0: vec![1.0],
            gamma0: 1.0,
        };
        let m = [DampedMode::new(500.0, 3.0, 0.1)];
        assert_eq!(
            estimate(&empty, &x, 44100.0, &m, &EstimateParams::default(), &|| {}).unwrap_err(),
            EstimateError::NoModelModes
        );
        assert!(matches!(
            estimate(
                &s,
                &x[..10],
                44100.0,
                &m,
                &EstimateParams::default(),
                &|| {}
            )
            .unwrap_err(),
            EstimateError::TooShort(10)
        ));
    }
}
