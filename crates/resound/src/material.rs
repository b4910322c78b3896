//! Materials: finding one (file, library, preset) and estimating one from a recording (Ren §5,
//! with the §6.1 residual).

use crate::error::{invalid, Error, Result};
use resound_core::{DampedMode, Hit, Material, ModalModel, Provenance, SoundMaterial};
use resound_estimate::estimate::{starting_points_within, Objective, MAX_STARTS};
use resound_estimate::{estimate, EstimateParams, ModalSide, RayleighParams};
use resound_io::library::{default_library_path, read_material, Library};
use resound_signal::Analysis;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The library at `path`, or the default one ($RESOUND_LIBRARY, else
/// ~/.local/share/resound/materials.sqlite).
///
/// # Errors
/// No home directory for the default; the library cannot be opened.
pub fn open_library(path: Option<&Path>) -> Result<Library> {
    let path: PathBuf = match path {
        Some(p) => p.to_path_buf(),
        None => default_library_path().ok_or_else(|| {
            invalid("no home directory for the default library; name a library file")
        })?,
    };
    Library::open(&path).map_err(|e| {
        Error::from(e).context(format!("opening the material library {}", path.display()))
    })
}

/// Refuses a `name` the library at `path` (or the default one) already holds, unless
/// `replace`: the check before a long estimate whose result will be stored under it.
///
/// # Errors
/// [`Error::Exists`]; an unreadable library.
pub fn check_name_free(path: Option<&Path>, name: &str, replace: bool) -> Result<()> {
    if replace {
        return Ok(());
    }
    match read_library(path)? {
        Some(lib) if lib.get(name)?.is_some() => Err(Error::Exists(name.to_string())),
        _ => Ok(()),
    }
}

/// Stores `material` in the library at `path` (or the default one, created if need be) under
/// its name; an existing entry of that name is replaced only with `replace` — never silently.
///
/// # Errors
/// [`Error::Exists`]; a library that cannot be opened or written.
pub fn store_material(path: Option<&Path>, material: &SoundMaterial, replace: bool) -> Result<()> {
    let mut lib = open_library(path)?;
    if !replace && lib.get(&material.name)?.is_some() {
        return Err(Error::Exists(material.name.clone()));
    }
    Ok(lib.put(material)?)
}

/// The library at `path` (or the default one) for reading: `None` when it does not exist yet.
/// Never creates or changes a file.
///
/// # Errors
/// A file that is not a library; no home directory for the default.
pub fn read_library(path: Option<&Path>) -> Result<Option<Library>> {
    let path: PathBuf = match path {
        Some(p) => p.to_path_buf(),
        None => default_library_path().ok_or_else(|| {
            invalid("no home directory for the default library; name a library file")
        })?,
    };
    Ok(Library::open_read_only(&path)?)
}

/// A library entry by name, else the built-in of that name (with or without a library); a
/// missing name lists the known ones. A library entry holding Ren's Table I in mesh units (as
/// earlier versions seeded) is an error that says how to replace it.
///
/// # Errors
/// Unknown names, legacy entries, unreadable libraries.
pub fn library_material(lib: Option<&Library>, name: &str) -> Result<SoundMaterial> {
    if let Some(l) = lib {
        if let Some(m) = l.get(name)? {
            return not_legacy(m, l.path());
        }
    }
    SoundMaterial::builtin_named(name).ok_or_else(|| {
        let mut known: Vec<String> = match lib {
            Some(l) => l.names().unwrap_or_default(),
            None => Vec::new(),
        };
        known.extend(SoundMaterial::builtin().into_iter().map(|m| m.name));
        known.sort();
        known.dedup();
        invalid(format!(
            "no material {name:?} in the library (known: {})",
            known.join(", ")
        ))
    })
}

/// Where a listed material comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// Built in, not (or not differently) stored in the library.
    Builtin,
    /// Stored in the library without provenance (imported, or a seeded built-in).
    Library,
    /// Estimated from a recording.
    Estimated,
    /// Ren's Table I in mesh units, seeded by an earlier version: remove it.
    LegacyTable1,
}

/// Every material a name can reach: the library's entries and the built-ins it does not hold,
/// sorted by name.
///
/// # Errors
/// Unreadable libraries.
pub fn list_materials(lib: Option<&Library>) -> Result<Vec<(SoundMaterial, Origin)>> {
    let mut out = Vec::new();
    if let Some(l) = lib {
        for n in l.names()? {
            let Some(m) = l.get(&n)? else { continue };
            let origin = if m.is_legacy_table_1() {
                Origin::LegacyTable1
            } else if m.provenance.is_some() {
                Origin::Estimated
            } else if SoundMaterial::builtin_named(&n).as_ref() == Some(&m) {
                Origin::Builtin
            } else {
                Origin::Library
            };
            out.push((m, origin));
        }
    }
    for b in SoundMaterial::builtin() {
        if !out.iter().any(|(m, _)| m.name == b.name) {
            out.push((b, Origin::Builtin));
        }
    }
    out.sort_by(|a, b| a.0.name.cmp(&b.0.name));
    Ok(out)
}

fn not_legacy(m: SoundMaterial, library: &Path) -> Result<SoundMaterial> {
    if !m.is_legacy_table_1() {
        return Ok(m);
    }
    Err(invalid(format!(
        "library entry {:?} in {} holds Ren 2013 Table I as printed, in his meshes' units \
         (γ = {:.4e} m²/s², σ = {:.4e}): on a mesh in metres it renders several times too low \
         in pitch and near −150 dBFS. Earlier versions seeded libraries with it. Remove it \
         (`resound materials remove {}`) and the SI built-in of that name is used",
        m.name,
        library.display(),
        m.gamma,
        m.sigma,
        m.name
    )))
}

/// The Rayleigh α, β of the built-in (Ren Table I) material that matches an elastic preset.
fn table_damping(preset: &str) -> Option<(f64, f64)> {
    let ren = match preset {
        "steel" | "aluminium" => "metal",
        "ceramic" => "porcelain",
        "glass" => "glass",
        "wood" => "wood",
        "plastic" => "plastic",
        _ => return None,
    };
    SoundMaterial::builtin_named(ren).map(|m| (m.alpha, m.beta))
}

/// `preset:NAME` as a sound material: an elastic preset's γ = E/ρ with the Rayleigh damping of
/// the matching Ren 2013 Table I material (steel and aluminium → metal, ceramic → porcelain),
/// σ = [`resound_core::DEFAULT_SIGMA`].
pub fn preset_sound_material(name: &str) -> Option<SoundMaterial> {
    let m = Material::preset(name).ok()?;
    let (alpha, beta) = table_damping(name)?;
    Some(SoundMaterial::rayleigh(
        &format!("preset:{name}"),
        alpha,
        beta,
        m.stiffness_density_ratio(),
        resound_core::DEFAULT_SIGMA,
    ))
}

/// Resolves a material reference: `preset:NAME`, a material file (relative to `base_dir`), a
/// library name, a built-in name ([`SoundMaterial::builtin`]) or a plain preset name. The
/// result is validated.
///
/// # Errors
/// Unknown references, unreadable files, invalid values, legacy library entries.
pub fn resolve_material(
    spec: &str,
    base_dir: &Path,
    library: Option<&Library>,
) -> Result<SoundMaterial> {
    let m = if let Some(p) = spec.strip_prefix("preset:") {
        preset_sound_material(p).ok_or_else(|| {
            invalid(format!(
                "unknown preset {p:?} (steel, aluminium, glass, ceramic, wood, plastic)"
            ))
        })?
    } else {
        let path = base_dir.join(spec);
        if spec.to_ascii_lowercase().ends_with(".json") || path.is_file() {
            read_material(&path)?
        } else {
            let entry = match library {
                Some(l) => l.get(spec)?.map(|m| not_legacy(m, l.path())).transpose()?,
                None => None,
            };
            match entry
                .or_else(|| SoundMaterial::builtin_named(spec))
                .or_else(|| preset_sound_material(spec))
            {
                Some(m) => m,
                None => {
                    return Err(invalid(format!(
                        "no material {spec:?} in the library, no such file, and neither a \
                         built-in (wood, plastic, metal, glass, porcelain) nor a preset"
                    )))
                }
            }
        }
    };
    m.validate().map_err(invalid)?;
    Ok(m)
}

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
    pub warnings: Vec<String>,
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
) -> Result<(ModalSide, Vec<String>)> {
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

/// How many starting points [`estimate_material`] will run (for a progress bar).
pub fn start_count(
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

/// How many progress ticks [`estimate_material_from`] makes for `takes`.
pub fn take_tick_count(takes: &[TakeInput<'_>], params: &EstimateParams) -> usize {
    match takes {
        [t] => start_count(t.model, t.hit, t.analysis, params),
        _ => takes.len() + 1,
    }
}

/// Estimates the material of the object `model`, struck at `hit`, from `analysis` (its modes
/// and the very segment they were fitted to): α, β, γ, σ, then the §6.1 residual against the
/// estimated modes. `tick` is called after each starting point.
///
/// # Errors
/// No modes, a failed estimation, and a result that is not credible (a non-finite metric or
/// invalid values) — an error, never a material file that cannot be read back.
pub fn estimate_material(
    analysis: &Analysis,
    model: &ModalModel,
    hit: &Hit,
    params: &EstimateMaterialParams,
    tick: &(dyn Fn() + Sync),
) -> Result<(SoundMaterial, EstimateInfo)> {
    let take = TakeInput {
        analysis,
        model,
        hit,
        label: &params.recording_name,
    };
    estimate_material_from(&[take], params, tick)
}

/// [`estimate_material`] from several recordings of one material — strikes of one file,
/// microphones of one strike, other objects of the material: α, β, γ are shared, each take
/// keeps its own σ ([`resound_estimate::joint`]). The material's σ, residual and provenance
/// features are the first take's. `tick` is called after each take's own estimate and after
/// the joint fit (after each starting point for one take).
///
/// # Errors
/// As [`estimate_material`], for any take; no takes.
pub fn estimate_material_from(
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
    let sides_at = |gamma: f64, warnings: &mut Vec<String>| -> Result<Vec<ModalSide>> {
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
                mic_warnings.push(format!(
                    "the radiation factors did not settle in {passes} estimates: the last moved \
                     the modes by {moved_octaves:.3} octaves"
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
        implausible.push(format!(
            "β = {:.1e} s sits at the optimizer's floor: the recording's decay rates do not grow with frequency as stiffness damping does (noise before the strike, a wrong object, or a wrong hit point)",
            p.beta
        ));
    }
    if !(GAMMA_RANGE_M2_S2.0..=GAMMA_RANGE_M2_S2.1).contains(&p.gamma) {
        implausible.push(format!(
            "γ = E/ρ = {:.3e} m²/s² is outside the range of solids ({:.0e}–{:.0e}): the object's modes cannot be matched to the recording's (check its size, --scale and the hit)",
            p.gamma, GAMMA_RANGE_M2_S2.0, GAMMA_RANGE_M2_S2.1
        ));
    }
    if !implausible.is_empty() && !params.allow_implausible {
        return Err(invalid(format!(
            "the estimate is not credible: {} (keep it anyway with --allow-implausible)",
            implausible.join("; ")
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
            warnings.push(format!(
                "{} was left out: its loudness image holds nothing above its floor (too short or too quiet)",
                takes[k].label
            ));
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
                .map(|((t, alone), (&sigma, &metric))| TakeReport {
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
                warnings.push(format!(
                    "the recordings' own estimates of γ differ by {:.0} % (relative SD): they may not be of one material, or of the objects and hits given",
                    100.0 * spread.gamma_rel_sd
                ));
            }
            (reports, Some(spread))
        }
    };
    if p.alpha < 1e-6 {
        warnings.push(format!(
            "α = {:.1e} 1/s sits at its bound (0): no mass damping is seen; α is not determined by this recording",
            p.alpha
        ));
    }
    if fit.paired_modes < 2 {
        warnings.push(format!(
            "only {} recorded mode(s) lie within 3 % of an estimated one: γ rests on one mode and α, β are not determined",
            fit.paired_modes
        ));
    } else if fit.loudness_share < 0.25 {
        warnings.push(format!(
            "the paired modes carry only {:.0} % of the recording's loudness: most of what is heard is not explained by this object",
            100.0 * fit.loudness_share
        ));
    }
    let band_top = analysis.modes.iter().map(|m| m.freq_hz).fold(0.0, f64::max);
    let lowest = model.freq_hz(0) * (p.gamma / side.gamma0).sqrt();
    if lowest > band_top {
        warnings.push(format!(
            "the object's lowest mode ({lowest:.0} Hz) lies above every recorded mode"
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
    let floor = analysis.modes.iter().map(level).fold(0.0, f64::max) * 1e-3;
    let shown: Vec<DampedMode> = objective
        .modes(&info.params)
        .into_iter()
        .filter(|m| level(m) >= floor)
        .collect();
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
