//! Estimating a material from recordings of a known object (Ren §5, with the §6.1 residual).

use crate::error::{invalid, Error, Result};
use resound_core::progress::{Progress, ProgressFn, Stage, Warning, WarningKind};
use resound_core::{DampedMode, Hit, ModalModel, Provenance, SoundMaterial};
use resound_estimate::estimate::{starting_points_within, Objective, MAX_STARTS};
use resound_estimate::{estimate, EstimateParams, ModalSide, RayleighParams};
use resound_signal::Analysis;
use serde::{Deserialize, Serialize};
#[cfg(feature = "plot")]
use std::path::Path;

/// Settings of [`estimate_material`].
#[derive(Clone, Debug)]
pub struct EstimateMaterialParams {
    /// Name of the material.
    pub name: String,
    /// The optimizer's settings.
    pub estimate: EstimateParams,
    /// Compute the §6.1 residual (stored with the material).
    pub residual: bool,
    /// Longest residual kept, s (a residual is mostly the strike's transient).
    pub max_residual_s: f64,
    /// Recorded in the material's provenance.
    pub recording_name: String,
    /// Recorded in the material's provenance.
    pub object_name: String,
    /// Keep an estimate whose parameters are not credible (β at the optimizer's floor, γ outside
    /// the range of solids) as a warning instead of an error.
    pub allow_implausible: bool,
    /// Where the microphone was (model coordinates, m; every take's): the forward model then
    /// weights each mode's gain by what it radiates there (the model's acoustic transfer,
    /// fitted on the spot when it holds none), as `synth --mic` renders it. `None`: every mode
    /// reaches the microphone alike (σ absorbs the average radiation).
    pub mic_m: Option<[f64; 3]>,
}

/// Smallest β the optimizer can express, s (it searches ln β; a start at β = 0 begins here).
pub const BETA_FLOOR_S: f64 = 1e-14;
/// γ = E/ρ of solids, m²/s²: from soft rubber (1 MPa / 1000 kg/m³) to diamond (1 TPa / 3500).
pub const GAMMA_RANGE_M2_S2: (f64, f64) = (1e3, 3e8);

impl Default for EstimateMaterialParams {
    fn default() -> Self {
        Self {
            name: "estimated".into(),
            estimate: EstimateParams::default(),
            residual: true,
            max_residual_s: 1.0,
            recording_name: String::new(),
            object_name: String::new(),
            allow_implausible: false,
            mic_m: None,
        }
    }
}

/// Recorded modes an estimate must pair with estimated ones to determine α, β and γ.
pub const MIN_PAIRED_MODES: usize = 3;

/// Loudness share the pairing must carry above what chance pairs
/// ([`resound_estimate::report::FitReport::share_over_chance`]) before the object is taken
/// for the recorded one without a warning.
pub const MIN_SHARE_OVER_CHANCE: f64 = 0.25;

/// What [`estimate_material`] found besides the material: the estimate's report, the one
/// document every front end shows (`resound estimate --json` prints it, Python receives it as a
/// dict made from it, the studio serves it).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EstimateInfo {
    /// The material's name.
    pub name: String,
    /// Best parameters: α 1/s, β s, γ m²/s², σ (at the top level of the document).
    #[serde(flatten)]
    pub params: RayleighParams,
    /// The first recording's analysed strike, counting from 1.
    pub strike: usize,
    /// Why that strike.
    pub strike_reason: String,
    /// Hybrid metric there (finite).
    pub metric: f64,
    /// Starting points run.
    pub starts: usize,
    /// Metric evaluations (of every run, with a microphone).
    pub evaluations: usize,
    /// Reference modes (the recording's features).
    pub reference_modes: usize,
    /// The estimated modes on the recorded object at the hit.
    pub estimated_modes: Vec<DampedMode>,
    /// Wall time, s.
    pub elapsed_s: f64,
    /// How sure the estimate is: paired modes, loudness share, α/β/γ standard errors.
    pub fit: resound_estimate::report::FitReport,
    /// Things the user should know (the object's lowest mode above every recorded one, …).
    pub warnings: Vec<Warning>,
    /// Each recording's part when several were combined (empty for one).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub takes: Vec<TakeReport>,
    /// How much the recordings' own estimates differ (two or more recordings).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spread: Option<TakeSpread>,
    /// The microphone the forward model radiated to, m (estimates with `mic_m`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mic: Option<[f64; 3]>,
    /// Estimates run: with a microphone the radiation factors depend on where γ puts the
    /// modes, so the estimate is rerun at its γ until the modes move by less than
    /// [`MIC_SETTLE_OCTAVES`] (at most [`MIC_PASSES`] runs); 1 without.
    pub passes: usize,
    /// Time spent fitting acoustic transfers the models did not hold, s.
    pub transfer_fit_s: f64,
}

impl std::fmt::Display for EstimateInfo {
    /// The parameters, the fit (pairing, loudness share, uncertainties), and the takes'
    /// spread when several recordings were combined (else why this strike was used).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = &self.params;
        writeln!(
            f,
            "{}: alpha {:.4e} 1/s, beta {:.4e} s, gamma {:.4e} m²/s², sigma {:.4e}; metric \
             {:.4e} ({} starts, {} evaluations, {:.1} s)",
            self.name,
            p.alpha,
            p.beta,
            p.gamma,
            p.sigma,
            self.metric,
            self.starts,
            self.evaluations,
            self.elapsed_s
        )?;
        if let Some(m) = self.mic {
            writeln!(
                f,
                "heard at the microphone {m:?} m (each mode's radiation there; {} estimate{} \
                 until γ settled)",
                self.passes,
                if self.passes == 1 { "" } else { "s" }
            )?;
        }
        let fit = &self.fit;
        let pm = |s: Option<f64>, unit: &str| {
            s.map_or("unknown".to_string(), |s| format!("± {s:.2e} {unit}"))
        };
        // With no mode paired there is no error to take a median of, and no loudness share.
        let error = if fit.paired_modes > 0 && fit.median_freq_error.is_finite() {
            format!(
                "median frequency error {:.2} %",
                100.0 * fit.median_freq_error
            )
        } else {
            "no frequency error: none paired".to_string()
        };
        writeln!(
            f,
            "fit: {} of {} recorded modes paired ({error}), {:.0} % of the recording's \
             loudness ({:.0} % by chance); alpha {}, beta {}, gamma {}",
            fit.paired_modes,
            fit.recorded_modes,
            // (-0 % printed when nothing was paired.)
            if fit.loudness_share > 0.0 {
                100.0 * fit.loudness_share
            } else {
                0.0
            },
            100.0 * fit.chance_share,
            pm(fit.alpha_sigma, "1/s"),
            pm(fit.beta_sigma, "s"),
            pm(fit.gamma_sigma, "m²/s²")
        )?;
        let Some(sp) = &self.spread else {
            return writeln!(f, "{}", self.strike_reason);
        };
        let n = self.takes.iter().filter(|t| !t.left_out).count();
        let out = self.takes.len() - n;
        let of = if out > 0 {
            format!(" ({} analysed, {out} left out)", self.takes.len())
        } else {
            String::new()
        };
        if n < 2 {
            // One take left: no spread to report (a standard deviation of one value is NaN).
            writeln!(
                f,
                "{n} recording combined{of}; one take cannot show a spread: its estimate is the \
                 combined one"
            )?;
        } else {
            writeln!(
                f,
                "{n} recordings combined{of}; their own estimates spread by alpha {:.1} %, beta \
                 {:.1} %, gamma {:.1} % (relative SD; the combined value's standard error is \
                 that over √{n})",
                100.0 * sp.alpha_rel_sd,
                100.0 * sp.beta_rel_sd,
                100.0 * sp.gamma_rel_sd,
            )?;
        }
        for t in &self.takes {
            if t.left_out {
                writeln!(f, "  {}: left out (nothing above its floor)", t.label)?;
                continue;
            }
            writeln!(
                f,
                "  {}: sigma {:.3e}, metric {:.3e} (alone: alpha {:.3e}, beta {:.3e}, gamma \
                 {:.3e}, metric {:.3e})",
                t.label,
                t.sigma,
                t.metric,
                t.alone.alpha,
                t.alone.beta,
                t.alone.gamma,
                t.alone_metric
            )?;
        }
        Ok(())
    }
}

/// With a microphone, the estimate is rerun while its γ moves the modes by more than this
/// (octaves): an eighth of the transfer grid's third-octave spacing.
pub const MIC_SETTLE_OCTAVES: f64 = 1.0 / 24.0;
/// Most estimates run with a microphone.
pub const MIC_PASSES: usize = 4;

/// [`modal_side`] as a microphone at `mic` hears it: each mode's gain times its radiation
/// factor there ([`crate::radiation::mic_factors`]) with the modes where a material of
/// stiffness ratio `gamma` puts them, and the warnings the factors came with.
///
/// # Errors
/// A transfer that does not belong to `model`; a non-finite microphone position.
pub fn heard_side(
    model: &ModalModel,
    hit: &Hit,
    transfer: &resound_core::AcousticTransfer,
    mic: [f64; 3],
    gamma: f64,
) -> Result<(ModalSide, Vec<Warning>)> {
    let freqs = crate::radiation::freqs_in(model, gamma);
    let (f, warnings) = crate::radiation::mic_factors(transfer, &freqs, mic)?;
    let mut side = modal_side(model, hit);
    for (g, f) in side.gains0.iter_mut().zip(&f) {
        *g *= f;
    }
    Ok((side, warnings))
}

/// One recording of a combined estimate ([`estimate_material_from`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TakeReport {
    /// The take's label (file, strike, channel).
    pub label: String,
    /// Its amplitude scale σ at the combined α, β, γ.
    pub sigma: f64,
    /// Its hybrid metric at the combined parameters.
    pub metric: f64,
    /// The take estimated alone.
    pub alone: RayleighParams,
    /// Its metric alone.
    pub alone_metric: f64,
    /// Left out of the combined estimate (its loudness image held nothing above its floor):
    /// its σ and metrics mean nothing.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub left_out: bool,
}

/// Relative standard deviations of the takes' own estimates: the measured variation between
/// strikes, microphones or objects, and the standard error of the combined value (that over
/// √takes).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct TakeSpread {
    /// Of α (relative to the mean).
    pub alpha_rel_sd: f64,
    /// Of β.
    pub beta_rel_sd: f64,
    /// Of γ.
    pub gamma_rel_sd: f64,
}

/// One recording of the material for [`estimate_material_from`].
#[derive(Clone, Copy, Debug)]
pub struct TakeInput<'a> {
    /// The analysed strike.
    pub analysis: &'a Analysis,
    /// The recorded object.
    pub model: &'a ModalModel,
    /// Where it was struck.
    pub hit: &'a Hit,
    /// A label for reports.
    pub label: &'a str,
}

/// The recorded object's side of the estimation: eigenvalues and gains at the hit.
pub fn modal_side(model: &ModalModel, hit: &Hit) -> ModalSide {
    ModalSide {
        eigenvalues0: model.eigenvalues.clone(),
        gains0: hit.gains.clone(),
        gamma0: model.gamma0(),
    }
}

/// How many starting points [`estimate_material`] will run.
fn start_count(
    model: &ModalModel,
    hit: &Hit,
    analysis: &Analysis,
    params: &EstimateParams,
) -> usize {
    let side = modal_side(model, hit);
    let len_s = analysis.segment.len() as f64 / analysis.sample_rate_hz;
    starting_points_within(&side, &analysis.modes, params.dominant, len_s)
        .len()
        .min(MAX_STARTS)
}

/// How many ticks the estimators make for `takes` (one per start, or one per take and the
/// joint fit).
fn take_tick_count(takes: &[TakeInput<'_>], params: &EstimateParams) -> usize {
    match takes {
        [t] => start_count(t.model, t.hit, t.analysis, params),
        _ => takes.len() + 1,
    }
}

/// Estimates the material of the object `model`, struck at `hit`, from `analysis` (its modes
/// and the very segment they were fitted to): α, β, γ, σ, then the §6.1 residual against the
/// estimated modes. `progress` hears [`Stage::Estimating`] and its fraction.
///
/// # Errors
/// No modes, a failed estimation, and a result that is not credible (a non-finite metric or
/// invalid values) — an error, never a material file that cannot be read back.
pub fn estimate_material(
    analysis: &Analysis,
    model: &ModalModel,
    hit: &Hit,
    params: &EstimateMaterialParams,
    progress: ProgressFn<'_>,
) -> Result<(SoundMaterial, EstimateInfo)> {
    let take = TakeInput {
        analysis,
        model,
        hit,
        label: &params.recording_name,
    };
    estimate_material_from(&[take], params, progress)
}

/// [`estimate_material`] from several recordings of one material — strikes of one file,
/// microphones of one strike, other objects of the material: α, β, γ are shared, each take
/// keeps its own σ ([`resound_estimate::joint`]). The material's σ, residual and provenance
/// features are the first take's. `progress` hears [`Stage::Estimating`]: the fraction of
/// starting points (one take) or of takes and the joint fit done, and every warning.
///
/// # Errors
/// As [`estimate_material`], for any take; no takes.
pub fn estimate_material_from(
    takes: &[TakeInput<'_>],
    params: &EstimateMaterialParams,
    progress: ProgressFn<'_>,
) -> Result<(SoundMaterial, EstimateInfo)> {
    let ticks = take_tick_count(takes, &params.estimate).max(1);
    let done = std::sync::atomic::AtomicUsize::new(0);
    progress(Progress::fraction(Stage::Estimating, 0.0));
    let tick = || {
        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        // With a microphone the fit runs again as γ settles: the bar restarts per pass.
        let k = (k - 1) % ticks + 1;
        progress(Progress::fraction(
            Stage::Estimating,
            k as f64 / ticks as f64,
        ));
    };
    let tick: &(dyn Fn() + Sync) = &tick;
    // Many modes: the search runs on the lowest few first (an evaluation's cost grows with
    // the modes, most with heavily damped high ones), then the estimate on all of them is
    // refined from its result, beside the best usual starts. With a microphone the modes'
    // weights change with γ: no shortcut there.
    let few = first_search_modes(takes.iter().map(|t| t.analysis));
    if params.estimate.warm_start.is_none()
        && params.mic_m.is_none()
        && takes.iter().all(|t| t.model.n_modes() > few)
    {
        let models: Vec<ModalModel> = takes.iter().map(|t| lowest_modes(t.model, few)).collect();
        let hits: Vec<Hit> = takes
            .iter()
            .map(|t| Hit {
                at: t.hit.at,
                gains: t.hit.gains.iter().take(few).copied().collect(),
            })
            .collect();
        let inputs: Vec<TakeInput<'_>> = takes
            .iter()
            .zip(models.iter().zip(&hits))
            .map(|(t, (model, hit))| TakeInput { model, hit, ..*t })
            .collect();
        let search = EstimateMaterialParams {
            residual: false,
            ..params.clone()
        };
        if let Ok((m, _)) = estimate_takes(&inputs, &search, tick) {
            let mut refine = params.clone();
            refine.estimate.warm_start = Some(as_start(&m));
            let result = estimate_takes(takes, &refine, tick)?;
            for w in &result.1.warnings {
                progress(Progress::Warning(w.clone()));
            }
            return Ok(result);
        }
    }
    let result = estimate_takes(takes, params, tick)?;
    for w in &result.1.warnings {
        progress(Progress::Warning(w.clone()));
    }
    Ok(result)
}

fn estimate_takes(
    takes: &[TakeInput<'_>],
    params: &EstimateMaterialParams,
    tick: &(dyn Fn() + Sync),
) -> Result<(SoundMaterial, EstimateInfo)> {
    let Some(first) = takes.first() else {
        return Err(invalid("no recordings to estimate from"));
    };
    for t in takes {
        if t.analysis.modes.is_empty() {
            return Err(invalid(format!(
                "no modes in the recording{}: nothing to estimate from",
                if t.label.is_empty() {
                    String::new()
                } else {
                    format!(" {}", t.label)
                }
            )));
        }
    }
    SoundMaterial::rayleigh(&params.name, 1.0, 1.0, 1.0, 1.0)
        .validate()
        .map_err(invalid)?;
    let t0 = std::time::Instant::now();
    let (analysis, model, hit) = (first.analysis, first.model, first.hit);
    let fs = analysis.sample_rate_hz;
    let seg = &analysis.segment;
    // With a microphone: each distinct model's acoustic transfer, fitted once if it has none.
    let mut transfer_fit_s = 0.0;
    let mut transfers: Vec<(
        *const ModalModel,
        std::borrow::Cow<'_, resound_core::AcousticTransfer>,
    )> = Vec::new();
    if params.mic_m.is_some() {
        for t in takes {
            if transfers.iter().any(|(m, _)| std::ptr::eq(*m, t.model)) {
                continue;
            }
            let t1 = std::time::Instant::now();
            let (tr, fitted) = crate::radiation::transfer_of(t.model)?;
            if fitted.is_some() {
                transfer_fit_s += t1.elapsed().as_secs_f64();
            }
            transfers.push((t.model as *const ModalModel, tr));
        }
    }
    let transfer_for = |m: &ModalModel| {
        transfers
            .iter()
            .find(|(p, _)| std::ptr::eq(*p, m))
            .map(|(_, t)| t.as_ref())
    };
    let mut mic_warnings = Vec::new();
    // The sides heard at the microphone when γ puts the modes at `gamma` (plain sides without).
    let sides_at = |gamma: f64, warnings: &mut Vec<Warning>| -> Result<Vec<ModalSide>> {
        takes
            .iter()
            .map(|t| match (params.mic_m, transfer_for(t.model)) {
                (Some(mic), Some(tr)) => {
                    let (side, w) = heard_side(t.model, t.hit, tr, mic, gamma)?;
                    for w in w {
                        if !warnings.contains(&w) {
                            warnings.push(w);
                        }
                    }
                    Ok(side)
                }
                _ => Ok(modal_side(t.model, t.hit)),
            })
            .collect()
    };
    let run = |sides: &[ModalSide]| -> Result<(
        resound_estimate::Estimate,
        Option<resound_estimate::JointEstimate>,
    )> {
        if takes.len() == 1 {
            let e = estimate(&sides[0], seg, fs, &analysis.modes, &params.estimate, tick)?;
            Ok((e, None))
        } else {
            let inputs: Vec<resound_estimate::Take<'_>> = takes
                .iter()
                .zip(sides)
                .map(|(t, side)| resound_estimate::Take {
                    side,
                    signal: &t.analysis.segment,
                    sample_rate_hz: t.analysis.sample_rate_hz,
                    reference_modes: &t.analysis.modes,
                })
                .collect();
            let j = resound_estimate::estimate_joint(&inputs, &params.estimate, tick)?;
            let e = resound_estimate::Estimate {
                params: j.params,
                metric: j.metric,
                starts: j.starts,
                evaluations: j.evaluations,
            };
            Ok((e, Some(j)))
        }
    };
    // Without a microphone one run. With one, the factors are taken where the model's own
    // material puts the modes, then where each estimate's γ does, until γ settles.
    let mut gamma = model.gamma0();
    let mut passes = 0;
    let mut evaluations = 0;
    let (sides, est, joint) = loop {
        let sides = sides_at(gamma, &mut Vec::new())?;
        let (est, joint) = run(&sides)?;
        passes += 1;
        evaluations += est.evaluations;
        let Some(_) = params.mic_m else {
            break (sides, est, joint);
        };
        if !est.params.gamma.is_finite() {
            break (sides, est, joint);
        }
        let moved_octaves = 0.5 * (est.params.gamma / gamma).log2().abs();
        if moved_octaves < MIC_SETTLE_OCTAVES || passes >= MIC_PASSES {
            if moved_octaves >= MIC_SETTLE_OCTAVES {
                mic_warnings.push(Warning::new(
                    WarningKind::Model,
                    format!(
                    "the radiation factors did not settle in {passes} estimates: the last moved \
                     the modes by {moved_octaves:.3} octaves"
                ),
                ));
            }
            // The sides the reports use: heard where the final γ puts the modes.
            let sides = sides_at(est.params.gamma, &mut mic_warnings)?;
            break (sides, est, joint);
        }
        gamma = est.params.gamma;
    };
    let side = sides[0].clone();
    if !(est.metric.is_finite() && est.metric > 0.0) {
        if est.metric == 0.0 {
            return Err(resound_estimate::EstimateError::Uninformative.into());
        }
        return Err(invalid(format!(
            "the estimate's metric is not finite ({}): the recording does not fit this object",
            est.metric
        )));
    }
    let p = est.params;
    let mut implausible = Vec::new();
    if p.beta <= BETA_FLOOR_S {
        implausible.push(Warning::new(WarningKind::Implausible, format!(
            "β = {:.1e} s sits at the optimizer's floor: the recording's decay rates do not grow with frequency as stiffness damping does (noise before the strike, a wrong object, or a wrong hit point)",
            p.beta
        )));
    }
    if !(GAMMA_RANGE_M2_S2.0..=GAMMA_RANGE_M2_S2.1).contains(&p.gamma) {
        implausible.push(Warning::new(WarningKind::Implausible, format!(
            "γ = E/ρ = {:.3e} m²/s² is outside the range of solids ({:.0e}–{:.0e}): the object's modes cannot be matched to the recording's (check its size, its unit and the hit)",
            p.gamma, GAMMA_RANGE_M2_S2.0, GAMMA_RANGE_M2_S2.1
        )));
    }
    let estimated = resound_estimate::forward_modes(
        &side.eigenvalues0,
        &side.gains0,
        side.gamma0,
        &p,
        0.5 * fs,
    );
    let residual = params.residual.then(|| {
        let mut r =
            resound_estimate::residual::compute_residual(seg, fs, &analysis.modes, &estimated);
        r.samples.truncate((params.max_residual_s * fs) as usize);
        r
    });
    let mut warnings = implausible;
    warnings.extend(mic_warnings);
    if let Some(j) = &joint {
        for &k in &j.left_out {
            warnings.push(Warning::new(WarningKind::Input, format!(
                "{} was left out: its loudness image holds nothing above its floor (too short or too quiet)",
                takes[k].label
            )));
        }
    }
    let sigmas: Vec<f64> = joint
        .as_ref()
        .map_or_else(|| vec![p.sigma], |j| j.sigmas.clone());
    let take_modes: Vec<Vec<DampedMode>> = sides
        .iter()
        .zip(takes)
        .zip(&sigmas)
        .map(|((side, t), &sigma)| {
            resound_estimate::forward_modes(
                &side.eigenvalues0,
                &side.gains0,
                side.gamma0,
                &RayleighParams { sigma, ..p },
                0.5 * t.analysis.sample_rate_hz,
            )
        })
        .collect();
    let pooled: Vec<(&[DampedMode], &[DampedMode], f64)> = takes
        .iter()
        .zip(&take_modes)
        .map(|(t, e)| {
            (
                t.analysis.modes.as_slice(),
                e.as_slice(),
                t.analysis.segment.len() as f64 / t.analysis.sample_rate_hz,
            )
        })
        .collect();
    let fit = resound_estimate::report::pooled_fit_report(&pooled, &p);
    let (take_reports, spread) = match &joint {
        None => (Vec::new(), None),
        Some(j) => {
            let reports: Vec<TakeReport> = takes
                .iter()
                .zip(&j.individual)
                .zip(j.sigmas.iter().zip(&j.take_metrics))
                .enumerate()
                .map(|(k, ((t, alone), (&sigma, &metric)))| TakeReport {
                    left_out: j.left_out.contains(&k),
                    label: t.label.to_string(),
                    sigma,
                    metric,
                    alone: alone.params,
                    alone_metric: alone.metric,
                })
                .collect();
            let rel_sd = |f: &dyn Fn(&RayleighParams) -> f64| {
                let x: Vec<f64> = j
                    .individual
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| !j.left_out.contains(k))
                    .map(|(_, e)| f(&e.params))
                    .collect();
                if x.len() < 2 {
                    return f64::NAN;
                }
                let mean = x.iter().sum::<f64>() / x.len() as f64;
                let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (x.len() - 1) as f64;
                if mean > 0.0 {
                    var.sqrt() / mean
                } else {
                    f64::NAN
                }
            };
            let spread = TakeSpread {
                alpha_rel_sd: rel_sd(&|p| p.alpha),
                beta_rel_sd: rel_sd(&|p| p.beta),
                gamma_rel_sd: rel_sd(&|p| p.gamma),
            };
            if spread.gamma_rel_sd > 0.1 {
                warnings.push(Warning::new(WarningKind::Implausible, format!(
                    "the recordings' own estimates of γ differ by {:.0} % (relative SD): they may not be of one material, or of the objects and hits given",
                    100.0 * spread.gamma_rel_sd
                )));
            }
            (reports, Some(spread))
        }
    };
    if p.alpha < 1e-6 {
        warnings.push(Warning::new(
            WarningKind::Model,
            format!(
                "α = {:.1e} 1/s sits at its bound (0): no mass damping is seen in this recording",
                p.alpha
            ),
        ));
    }
    if fit.paired_modes < MIN_PAIRED_MODES {
        warnings.push(Warning::new(WarningKind::Implausible, format!(
            "only {} of the {} recorded modes lie within 3 % of an estimated one: α, β and γ are not determined by fewer than {MIN_PAIRED_MODES}",
            fit.paired_modes,
            fit.recorded_modes,
        )));
    } else if fit.loudness_share < 0.25 {
        warnings.push(Warning::new(WarningKind::Implausible, format!(
            "the paired modes carry only {:.0} % of the recording's loudness: most of what is heard is not explained by this object",
            100.0 * fit.loudness_share
        )));
    } else if fit.share_over_chance() < MIN_SHARE_OVER_CHANCE {
        warnings.push(Warning::new(WarningKind::Model, format!(
            "the object's modes pair {:.0} % of the recording's loudness here and {:.0} % wherever else γ puts them (the median over scalings of ½–2): the pairing is mostly chance, so the object may not be the recorded one and α, β, γ not its material's",
            100.0 * fit.loudness_share,
            100.0 * fit.chance_share
        )));
    }
    let band_top = analysis.modes.iter().map(|m| m.freq_hz).fold(0.0, f64::max);
    let lowest = model.freq_hz(0) * (p.gamma / side.gamma0).sqrt();
    if lowest > band_top {
        warnings.push(Warning::new(
            WarningKind::Implausible,
            format!("the object's lowest mode ({lowest:.0} Hz) lies above every recorded mode"),
        ));
    }
    let material = SoundMaterial {
        residual,
        provenance: Some(Provenance {
            recording: params.recording_name.clone(),
            mesh: params.object_name.clone(),
            hit: hit.at.point,
            metric: est.metric,
            features: analysis.modes.clone(),
        }),
        ..SoundMaterial::rayleigh(&params.name, p.alpha, p.beta, p.gamma, p.sigma)
    };
    material.validate().map_err(invalid)?;
    let info = EstimateInfo {
        name: params.name.clone(),
        params: p,
        strike: analysis.strike + 1,
        strike_reason: analysis.strike_reason.clone(),
        metric: est.metric,
        starts: est.starts,
        evaluations,
        reference_modes: takes.iter().map(|t| t.analysis.modes.len()).sum(),
        estimated_modes: estimated,
        elapsed_s: t0.elapsed().as_secs_f64(),
        fit,
        warnings,
        takes: take_reports,
        spread,
        mic: params.mic_m,
        passes,
        transfer_fit_s,
    };
    // Every implausible finding (β at its floor, γ outside solids, too few modes paired, too
    // little of the loudness explained, …) refuses the material unless asked for; the error
    // carries the report, so a front end still shows what was found.
    let reasons: Vec<&str> = info
        .warnings
        .iter()
        .filter(|w| w.kind == WarningKind::Implausible)
        .map(|w| w.message.as_str())
        .collect();
    if !reasons.is_empty() && !params.allow_implausible {
        return Err(Error::Implausible(reasons.join("; "), Some(Box::new(info))));
    }
    Ok((material, info))
}

/// The picture of an estimate: features against the Rayleigh curve, and the two loudness
/// images the metric compares (estimated modes within 60 dB of the recording's strongest).
/// An estimate with a microphone is drawn as heard there (the model's transfer, fitted again
/// when the model holds none).
///
/// # Errors
/// Drawing or writing fails.
#[cfg(feature = "plot")]
pub fn estimate_plot(
    path: &Path,
    title: &str,
    analysis: &Analysis,
    model: &ModalModel,
    hit: &Hit,
    info: &EstimateInfo,
    params: &EstimateParams,
) -> Result<()> {
    let side = match info.mic {
        Some(mic) => {
            let (t, _) = crate::radiation::transfer_of(model)?;
            heard_side(model, hit, &t, mic, info.params.gamma)?.0
        }
        None => modal_side(model, hit),
    };
    let objective = Objective::new(
        &side,
        &analysis.segment,
        analysis.sample_rate_hz,
        &analysis.modes,
        params.floor_db,
        params.route,
    )?;
    let level = |m: &DampedMode| resound_signal::mode_level(m, resound_signal::LEVEL_WINDOW_S);
    // Within 60 dB of the estimate's own strongest mode: its levels are drawn relative to
    // their own peak (the plot showed none when the estimate's scale sat far below the
    // recording's).
    let modes = objective.modes(&info.params);
    let floor = modes.iter().map(level).fold(0.0, f64::max) * 1e-3;
    let shown: Vec<DampedMode> = modes.into_iter().filter(|m| level(m) >= floor).collect();
    resound_plot::estimate_png(
        path,
        &resound_plot::EstimatePlot {
            title,
            reference: &analysis.modes,
            estimated: &shown,
            alpha: info.params.alpha,
            beta: info.params.beta,
            reference_image: objective.reference_image(),
            estimated_image: &objective.image(&info.params),
        },
    )?;
    Ok(())
}

/// What [`estimate_files`] estimates from: recordings of an object in a file, struck at a
/// point — the inputs of `resound estimate`, of the studio's material step and of Python's
/// `estimate_material`.
#[derive(Clone, Debug)]
pub struct EstimateFiles {
    /// Recordings (several: microphones or takes of one material).
    pub recordings: Vec<std::path::PathBuf>,
    /// Channel and resampling of each recording.
    pub recording: crate::recording::RecordingParams,
    /// The analysis (high-pass, which strike).
    pub analyze: resound_signal::AnalyzeParams,
    /// Every strike and/or every channel as a take of its own.
    pub select: crate::recording::TakeSelection,
    /// The object: a mesh or a saved modal model.
    pub object: std::path::PathBuf,
    /// How a mesh is solved (scale, modes, reference material).
    pub object_params: crate::object::ObjectParams,
    /// Hit point, m (model coordinates; snapped to the surface).
    pub hit_m: [f64; 3],
    /// The estimate's settings (name, residual, microphone, …). `recording_name` and
    /// `object_name` are filled in from the files, and an empty `name` by the first
    /// recording's file stem.
    pub params: EstimateMaterialParams,
}

/// What [`estimate_files`] found: the material, its report, and what it was fitted to (for a
/// picture: [`estimate_plot`]).
#[derive(Debug)]
pub struct EstimateOutcome {
    /// The material.
    pub material: SoundMaterial,
    /// The report (`estimate --json`).
    pub info: EstimateInfo,
    /// The analysed takes, first the one the report's features are from.
    pub takes: Vec<crate::recording::AnalysedTake>,
    /// The object's model (with its acoustic transfer when a microphone was given).
    pub model: ModalModel,
    /// The hit on the model's surface.
    pub hit: Hit,
    /// What was done on the way (takes skipped, the hit snapped, a transfer fitted).
    pub notes: Vec<String>,
}

impl EstimateOutcome {
    /// Draws the estimate ([`estimate_plot`]) against the first take's analysis to `path`.
    ///
    /// # Errors
    /// No take; as [`estimate_plot`].
    pub fn plot(&self, path: &Path, title: &str, params: &EstimateParams) -> Result<()> {
        let take = self
            .takes
            .first()
            .ok_or_else(|| Error::Invalid("no take to draw the estimate against".into()))?;
        estimate_plot(
            path,
            title,
            &take.analysis,
            &self.model,
            &self.hit,
            &self.info,
            params,
        )
    }
}

/// Analyses `job`'s recordings, loads or solves the object and estimates the material
/// ([`estimate_on_model`]). `progress` hears every stage: the modal solve, the acoustic
/// transfer (with a microphone and a model without one) and the estimate.
///
/// # Errors
/// As the steps: unreadable files, no modes in any take, a hit off the model, a failed or
/// implausible estimate.
pub fn estimate_files(job: &EstimateFiles, progress: ProgressFn<'_>) -> Result<EstimateOutcome> {
    let mut notes = Vec::new();
    let mut analysed = Vec::new();
    for path in &job.recordings {
        let (takes, skipped) =
            crate::recording::analyze_takes(path, &job.recording, &job.analyze, job.select)?;
        notes.extend(skipped.iter().map(|s| format!("skipped {s}")));
        analysed.extend(takes);
    }
    if analysed.len() > 1 {
        notes.push(crate::joint::share_poles(
            &mut analysed,
            &Default::default(),
        ));
    }
    crate::object::check_hit_before_solve(&job.object, job.object_params.scale, job.hit_m)?;
    if let Some(mic) = job.params.mic_m {
        crate::object::check_mic_before_solve(&job.object, job.object_params.scale, mic)?;
    }
    let mut params = EstimateMaterialParams {
        object_name: job.object.display().to_string(),
        ..job.params.clone()
    };
    if params.name.is_empty() {
        params.name = job
            .recordings
            .first()
            .and_then(|p| p.file_stem())
            .map_or_else(|| "estimated".into(), |s| s.to_string_lossy().into_owned());
    }
    let full = &job.object_params;
    // The band heard: to 20 kHz and every recorded mode, within the recordings' Nyquist
    // frequency. Modes above it inform no estimate.
    let nyquist_hz = analysed
        .iter()
        .map(|t| 0.5 * t.analysis.sample_rate_hz)
        .fold(f64::INFINITY, f64::min);
    let highest_hz = analysed
        .iter()
        .flat_map(|t| t.analysis.modes.iter().map(|m| m.freq_hz))
        .fold(0.0, f64::max);
    let top_hz = AUDIBLE_TOP_HZ.max(1.05 * highest_hz).min(nyquist_hz);
    let first_count = first_search_modes(analysed.iter().map(|t| &t.analysis));
    let solve_and_estimate = |object_params: &crate::object::ObjectParams,
                              takes: Vec<crate::recording::AnalysedTake>,
                              warm: Option<&SoundMaterial>|
     -> Result<EstimateOutcome> {
        let (model, solve_warnings) =
            crate::object::load_object_warned(&job.object, object_params, progress)?;
        for w in &solve_warnings {
            progress(crate::Progress::Warning(w.clone()));
        }
        let mut params = params.clone();
        params.estimate.warm_start = warm.map(as_start);
        let mut out = estimate_on_model(takes, model, job.hit_m, &params, progress)?;
        out.info.warnings.splice(0..0, solve_warnings);
        Ok(out)
    };
    let mut out = match full.modal.n_modes {
        // A mesh, a mode count and no cutoff: γ is what is estimated, so the band of modes
        // that sounds is known only after a first estimate. Solve a few modes, estimate,
        // then solve (at most the count) up to the band in the estimated material when the
        // first solve fell short of it. A first estimate that fails is redone the long way.
        Some(n)
            if first_count < n
                && full.modal.max_freq_hz.is_none()
                && !crate::object::is_model_file(&job.object) =>
        {
            // The band, guessed: the lowest recorded mode is at or above the object's
            // fundamental, which a coarse solve of a few modes places (a coarse model rings a
            // little high: the guess errs wide). A wrong guess (the fundamental unheard) is
            // caught below by the first estimate.
            let lowest_hz = analysed
                .iter()
                .flat_map(|t| t.analysis.modes.iter().map(|m| m.freq_hz))
                .filter(|f| *f > 0.0)
                .fold(f64::INFINITY, f64::min);
            let mut first = full.clone();
            first.modal.n_modes = Some(first_count);
            if let Some(coarse) = coarse_freqs_hz(&job.object, full, first_count, progress) {
                let gamma0 = full.reference_material.stiffness_density_ratio();
                let gamma_max = gamma0 * (lowest_hz / (1.1 * coarse[0])).powi(2);
                let band = full.band_limited(gamma_max, top_hz);
                // A band of fewer modes than a first search needs is solved as that count.
                if band
                    .modal
                    .max_freq_hz
                    .is_some_and(|f| coarse.iter().all(|&c| c < f))
                {
                    first = band;
                }
            }
            match solve_and_estimate(&first, analysed.clone(), None) {
                Ok(out) => {
                    let gamma0 = out.model.gamma0();
                    let solved = out.model.n_modes();
                    let covered_hz = out.model.eigenvalues.last().map_or(0.0, |&l| {
                        resound_core::units::lambda_to_freq_hz(l * out.material.gamma / gamma0)
                    });
                    if covered_hz >= top_hz || solved >= n {
                        notes.push(format!(
                            "solved {solved} modes: with the estimated γ they reach \
                             {covered_hz:.0} Hz{}",
                            if covered_hz >= top_hz {
                                format!(", past the {top_hz:.0} Hz heard")
                            } else {
                                String::new()
                            }
                        ));
                        out
                    } else {
                        // γ may come out lower once more modes are in: margin of 20 %.
                        let band = full.band_limited(out.material.gamma / 1.2, top_hz);
                        // Refined from the first estimate (its low modes are these).
                        let out = solve_and_estimate(&band, analysed, Some(&out.material))?;
                        notes.push(format!(
                            "solved {} modes, up to {top_hz:.0} Hz in the material first \
                             estimated (the lowest {solved} reached {covered_hz:.0} Hz)",
                            out.model.n_modes()
                        ));
                        out
                    }
                }
                Err(_) => solve_and_estimate(full, analysed, None)?,
            }
        }
        _ => solve_and_estimate(full, analysed, None)?,
    };
    notes.append(&mut out.notes);
    out.notes = notes;
    Ok(out)
}

/// Modes of an estimate's first search: [`FIRST_PASS_MODES`], or twice the most modes one
/// take shows when more.
fn first_search_modes<'a>(analyses: impl Iterator<Item = &'a Analysis>) -> usize {
    analyses
        .map(|a| 2 * a.modes.len())
        .max()
        .unwrap_or(0)
        .max(FIRST_PASS_MODES)
}

/// A material as a start of the estimate's search.
fn as_start(m: &SoundMaterial) -> RayleighParams {
    RayleighParams {
        alpha: m.alpha,
        beta: m.beta,
        gamma: m.gamma,
        sigma: m.sigma,
    }
}

/// `model` with only its lowest `k` modes.
fn lowest_modes(model: &ModalModel, k: usize) -> ModalModel {
    let values = model.vertices.len() * 3;
    let mut m = model.clone();
    m.eigenvalues.truncate(k);
    m.shapes.truncate(k * values);
    if let Some(t) = &mut m.transfer {
        t.modes.truncate(k);
    }
    m
}

/// The lowest `count` frequencies (Hz, in the reference material) of the mesh in `path` by a
/// coarse solve: a quarter of the voxels (or half the resolution), no inertia check. `None`
/// when that solve fails or gives fewer (the caller then sizes its first solve by a count).
fn coarse_freqs_hz(
    path: &Path,
    full: &crate::object::ObjectParams,
    count: usize,
    progress: crate::ProgressFn<'_>,
) -> Option<Vec<f64>> {
    let mut modal = full.modal.clone();
    modal.n_modes = Some(count);
    modal.max_freq_hz = None;
    modal.sturm_check = false;
    if modal.resolution == 0 {
        modal.target_voxels = (modal.target_voxels / 4).max(500);
    } else {
        modal.resolution = (modal.resolution / 2).max(4);
    }
    let solved = crate::object::solve_mesh_file(
        path,
        full.scale,
        &full.reference_material,
        &modal,
        progress,
    )
    .ok()?;
    let f: Vec<f64> = solved
        .model
        .eigenvalues
        .iter()
        .map(|&l| resound_core::units::lambda_to_freq_hz(l))
        .collect();
    (f.len() == count && f[0] > 0.0 && f.iter().all(|v| v.is_finite())).then_some(f)
}

/// The top of the band a person hears, Hz: modes above it inform no estimate.
const AUDIBLE_TOP_HZ: f64 = 20_000.0;

/// Modes of an estimate's first search, at least (twice the most modes one take shows, when
/// more): enough for a first γ, refined on every mode after (and a first solve's count when
/// no coarse solve could place the fundamental).
const FIRST_PASS_MODES: usize = 24;

/// Estimates the material of `model`, struck near `hit_m` (snapped to the surface), from
/// analysed takes ([`estimate_material_from`]): fits the model's acoustic transfer first when
/// a microphone is given and the model has none. The report's warnings hold the takes'
/// analysis warnings too; `params.recording_name` is the takes' labels.
///
/// # Errors
/// No takes, a hit off the model, a failed or implausible estimate.
pub fn estimate_on_model(
    takes: Vec<crate::recording::AnalysedTake>,
    mut model: ModalModel,
    hit_m: [f64; 3],
    params: &EstimateMaterialParams,
    progress: ProgressFn<'_>,
) -> Result<EstimateOutcome> {
    if takes.is_empty() {
        return Err(invalid("no recordings to estimate from"));
    }
    let mut notes = Vec::new();
    let mut warnings: Vec<Warning> = takes
        .iter()
        .flat_map(|t| t.analysis.warnings.iter().cloned())
        .collect();
    if params.mic_m.is_some() && model.transfer.is_none() {
        progress(Progress::begin(Stage::Transfer));
        let t0 = std::time::Instant::now();
        let info = crate::radiation::add_transfer(
            &mut model,
            &resound_modal::radiation::TransferParams::default(),
        )?;
        notes.push(format!(
            "fitted the acoustic transfer of {} modes in {:.1} s (a model saved with its \
             transfer skips this)",
            model.n_modes(),
            t0.elapsed().as_secs_f64()
        ));
        if info.poorly_fitted > 0 {
            warnings.push(Warning::new(
                WarningKind::PoorTransfer,
                format!(
                    "the acoustic transfer fits {} modes poorly (misfit > {})",
                    info.poorly_fitted,
                    resound_core::limits::POOR_TRANSFER_MISFIT
                ),
            ));
        }
    }
    let (hit, note) = crate::object::snap_hit(&model, hit_m)?;
    notes.extend(note);
    let params = EstimateMaterialParams {
        recording_name: takes
            .iter()
            .map(|t| t.label.as_str())
            .collect::<Vec<_>>()
            .join("; "),
        ..params.clone()
    };
    let inputs: Vec<TakeInput<'_>> = takes
        .iter()
        .map(|t| TakeInput {
            analysis: &t.analysis,
            model: &model,
            hit: &hit,
            label: &t.label,
        })
        .collect();
    let (material, mut info) = estimate_material_from(&inputs, &params, progress)?;
    drop(inputs);
    warnings.append(&mut info.warnings);
    info.warnings = warnings;
    Ok(EstimateOutcome {
        material,
        info,
        takes,
        model,
        hit,
        notes,
    })
}
