//! `resound demo`: the whole pipeline on bundled data, with no arguments.
//!
//! 1. The bundled real recording (a steel nut striking an aluminium ramp, CC BY 4.0) is analysed.
//! 2. The ramp is approximated by an aluminium bar of 100 × 30 × 5 mm (our assumption: the
//!    recording's source does not give the ramp's size; a 400 × 100 × 4 mm plate put its first
//!    mode at 130 Hz, far below the strike's lowest strong mode near 2.1 kHz, and forced an
//!    unphysical γ); its modal model is computed.
//! 3. The ramp's material is estimated from the first strike (with its residual), stored in the
//!    material library as `demo-ramp` and written to `material.json`.
//! 4. One strike of that material on the plate is synthesized (`strike.wav`).
//! 5. The whole recording is cut into grains and correlation patterns (`demo.grains`, Picard
//!    2009), rebuilt, and stretched 1.5× with variation (`grains_stretched.wav`).
//! 6. The bundled scene — objects of that material and of presets on a wooden table, and a nut
//!    sounding from the grains — is rendered (`scene.wav`, `events.jsonl`).
//! 7. Pictures (`recording.png`, `estimate.png`, `scene.png`) and `summary.txt` are written.

use crate::estimate_cmd::EstimateArgs;
use crate::scene_cmd::SceneArgs;
use crate::synth_cmd::{ContactArg, FormatArg, SynthArgs};
use anyhow::{Context, Result};
use clap::Args;
use resound::core::Material;
use resound::io::atomic::write_atomic;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

static RECORDING: &[u8] = include_bytes!("../../../assets/recordings/steel_nut_M4_2.wav");
static SCENE: &str = include_str!("../../../assets/scenes/demo.toml");
/// Our stand-in for the ramp: an aluminium bar, m.
const RAMP: [f64; 3] = [0.1, 0.03, 0.005];
/// Where the nut strikes it (on the top face, off-centre).
const HIT: [f64; 3] = [0.02, 0.01, 0.0025];

/// Arguments of `demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output directory.
    #[arg(long, default_value = "demo-out")]
    pub out_dir: PathBuf,
    /// Material library (default: $RESOUND_LIBRARY or ~/.local/share/resound/materials.sqlite).
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Do not use cached modal models.
    #[arg(long)]
    pub no_cache: bool,
}

/// Runs `demo`.
pub fn run(a: DemoArgs) -> Result<()> {
    let total = Instant::now();
    let dir = &a.out_dir;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut log = String::new();
    let step = |name: &str, t: Instant, log: &mut String| {
        let s = t.elapsed().as_secs_f64();
        eprintln!("demo: {name} ({s:.1} s)");
        let _ = writeln!(log, "{s:>7.2} s  {name}");
    };

    // 1. The recording and its modes.
    let t = Instant::now();
    let rec = dir.join("recording.wav");
    write_atomic(&rec, |w| w.write_all(RECORDING))?;
    let clip = resound::io::load_audio(&rec)?;
    let x = clip.mono(None, &rec)?;
    let fs = f64::from(clip.sample_rate_hz);
    let params = resound::signal::AnalyzeParams {
        highpass_hz: Some(100.0),
        ..Default::default()
    };
    let analysis = resound::signal::analyze(&x, fs, &params)?;
    let onset = (analysis.onset_s * fs).round() as usize;
    let mut seg = x[onset..].to_vec();
    resound::signal::filter::highpass_zero_phase(&mut seg, 100.0, fs);
    seg.truncate(analysis.samples);
    crate::plot::analysis_png(
        &dir.join("recording.png"),
        &seg,
        &analysis,
        "recording: steel nut on aluminium ramp (CC BY 4.0)",
    )?;
    step(
        &format!(
            "analysed the recording: {} modes in the first of {} strikes",
            analysis.modes.len(),
            analysis.strikes_s.len()
        ),
        t,
        &mut log,
    );

    // 2. The stand-in object's modal model.
    let t = Instant::now();
    let plate = resound::fem::primitive::bar(RAMP);
    let aluminium = Material::preset("aluminium")?;
    let mp = resound::modal::ModalParams {
        n_modes: Some(80),
        max_freq_hz: None,
        ..Default::default()
    };
    let (model, _) = resound::modal::compute_modal_model(&plate, &aluminium, &mp, &|_| {})?;
    let model_path = dir.join("ramp.rmodal");
    resound::io::model_file::save(&model_path, &model)?;
    step(
        &format!(
            "modal model of a {}×{}×{} mm aluminium bar (stand-in for the ramp): {} modes, first at {:.0} Hz",
            RAMP[0] * 1e3,
            RAMP[1] * 1e3,
            RAMP[2] * 1e3,
            model.n_modes(),
            model.freq_hz(0)
        ),
        t,
        &mut log,
    );

    // 3. The material, into the library.
    let t = Instant::now();
    let hit = format!("{},{},{}", HIT[0], HIT[1], HIT[2]);
    crate::estimate_cmd::run(EstimateArgs {
        audio: rec.clone(),
        mesh: model_path.clone(),
        hit: hit.clone(),
        scale: 1.0,
        modes: 80,
        reference_material: "aluminium".into(),
        highpass_hz: Some(100.0),
        name: Some("demo-ramp".into()),
        output: Some(dir.join("material.json")),
        json: false,
        plot: Some(dir.join("estimate.png")),
        library: a.library.clone(),
        no_residual: false,
    })?;
    let m = resound::io::library::read_material(&dir.join("material.json"))?;
    step(
        &format!(
            "estimated the material (stored as demo-ramp): alpha {:.3e} 1/s, beta {:.3e} s, gamma {:.3e} m²/s², sigma {:.3e}",
            m.alpha, m.beta, m.gamma, m.sigma
        ),
        t,
        &mut log,
    );

    // 4. One strike of it.
    let t = Instant::now();
    crate::synth_cmd::run(SynthArgs {
        material: Some("demo-ramp".into()),
        mesh: Some(model_path.clone()),
        hit: Some(hit),
        modes: None,
        stats: None,
        seed: 1,
        velocity: 1.0,
        impactor_mass: None,
        impactor_radius: 0.005,
        impactor_material: "steel".into(),
        contact: ContactArg::Hertz,
        no_residual: false,
        duration: 1.5,
        sample_rate: 48_000,
        scale: 1.0,
        mesh_modes: 80,
        reference_material: "aluminium".into(),
        library: a.library.clone(),
        output: dir.join("strike.wav"),
        format: FormatArg::Pcm24,
        json: false,
        play: false,
    })?;
    step(
        "synthesized one strike of the material on the plate (modes + residual)",
        t,
        &mut log,
    );

    // 5. Grains of the whole recording (nuts rolling, sliding and striking).
    let t = Instant::now();
    let (recs, gfs, _) = crate::grains_cmd::load_recordings(
        &[rec.to_string_lossy().into_owned()],
        crate::grains_cmd::KindArg::Continuous,
        None,
    )?;
    let (dict, _) = resound::grains::analyze(
        &recs,
        gfs,
        &resound::grains::AnalyzeParams::default(),
        &|_, _| {},
    )?;
    resound::io::grains_file::save(&dir.join("demo.grains"), &dict)?;
    let rebuilt = resound::grains::resynth::resynthesize(
        &dict,
        0,
        &resound::grains::resynth::ResynthParams::default(),
    )?;
    let sc = resound::grains::quality::spectral_convergence_db(&recs[0].samples, &rebuilt, gfs);
    let stretched = resound::grains::resynth::resynthesize(
        &dict,
        0,
        &resound::grains::resynth::ResynthParams {
            time_scale: 1.5,
            variation: 0.3,
            seed: 3,
        },
    )?;
    resound::io::write_wav(
        &dir.join("grains_stretched.wav"),
        &stretched,
        gfs as u32,
        resound::io::WavFormat::Float32,
    )?;
    step(
        &format!(
            "cut the recording into {} grains (demo.grains; rebuilt to {sc:.0} dB spectral convergence) and stretched it 1.5× with variation (grains_stretched.wav)",
            dict.grains.len()
        ),
        t,
        &mut log,
    );

    // 6. The scene.
    let t = Instant::now();
    let scene_path = dir.join("scene.toml");
    write_atomic(&scene_path, |w| w.write_all(SCENE.as_bytes()))?;
    let summary = crate::scene_cmd::render_scene(&SceneArgs {
        scene: scene_path,
        output: dir.join("scene.wav"),
        events: Some(dir.join("events.jsonl")),
        library: a.library.clone(),
        cache: None,
        no_cache: a.no_cache,
        json: false,
        play: false,
        keep_level: false,
    })?;
    step(
        &format!(
            "rendered the scene: {} bodies, {} impacts, {} sliding and {} rolling body-steps, {:.0}× real time",
            summary["bodies"],
            summary["impacts"],
            summary["sliding_steps"],
            summary["rolling_steps"],
            summary["realtime_factor"].as_f64().unwrap_or(0.0)
        ),
        t,
        &mut log,
    );

    // 7. The result's picture and the summary.
    let t = Instant::now();
    let out = dir.join("scene.wav");
    let clip = resound::io::load_audio(&out)?;
    let left = clip.mono(Some(0), &out)?;
    crate::plot::spectrogram_png(
        &dir.join("scene.png"),
        &left,
        f64::from(clip.sample_rate_hz),
        "scene.wav (left)",
    )?;
    step("drew scene.png", t, &mut log);
    let mut text = String::new();
    let _ = writeln!(
        text,
        "Resound demo ({:.1} s in all)\n",
        total.elapsed().as_secs_f64()
    );
    text.push_str(&log);
    let _ = writeln!(
        text,
        "\nFiles: recording.wav/.png (the bundled recording and its modes), ramp.rmodal (the stand-in\n\
         plate), material.json and estimate.png (the estimated material: features with the Rayleigh\n\
         curve, loudness images), strike.wav, demo.grains and grains_stretched.wav (the recording's\n\
         grains, stretched 1.5×), scene.toml, scene.wav/.png, events.jsonl."
    );
    write_atomic(&dir.join("summary.txt"), |w| w.write_all(text.as_bytes()))?;
    println!("{text}");
    Ok(())
}
