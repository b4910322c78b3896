//! The whole pipeline on bundled data, with no arguments (`resound demo`).
//!
//! 1. The bundled real recording (a steel nut striking an aluminium ramp, CC BY 4.0) is analysed.
//! 2. The ramp is approximated by an aluminium bar of 100 × 30 × 5 mm (our assumption: the
//!    recording's source does not give the ramp's size; a 400 × 100 × 4 mm plate put its first
//!    mode at 130 Hz, far below the strike's lowest strong mode near 2.1 kHz, and forced an
//!    unphysical γ); its modal model is computed.
//! 3. The ramp's material is estimated from the first strike (with its residual), stored in the
//!    material library as `demo-ramp` and written to `material.json`.
//! 4. One strike of that material on the bar is synthesized (`strike.wav`).
//! 5. The whole recording is cut into grains and correlation patterns (`demo.grains`, Picard
//!    2009), rebuilt, and stretched 1.5× with variation (`grains_stretched.wav`).
//! 6. The bundled scene — objects of that material and of presets on a wooden table, and a nut
//!    sounding from the grains — is rendered (`scene.wav`, `events.jsonl`).
//! 7. Pictures (`recording.png`, `estimate.png`, `scene.png`) and `summary.txt` are written.

use crate::error::{invalid, Result};
use crate::material::{estimate_material, estimate_plot, open_library, EstimateMaterialParams};
use crate::recording::{analyze_file, RecordingParams};
use crate::scene::{render_scene, SceneRenderParams, SceneSummary};
use crate::strike::{render_strike, StrikeParams, Struck};
use resound_core::Material;
use resound_io::atomic::write_atomic;
use resound_io::{write_wav, write_wav_channels, WavFormat};
use resound_modal::ModalBuilder;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

static RECORDING: &[u8] = include_bytes!("../../../assets/recordings/steel_nut_M4_2.wav");
static SCENE: &str = include_str!("../../../assets/scenes/demo.toml");
/// Our stand-in for the ramp: an aluminium bar, m.
pub const RAMP: [f64; 3] = [0.1, 0.03, 0.005];
/// Where the nut strikes it (on the top face, off-centre).
pub const HIT: [f64; 3] = [0.02, 0.01, 0.0025];

/// Settings of [`run`].
#[derive(Clone, Debug)]
pub struct DemoParams {
    /// Output directory.
    pub out_dir: PathBuf,
    /// Material library (`None`: the default).
    pub library: Option<PathBuf>,
    /// Directory of cached modal models for the scene (`None`: no cache).
    pub cache_dir: Option<PathBuf>,
}

/// What the demo did: one line per step (with its time) and the whole time.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct DemoReport {
    /// Steps: seconds and what was done.
    pub steps: Vec<(f64, String)>,
    /// The scene's figures.
    pub scene: SceneSummary,
    /// Everything, s.
    pub total_s: f64,
    /// What the steps' reports warned of (the estimate's: the stand-in bar's pairing with the
    /// recording is mostly chance), also in `summary.txt` and sent as `warning:` lines.
    pub warnings: Vec<resound_core::Warning>,
    /// The text of `summary.txt`.
    pub text: String,
}

/// Runs the demo; `step` gets each step's line as it finishes.
///
/// # Errors
/// Any stage's error.
pub fn run(p: &DemoParams, step: &dyn Fn(&str)) -> Result<DemoReport> {
    let total = Instant::now();
    let dir = &p.out_dir;
    crate::files::make_output_dir(dir)?;
    let mut report = DemoReport::default();
    let done = |name: String, t: Instant, report: &mut DemoReport| {
        let s = t.elapsed().as_secs_f64();
        step(&format!("{name} ({s:.1} s)"));
        report.steps.push((s, name));
    };

    // 1. The recording and its modes.
    let t = Instant::now();
    let rec = dir.join("recording.wav");
    write_atomic(&rec, |w| w.write_all(RECORDING))?;
    let params = resound_signal::AnalyzeParams {
        highpass_hz: Some(100.0),
        strike: Some(0),
        ..Default::default()
    };
    let (_, analysis) = analyze_file(&rec, &RecordingParams::default(), &params)?;
    resound_plot::analysis_png(
        &dir.join("recording.png"),
        &analysis,
        "recording: steel nut on aluminium ramp (CC BY 4.0)",
    )?;
    done(
        format!(
            "analysed the recording: {} modes in the first of {} strikes",
            analysis.modes.len(),
            analysis.strikes_s.len()
        ),
        t,
        &mut report,
    );

    // 2. The stand-in object's modal model.
    let t = Instant::now();
    let bar = resound_fem::primitive::bar(RAMP);
    let aluminium = Material::preset("aluminium")?;
    let model = ModalBuilder::surface(&bar, &aluminium)
        .modes(80)
        .solve()?
        .model;
    let model_path = dir.join("ramp.rmodal");
    resound_io::model_file::save(&model_path, &model)?;
    done(
        format!(
            "modal model of a {}×{}×{} mm aluminium bar (stand-in for the ramp): {} modes, first at {:.0} Hz",
            RAMP[0] * 1e3,
            RAMP[1] * 1e3,
            RAMP[2] * 1e3,
            model.n_modes(),
            model.freq_hz(0)
        ),
        t,
        &mut report,
    );

    // 3. The material, into the library.
    let t = Instant::now();
    let hit = model.hit(HIT)?;
    let ep = EstimateMaterialParams {
        name: "demo-ramp".into(),
        recording_name: rec.display().to_string(),
        object_name: model_path.display().to_string(),
        ..Default::default()
    };
    let (material, info) = estimate_material(
        &analysis,
        &model,
        &hit,
        &ep,
        &resound_core::progress::ignore,
    )?;
    resound_io::library::write_material(&dir.join("material.json"), &material)?;
    estimate_plot(
        &dir.join("estimate.png"),
        "steel_nut_M4_2.wav",
        &analysis,
        &model,
        &hit,
        &info,
        &ep.estimate,
    )?;
    open_library(p.library.as_deref())?.put(&material)?;
    done(
        format!(
            "estimated the material (stored as demo-ramp): alpha {:.3e} 1/s, beta {:.3e} s, gamma {:.3e} m²/s², sigma {:.3e}",
            material.alpha, material.beta, material.gamma, material.sigma
        ),
        t,
        &mut report,
    );
    for w in &info.warnings {
        step(&format!("warning: {}", w.message));
    }
    report.warnings.extend(info.warnings.iter().cloned());

    // 4. One strike of it.
    let t = Instant::now();
    let mut strike = render_strike(
        Struck::Object {
            material: &material,
            model: &model,
            hit: &hit,
            same_object: true,
        },
        &StrikeParams {
            duration_s: 1.5,
            ..Default::default()
        },
    )?;
    let level =
        resound_synth::render::normalize(&mut strike.samples, resound_synth::render::CEILING)?;
    if let Some(w) = level.quiet_warning() {
        return Err(invalid(format!("the demo strike: {w}")));
    }
    write_wav(
        &dir.join("strike.wav"),
        &strike.samples,
        48_000,
        WavFormat::Pcm24,
    )?;
    done(
        "synthesized one strike of the material on the bar (modes + residual)".into(),
        t,
        &mut report,
    );

    // 5. Grains of the whole recording (nuts rolling, sliding and striking).
    let t = Instant::now();
    let (recs, gfs, _) = crate::grain_files::load_recordings(
        &[rec.to_string_lossy().into_owned()],
        crate::grain_files::KindRule::Fixed(resound_grains::Contact::Continuous),
        None,
    )?;
    let (dict, _) = resound_grains::analyze(
        &recs,
        gfs,
        &resound_grains::AnalyzeParams::default(),
        &resound_core::progress::ignore,
    )?;
    resound_io::grains_file::save(&dir.join("demo.grains"), &dict)?;
    let rebuilt = resound_grains::resynth::resynthesize(&dict, 0, &Default::default())?;
    let sc = resound_grains::quality::spectral_convergence_db(&recs[0].samples, &rebuilt, gfs);
    let stretched = resound_grains::resynth::resynthesize(
        &dict,
        0,
        &resound_grains::resynth::ResynthParams {
            time_scale: 1.5,
            variation: 0.3,
            seed: 3,
        },
    )?;
    write_wav(
        &dir.join("grains_stretched.wav"),
        &stretched,
        gfs as u32,
        WavFormat::Pcm24,
    )?;
    done(
        format!(
            "cut the recording into {} grains (demo.grains; rebuilt to {sc:.0} dB spectral convergence) and stretched it 1.5× with variation (grains_stretched.wav)",
            dict.grains.len()
        ),
        t,
        &mut report,
    );

    // 6. The scene.
    let t = Instant::now();
    let scene_path = dir.join("scene.toml");
    write_atomic(&scene_path, |w| w.write_all(SCENE.as_bytes()))?;
    let scene = render_scene(
        &scene_path,
        &SceneRenderParams {
            library: p.library.clone(),
            cache_dir: p.cache_dir.clone(),
            keep_level: false,
            live: None,
        },
        &resound_core::progress::ignore,
    )?;
    let refs: Vec<&[f32]> = scene.channels.iter().map(|c| c.as_slice()).collect();
    write_wav_channels(
        &dir.join("scene.wav"),
        &refs,
        scene.sample_rate_hz,
        WavFormat::Pcm24,
    )?;
    crate::files::write_json_lines(&dir.join("events.jsonl"), &scene.events)?;
    let s = &scene.summary;
    done(
        format!(
            "rendered the scene: {} bodies, {} impacts, {} sliding and {} rolling body-steps, {:.0}× real time",
            s.bodies, s.impacts, s.sliding_steps, s.rolling_steps, s.realtime_factor
        ),
        t,
        &mut report,
    );

    // 7. The result's picture and the summary.
    let t = Instant::now();
    // Every channel, with the impacts marked (the picture showed the left channel alone).
    let chans: Vec<Vec<f64>> = scene
        .channels
        .iter()
        .map(|c| c.iter().map(|&v| f64::from(v)).collect())
        .collect();
    let names = ["scene.wav (left)", "scene.wav (right)"];
    let rows: Vec<(&str, &[f64])> = chans
        .iter()
        .enumerate()
        .map(|(i, c)| (names.get(i).copied().unwrap_or("scene.wav"), c.as_slice()))
        .collect();
    let impacts: Vec<f64> = scene
        .events
        .iter()
        .filter(|e| e.kind == resound_physics::ContactKind::Impact)
        .map(|e| e.time_s)
        .collect();
    resound_plot::spectrograms_png(
        &dir.join("scene.png"),
        &rows,
        f64::from(scene.sample_rate_hz),
        &impacts,
    )?;
    done("drew scene.png".into(), t, &mut report);
    report.scene = scene.summary;
    report.total_s = total.elapsed().as_secs_f64();
    let mut text = format!("Resound demo ({:.1} s in all)\n\n", report.total_s);
    for (s, name) in &report.steps {
        let _ = writeln!(text, "{s:>7.2} s  {name}");
    }
    if !report.warnings.is_empty() {
        text.push('\n');
    }
    for w in &report.warnings {
        let _ = writeln!(text, "warning: {}", w.message);
    }
    text.push_str(
        "\nFiles: recording.wav/.png (the bundled recording and its modes), ramp.rmodal (the stand-in\n\
         bar), material.json and estimate.png (the estimated material: features with the Rayleigh\n\
         curve, loudness images), strike.wav, demo.grains and grains_stretched.wav (the recording's\n\
         grains, stretched 1.5×), scene.toml, scene.wav/.png, events.jsonl.\n",
    );
    write_atomic(&dir.join("summary.txt"), |w| w.write_all(text.as_bytes()))?;
    report.text = text;
    Ok(report)
}
