//! One strike of an object, offline: the object's modes (from a material on a modal model at a
//! hit, from analysed modes, or sampled from mode statistics) struck by an impactor (Hertz,
//! spring or impulse), plus the material's transferred residual (Ren §6.2) or the statistics'
//! transient bands.

use crate::error::{invalid, Error, Result};
use resound_core::{DampedMode, Hit, Material, ModalModel, SoundMaterial};
use resound_stats::ModeStatistics;
use resound_synth::excitation::{ContactModel, Elastic, Impact};
use resound_synth::render::{bank_modes, render_strike as render_bank, REFERENCE_IMPULSE_N_S};
use resound_synth::residual::{GriffinLim, Pairing, ResidualSource};
use resound_synth::BankMode;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// What is struck.
#[derive(Clone, Copy, Debug)]
pub enum Struck<'a> {
    /// An object of `material` (its modal `model`, struck at `hit`). `same_object`: the model
    /// and hit are the recorded ones, so the residual pairs modes by index.
    Object {
        /// The material.
        material: &'a SoundMaterial,
        /// The object's modal model (solved with any reference material).
        model: &'a ModalModel,
        /// Where it is struck.
        hit: &'a Hit,
        /// Whether this is the object and hit the material was estimated on.
        same_object: bool,
    },
    /// Analysed modes rendered exactly as recorded (phases included), at the recording's level
    /// for the reference impact.
    Modes(&'a [DampedMode]),
    /// An impulse response sampled from mode statistics (Traer 2019) with `seed`.
    Stats {
        /// The statistics.
        stats: &'a ModeStatistics,
        /// Seed of the sampled IR; the per-impact variation uses seed + 1, the transient seed + 2.
        seed: u64,
    },
}

/// The impactor and the strike.
#[derive(Clone, Debug, PartialEq)]
pub struct StrikeParams {
    /// Impact speed, m/s.
    pub speed_m_s: f64,
    /// Impactor mass, kg (`None`: a sphere of `impactor_radius_m` of the impactor material).
    pub impactor_mass_kg: Option<f64>,
    /// Impactor radius at the contact, m.
    pub impactor_radius_m: f64,
    /// Impactor material.
    pub impactor: Material,
    /// Contact force law.
    pub contact: ContactModel,
    /// Add the material's residual (or the statistics' transient).
    pub residual: bool,
    /// Length, s.
    pub duration_s: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: u32,
    /// A microphone (model coordinates, m): each mode's gain is weighted by what it radiates
    /// there (the model's acoustic transfer, fitted when its file holds none). `None`: the
    /// modes' surface motion alone, as in Ren 2013.
    pub mic_m: Option<[f64; 3]>,
}

impl Default for StrikeParams {
    fn default() -> Self {
        Self {
            speed_m_s: 1.0,
            impactor_mass_kg: None,
            impactor_radius_m: 0.005,
            impactor: Material::preset("steel").unwrap_or_else(|_| unreachable!()),
            contact: ContactModel::Hertz,
            residual: true,
            duration_s: 2.0,
            sample_rate_hz: 48_000,
            mic_m: None,
        }
    }
}

/// Figures of a rendered strike: the strike's report, the one document every front end shows
/// (`resound synth --json` prints it beside the file it wrote, Python's `render_strike` returns
/// it as a dict).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct StrikeInfo {
    /// The material's name (objects and statistics; `None` for analysed modes).
    pub material: Option<String>,
    /// Modes rendered.
    pub modes: usize,
    /// The impact's impulse, N·s.
    pub impulse_n_s: f64,
    /// Contact duration, s (0 for analysed modes).
    pub contact_s: f64,
    /// Residual pairing used: "natural", "dominant", "transient" or "none".
    pub residual: String,
    /// Time spent transferring the residual, s.
    pub residual_transfer_s: f64,
    /// The hit point on the surface (objects only), m.
    pub hit: Option<[f64; 3]>,
    /// The microphone the modes radiate to, m (objects with `mic_m`).
    pub mic: Option<[f64; 3]>,
    /// Time spent fitting the acoustic transfer (a model file without one), s.
    pub transfer_fit_s: f64,
    /// Peak of the render at its physical level (1 m away), full scale = 1.
    pub peak: f32,
    /// Level change applied by [`level_for_file`], dB (0: the physical level).
    pub gain_db: f32,
    /// Wall time of the render, s.
    pub elapsed_s: f64,
    /// What is not credible about this strike (below audibility, a microphone inside the
    /// object's enclosing sphere, …).
    pub warnings: Vec<resound_core::Warning>,
}

impl StrikeInfo {
    /// The report without its wall-clock figures (zeroed): what content-addressed files hold,
    /// so the same strike writes the same bytes in any run.
    pub fn without_timings(&self) -> Self {
        Self {
            residual_transfer_s: 0.0,
            transfer_fit_s: 0.0,
            elapsed_s: 0.0,
            ..self.clone()
        }
    }
}

/// Turns a strike down to the file ceiling (−1 dBFS) when it would clip, as `resound synth`
/// writes it; the gain goes into its report. Returns the note a front end shows when it
/// turned the strike down.
///
/// # Errors
/// Non-finite samples.
pub fn level_for_file(strike: &mut Strike) -> Result<Option<String>> {
    let level =
        resound_synth::render::normalize(&mut strike.samples, resound_synth::render::CEILING)?;
    strike.info.gain_db = level.gain_db;
    warn_if_faint(strike);
    Ok(level.note())
}

/// One strike kept at its physical level (a file, Python's array) below −40 dBFS, and above
/// the inaudible tier (warned already): faint, said with the way out. Datasets (`batch`) keep
/// physical levels on purpose and are not told.
pub fn warn_if_faint(strike: &mut Strike) {
    let faint = resound_core::limits::FAINT_DBFS;
    let peak_dbfs = 20.0 * f64::from(strike.info.peak).log10();
    let quiet = resound_core::WarningKind::Quiet;
    if strike.info.warnings.iter().all(|w| w.kind != quiet) && peak_dbfs < faint {
        strike.info.warnings.push(resound_core::Warning::new(
            quiet,
            format!(
                "the strike peaks at {peak_dbfs:.0} dBFS, below {faint:.0} dBFS: faint, heard only turned up (a slow or light impact, a hit near a nodal line, or a material's σ too small); normalize it if the level is not what you meant"
            ),
        ));
    }
}

/// Brings a strike's peak to the file ceiling (−1 dBFS), up or down, instead of keeping its
/// physical level; the gain goes into its report and its level warnings are dropped (the
/// level is now chosen). Returns the note a front end shows.
///
/// # Errors
/// Non-finite samples.
pub fn normalize_for_file(strike: &mut Strike) -> Result<String> {
    use resound_synth::render::{set_level, Level, CEILING};
    let level = set_level(&mut [&mut strike.samples[..]], CEILING, Level::Normalize)?;
    strike.info.gain_db = level.gain_db;
    strike
        .info
        .warnings
        .retain(|w| w.kind != resound_core::WarningKind::Quiet);
    Ok(format!(
        "normalized: peak {:.1} dBFS brought to −1 dBFS ({:+.1} dB)",
        level.peak_dbfs(),
        level.gain_db
    ))
}

/// Measures the strike's peak into its report, with the inaudibility warning (replacing an
/// earlier one): after anything that changes the level physically (a listener's distance).
pub fn measure_level(s: &mut Strike) {
    let level = resound_synth::render::LevelReport {
        peak_before: s.samples.iter().fold(0.0f32, |a, v| a.max(v.abs())),
        gain_db: 0.0,
    };
    s.info.peak = level.peak_before;
    s.info
        .warnings
        .retain(|w| w.kind != resound_core::WarningKind::Quiet);
    s.info.warnings.extend(level.quiet_warning());
}

fn finish(mut s: Strike, t0: std::time::Instant) -> Strike {
    measure_level(&mut s);
    s.info.elapsed_s = t0.elapsed().as_secs_f64();
    s
}

/// A rendered strike and its parts (the live engine replays the parts: modes struck by the
/// force pulse, plus the added signal).
#[derive(Clone, Debug)]
pub struct Strike {
    /// The sound, f32, full scale = 1 (not normalized).
    pub samples: Vec<f32>,
    /// Bank modes with gains per N·s (empty for analysed modes, rendered exactly instead).
    pub modes: Vec<BankMode>,
    /// Force pulse, N per sample.
    pub force: Vec<f32>,
    /// What is added to the bank's output: residual, transient, or the exact analysed modes.
    pub extra: Vec<f32>,
    /// Figures.
    pub info: StrikeInfo,
}

impl StrikeParams {
    /// Checks every parameter's range (what [`render_strike`] checks first): a front end
    /// calls it before slow work such as a modal solve.
    ///
    /// # Errors
    /// [`Error::Param`] naming the field.
    pub fn validate(&self) -> Result<()> {
        check(self)
    }
}

fn check(p: &StrikeParams) -> Result<()> {
    let param = |field, message| Error::Param { field, message };
    let fs = f64::from(p.sample_rate_hz);
    if !resound_core::limits::sample_rate_ok(fs) {
        return Err(param(
            "sample_rate_hz",
            resound_core::limits::sample_rate_message(fs),
        ));
    }
    if !(p.duration_s > 0.0 && p.duration_s <= 600.0) || (p.duration_s * fs).round() < 1.0 {
        return Err(param(
            "duration_s",
            format!(
                "duration must be in (0, 600] s and at least one sample, got {}",
                p.duration_s
            ),
        ));
    }
    if !(p.speed_m_s.is_finite() && p.speed_m_s >= 0.0 && p.speed_m_s < 1000.0) {
        return Err(param(
            "speed_m_s",
            format!("speed must be in [0, 1000) m/s, got {}", p.speed_m_s),
        ));
    }
    if !(p.impactor_radius_m > 0.0 && p.impactor_radius_m < 10.0) {
        return Err(param(
            "impactor_radius_m",
            format!(
                "impactor radius must be in (0, 10) m, got {}",
                p.impactor_radius_m
            ),
        ));
    }
    if let Some(m) = p.impactor_mass_kg {
        if !(m > 0.0 && m <= 1e4) {
            return Err(param(
                "impactor_mass_kg",
                format!("impactor mass must be in (0, 10 000] kg, got {m:e}"),
            ));
        }
    }
    Ok(())
}

fn elastic(m: &Material) -> Elastic {
    Elastic {
        youngs_modulus: m.youngs_modulus,
        poisson_ratio: m.poisson_ratio,
    }
}

/// Renders one strike.
///
/// # Errors
/// Parameters out of range; an object without modes below Nyquist; a failed force pulse or
/// resampling; a non-finite result.
pub fn render_strike(struck: Struck<'_>, p: &StrikeParams) -> Result<Strike> {
    check(p)?;
    let t0 = std::time::Instant::now();
    let fs = f64::from(p.sample_rate_hz);
    let samples = (p.duration_s * fs).round() as usize;
    let mass = p.impactor_mass_kg.unwrap_or_else(|| {
        4.0 / 3.0 * std::f64::consts::PI * p.impactor_radius_m.powi(3) * p.impactor.density
    });
    let mut impact = Impact {
        impactor_mass_kg: mass,
        impactor_radius_m: p.impactor_radius_m,
        impactor: elastic(&p.impactor),
        object: elastic(&p.impactor),
        object_mass_kg: None,
        speed_m_s: p.speed_m_s,
    };
    let scale = impact.impulse_n_s() / REFERENCE_IMPULSE_N_S;
    let mut info = StrikeInfo {
        impulse_n_s: impact.impulse_n_s(),
        residual: "none".into(),
        ..Default::default()
    };
    let (modes, extra): (Vec<DampedMode>, Vec<f32>) = match struck {
        Struck::Modes(modes) => {
            if let Some(m) = modes.iter().find(|m| {
                !(m.freq_hz.is_finite()
                    && m.damping_per_s.is_finite()
                    && m.damping_per_s >= 0.0
                    && m.amplitude.is_finite()
                    && m.phase_rad.is_finite())
            }) {
                return Err(invalid(format!("unusable mode {m:?}")));
            }
            let kept: Vec<DampedMode> = modes
                .iter()
                .copied()
                .filter(|m| m.freq_hz < 0.5 * fs)
                .collect();
            if kept.is_empty() {
                return Err(invalid("no modes below Nyquist"));
            }
            info.modes = kept.len();
            let x: Vec<f32> = resound_core::damped::synthesize(&kept, fs, samples)
                .iter()
                .map(|&v| (v * scale) as f32)
                .collect();
            return Ok(finish(
                Strike {
                    samples: x.clone(),
                    modes: Vec::new(),
                    force: Vec::new(),
                    extra: x,
                    info,
                },
                t0,
            ));
        }
        Struck::Stats { stats, seed } => {
            info.material = Some(stats.material.clone());
            let ir = resound_stats::perturb(&stats.sample(seed)?, seed.wrapping_add(1));
            let modes: Vec<DampedMode> = ir.into_iter().filter(|m| m.freq_hz < 0.5 * fs).collect();
            let mut extra = Vec::new();
            if let (Some(ts), true) = (&stats.transient, p.residual) {
                let t = ts.sample(seed.wrapping_add(2));
                extra = resound_stats::transient::synthesize_transient(&t, fs, samples, seed)
                    .iter()
                    .map(|v| (v * scale) as f32)
                    .collect();
                info.residual = "transient".into();
            }
            (modes, extra)
        }
        Struck::Object {
            material,
            model,
            hit,
            same_object,
        } => {
            material.validate().map_err(invalid)?;
            info.material = Some(material.name.clone());
            let gamma0 = model.gamma0();
            let gains: Cow<'_, [f64]> = match p.mic_m {
                None => Cow::Borrowed(&hit.gains),
                Some(mic) => {
                    let t1 = std::time::Instant::now();
                    let (transfer, fitted) = crate::radiation::transfer_of(model)?;
                    if fitted.is_some() {
                        info.transfer_fit_s = t1.elapsed().as_secs_f64();
                    }
                    let freqs = crate::radiation::freqs_in(model, material.gamma);
                    let (f, w) = crate::radiation::mic_factors(&transfer, &freqs, mic)?;
                    info.mic = Some(mic);
                    info.warnings.extend(w);
                    Cow::Owned(hit.gains.iter().zip(&f).map(|(g, f)| g * f).collect())
                }
            };
            let modes = material.modes(&model.eigenvalues, &gains, gamma0, 0.5 * fs);
            impact.object = Elastic {
                youngs_modulus: material.gamma * model.material.density,
                poisson_ratio: model.material.poisson_ratio,
            };
            info.hit = Some(hit.at.point);
            let mut extra = Vec::new();
            if let (Some(r), true, false) = (&material.residual, p.residual, modes.is_empty()) {
                let pairing = if same_object {
                    Pairing::Natural
                } else {
                    Pairing::Dominant(8)
                };
                info.residual = if same_object { "natural" } else { "dominant" }.into();
                let t1 = std::time::Instant::now();
                let res = ResidualSource::new(r).transfer(&modes, pairing, &GriffinLim::default());
                info.residual_transfer_s = t1.elapsed().as_secs_f64();
                let res: Vec<f64> = res.iter().map(|&v| f64::from(v)).collect();
                // The residual's modes are at the recording's rate; the target modes at ours.
                let res = if (r.sample_rate_hz - fs).abs() > 0.5 {
                    resound_signal::resample::resample(
                        &res,
                        r.sample_rate_hz.round() as u32,
                        p.sample_rate_hz,
                    )
                    .map_err(invalid)?
                } else {
                    res
                };
                extra = res.iter().map(|v| (v * scale) as f32).collect();
            }
            (modes, extra)
        }
    };
    if modes.is_empty() {
        return Err(invalid(format!(
            "the object has no modes below Nyquist ({} Hz)",
            0.5 * fs
        )));
    }
    info.modes = modes.len();
    info.contact_s = impact.duration_s(p.contact);
    let force = impact.force_pulse(p.contact, fs, 0.0)?;
    // Gains per N·s: σa⁰ is the recording's level for the reference impact.
    let mut bm = bank_modes(&modes);
    bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
    let mut out = render_bank(&bm, &force, fs, samples)?;
    for (o, v) in out.iter_mut().zip(&extra) {
        *o += v;
    }
    Ok(finish(
        Strike {
            samples: out,
            modes: bm,
            force,
            extra,
            info,
        },
        t0,
    ))
}

/// What sounds, from files: the inputs of `synth` and `scrape` (and the studio's audition).
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)] // one per command, never in a collection
pub enum StrikeSource {
    /// A modes file (JSON rows of f, d, a, φ).
    Modes(std::path::PathBuf),
    /// Mode statistics (Traer 2019), sampled with `seed`.
    Stats {
        /// The statistics file.
        path: std::path::PathBuf,
        /// Which sample.
        seed: u64,
    },
    /// A material on an object struck at a point.
    Object {
        /// The material: a material file or a library, built-in or preset name.
        material: String,
        /// The material library (`None`: the default one).
        library: Option<std::path::PathBuf>,
        /// The object: a mesh or a saved modal model.
        object: std::path::PathBuf,
        /// How a mesh is solved.
        object_params: crate::object::ObjectParams,
        /// Hit point, m (model coordinates; snapped to the surface).
        hit_m: [f64; 3],
    },
}

/// A material from a file (`*.json` or an existing path) or the library at `library` (the
/// default one when `None`), a built-in or a preset.
///
/// # Errors
/// Unreadable files or library; an unknown name; an invalid material.
pub fn load_material_spec(spec: &str, library: Option<&std::path::Path>) -> Result<SoundMaterial> {
    let path = std::path::Path::new(spec);
    let lib = if path.is_file() || spec.to_ascii_lowercase().ends_with(".json") {
        None
    } else {
        crate::material::read_library(library)?
    };
    crate::material::resolve_material(spec, std::path::Path::new("."), lib.as_ref())
}

/// Renders a strike of `source` ([`render_strike`]), loading what it names; also returns
/// what was done on the way (the hit snapped to the surface). `progress` hears a modal solve.
///
/// # Errors
/// Unreadable files, a failed solve, a hit off the model, parameters out of range.
pub fn render_strike_from(
    source: &StrikeSource,
    p: &StrikeParams,
    progress: resound_core::ProgressFn<'_>,
) -> Result<(Strike, Vec<String>)> {
    p.validate()?;
    match source {
        StrikeSource::Modes(path) => {
            let modes = crate::files::load_modes(path)?;
            Ok((render_strike(Struck::Modes(&modes), p)?, Vec::new()))
        }
        StrikeSource::Stats { path, seed } => {
            let stats = crate::files::load_stats(path)?;
            let struck = Struck::Stats {
                stats: &stats,
                seed: *seed,
            };
            Ok((render_strike(struck, p)?, Vec::new()))
        }
        StrikeSource::Object {
            object,
            object_params,
            ..
        } => {
            if let Some(mic) = p.mic_m {
                crate::object::check_mic_before_solve(object, object_params.scale, mic)?;
            }
            let (material, model, hit, note, warnings) =
                load_struck_object_warned(source, 0.5 * f64::from(p.sample_rate_hz), progress)?;
            let same_object =
                material.was_estimated_on(&object.display().to_string(), hit.at.point);
            let struck = Struck::Object {
                material: &material,
                model: &model,
                hit: &hit,
                same_object,
            };
            let mut strike = render_strike(struck, p)?;
            // The solve's warnings (modes left out, a size in the wrong unit) are the strike's.
            strike.info.warnings.splice(0..0, warnings);
            Ok((strike, note.into_iter().collect()))
        }
    }
}

/// The modes `source` sounds with at `sample_rate_hz` (per unit impulse; statistics sampled
/// with their seed), and what was done on the way: what a scrape or a custom excitation
/// drives.
///
/// # Errors
/// As [`render_strike_from`].
pub fn source_modes(
    source: &StrikeSource,
    sample_rate_hz: f64,
    progress: resound_core::ProgressFn<'_>,
) -> Result<(Vec<DampedMode>, Vec<String>)> {
    match source {
        StrikeSource::Modes(path) => Ok((crate::files::load_modes(path)?, Vec::new())),
        StrikeSource::Stats { path, seed } => {
            Ok((crate::files::load_stats(path)?.sample(*seed)?, Vec::new()))
        }
        StrikeSource::Object { .. } => {
            let (material, model, hit, note) =
                load_struck_object(source, 0.5 * sample_rate_hz, progress)?;
            let modes = material.modes(
                &model.eigenvalues,
                &hit.gains,
                model.gamma0(),
                0.5 * sample_rate_hz,
            );
            Ok((modes, note.into_iter().collect()))
        }
    }
}

/// One mode of an object struck at a point, for listening ([`object_mode`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ObjectModeInfo {
    /// The mode, counting from 1 in the model's order.
    pub mode: usize,
    /// Its frequency with the material, Hz.
    pub freq_hz: f64,
    /// Its damping with the material, 1/s.
    pub damping_per_s: f64,
    /// Its amplitude at the hit below the loudest mode's there, dB (a hit near one of its
    /// nodal lines makes it quiet: the sound is normalized, this says how quiet).
    pub level_db: f64,
    /// The note of a snapped hit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Mode `k` (counting from 1) of [`StrikeSource::Object`] alone, as the material makes it sound
/// at the hit: `duration_s` at `sample_rate_hz`, normalized to
/// [`crate::recording::ONE_MODE_PEAK`] (its level among the others is in the info).
///
/// # Errors
/// Not an object source; no mode `k`; a mode the material over-damps or puts at or above the
/// Nyquist frequency; a mode with no motion at the hit (a node); what loading the object and
/// the material can raise.
pub fn object_mode(
    source: &StrikeSource,
    k: usize,
    duration_s: f64,
    sample_rate_hz: u32,
) -> Result<(Vec<f32>, ObjectModeInfo)> {
    if !(duration_s > 0.0 && duration_s <= 60.0) {
        return Err(invalid(format!(
            "the duration must be in (0, 60] s, got {duration_s}"
        )));
    }
    let fs = f64::from(sample_rate_hz);
    let (material, model, hit, note) = load_struck_object(source, 0.5 * fs, &|_| {})?;
    let n = model.eigenvalues.len();
    if k == 0 || k > n {
        return Err(invalid(format!(
            "no mode {k}: the model has {n} (counting from 1)"
        )));
    }
    let all = material.modes_indexed(&model.eigenvalues, &hit.gains, model.gamma0(), 0.5 * fs);
    let Some(m) = all.iter().find(|(i, _)| *i == k - 1).map(|(_, m)| *m) else {
        return Err(invalid(format!(
            "mode {k} does not sound at {sample_rate_hz} Hz with {}: it is over-damped or at or above the Nyquist frequency",
            material.name
        )));
    };
    let loudest = all.iter().map(|(_, m)| m.amplitude).fold(0.0, f64::max);
    if !(m.amplitude > 0.0 && loudest > 0.0) {
        return Err(invalid(format!(
            "mode {k} does not move at this hit (a node): pick another point"
        )));
    }
    let x = resound_core::damped::synthesize(
        &[DampedMode {
            amplitude: 1.0,
            ..m
        }],
        fs,
        (duration_s * fs).round().max(1.0) as usize,
    );
    let peak = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if !(peak > 0.0 && peak.is_finite()) {
        return Err(invalid(format!("mode {k} is silent over {duration_s} s")));
    }
    let samples = x
        .iter()
        .map(|v| (crate::recording::ONE_MODE_PEAK * v / peak) as f32)
        .collect();
    Ok((
        samples,
        ObjectModeInfo {
            mode: k,
            freq_hz: m.freq_hz,
            damping_per_s: m.damping_per_s,
            level_db: 20.0 * (m.amplitude / loudest).log10(),
            note,
        },
    ))
}

/// The material, model and hit of [`StrikeSource::Object`] (nothing for the other sources),
/// with the note of a snapped hit. A mesh is solved only up to `top_hz` in the material
/// ([`crate::object::ObjectParams::band_limited`]).
fn load_struck_object(
    source: &StrikeSource,
    top_hz: f64,
    progress: resound_core::ProgressFn<'_>,
) -> Result<(SoundMaterial, ModalModel, Hit, Option<String>)> {
    let (material, model, hit, note, warnings) =
        load_struck_object_warned(source, top_hz, progress)?;
    for w in warnings {
        progress(resound_core::Progress::Warning(w));
    }
    Ok((material, model, hit, note))
}

/// [`load_struck_object`] with the solve's warnings returned (modes left out, a size in the
/// wrong unit) for a report that lists them.
#[allow(clippy::type_complexity)]
fn load_struck_object_warned(
    source: &StrikeSource,
    top_hz: f64,
    progress: resound_core::ProgressFn<'_>,
) -> Result<(
    SoundMaterial,
    ModalModel,
    Hit,
    Option<String>,
    Vec<resound_core::Warning>,
)> {
    let StrikeSource::Object {
        material,
        library,
        object,
        object_params,
        hit_m,
    } = source
    else {
        return Err(invalid("not an object source"));
    };
    let material = load_material_spec(material, library.as_deref())?;
    crate::object::check_hit_before_solve(object, object_params.scale, *hit_m)?;
    let params = object_params.band_limited(material.gamma, top_hz);
    let (model, warnings) =
        crate::object::load_object_warned(object, &params, progress).map_err(|e| {
            if e.is_no_modes() && params.modal.max_freq_hz != object_params.modal.max_freq_hz {
                invalid(format!(
                    "{}: with {} no mode of this object sounds below {top_hz:.0} Hz, the \
                     render's Nyquist frequency: its lowest lies higher (a small or stiff \
                     object; check the mesh's size and unit)",
                    object.display(),
                    material.name
                ))
            } else {
                e
            }
        })?;
    let (hit, note) = crate::object::snap_hit(&model, *hit_m)?;
    Ok((material, model, hit, note, warnings))
}
