//! `resound scene`: render a physics scene (TOML) to audio and an event log.

use crate::estimate_cmd::library_path;
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use resound::io::atomic::write_atomic;
use resound::io::library::Library;
use resound::io::scene::read_scene;
use resound::io::{write_wav_channels, WavFormat};
use resound::scene::{build_scene, BuildOptions};
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `scene`.
#[derive(Args, Debug)]
pub struct SceneArgs {
    /// Scene file (TOML; see `resound scene --help` and the docs of resound_io::scene).
    pub scene: PathBuf,
    /// Output WAV (stereo unless the scene says `stereo = false`).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Event log (JSON lines: time, bodies, kind, force, speed, point).
    #[arg(long)]
    pub events: Option<PathBuf>,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Directory of cached modal models (default: $XDG_CACHE_HOME/resound/models).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Do not read or write cached modal models.
    #[arg(long)]
    pub no_cache: bool,
    /// JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// Also play the result (needs the `live` build feature).
    #[arg(long)]
    pub play: bool,
    /// Keep the physical level (σ-calibrated) instead of normalizing the peak to −1 dBFS; a mix
    /// that would clip is still turned down.
    #[arg(long)]
    pub keep_level: bool,
}

/// The default modal-model cache directory.
pub fn default_cache_dir() -> Option<PathBuf> {
    std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .map(|d| d.join("resound").join("models"))
}

/// Runs `scene`.
pub fn run(a: SceneArgs) -> Result<()> {
    let summary = render_scene(&a)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        eprintln!(
            "wrote {} ({} impacts, {:.1}x real time)",
            a.output.display(),
            summary["impacts"],
            summary["realtime_factor"].as_f64().unwrap_or(0.0)
        );
    }
    Ok(())
}

/// Renders a scene as `scene` would and returns the summary (used by `demo` too).
pub fn render_scene(a: &SceneArgs) -> Result<serde_json::Value> {
    let t0 = std::time::Instant::now();
    let scene = read_scene(&a.scene)?;
    let lib_path = library_path(&a.library)?;
    let library = Library::open(&lib_path)
        .with_context(|| format!("opening the material library {}", lib_path.display()))?;
    let base_dir = a
        .scene
        .parent()
        .map_or_else(|| PathBuf::from("."), PathBuf::from);
    let cache_dir = if a.no_cache {
        None
    } else {
        a.cache.clone().or_else(default_cache_dir)
    };
    let spinner = crate::util::spinner("scene");
    let progress = |m: &str| spinner.set_message(m.to_string());
    let (bodies, params) = build_scene(
        &scene,
        &BuildOptions {
            base_dir: &base_dir,
            library: Some(&library),
            cache_dir,
            progress: &progress,
        },
    )
    .with_context(|| format!("building {}", a.scene.display()))?;
    spinner.finish_and_clear();
    let build_s = t0.elapsed().as_secs_f64();
    let pb = ProgressBar::new(1000);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{elapsed}] {bar:30} {percent}% simulated")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_prefix("scene");
    let t1 = std::time::Instant::now();
    let mut out =
        resound::physics::simulate(&bodies, &params, &|f| pb.set_position((f * 1000.0) as u64))
            .with_context(|| format!("simulating {}", a.scene.display()))?;
    pb.finish_and_clear();
    let sim_s = t1.elapsed().as_secs_f64();
    // One gain for all channels: keep the image, never clip.
    let peak = out
        .channels
        .iter()
        .flat_map(|c| c.iter())
        .fold(0.0f32, |m, v| m.max(v.abs()));
    if !peak.is_finite() {
        anyhow::bail!("the scene's sound is not finite (absurd parameters?)");
    }
    let mut gain_db = 0.0f32;
    if peak > 0.891 || (!a.keep_level && peak > 0.0) {
        let g = 0.891 / peak;
        gain_db = 20.0 * g.log10();
        out.channels
            .iter_mut()
            .for_each(|c| c.iter_mut().for_each(|v| *v *= g));
        if a.keep_level {
            eprintln!(
                "note: peak {peak:.2} of full scale; turned down by {:.1} dB (no clipping)",
                -gain_db
            );
        }
    } else if peak == 0.0 {
        eprintln!("note: the scene is silent (no sounding contacts)");
    }
    let refs: Vec<&[f32]> = out.channels.iter().map(|c| c.as_slice()).collect();
    write_wav_channels(
        &a.output,
        &refs,
        params.sample_rate_hz as u32,
        WavFormat::Pcm24,
    )?;
    if let Some(p) = &a.events {
        let mut text = String::new();
        for e in &out.events {
            text.push_str(&serde_json::to_string(e)?);
            text.push('\n');
        }
        write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    if a.play {
        let n = out.channels[0].len();
        let mono: Vec<f32> = (0..n)
            .map(|i| out.channels.iter().map(|c| c[i]).sum::<f32>() / out.channels.len() as f32)
            .collect();
        crate::live::play(
            crate::live::LiveParts {
                modes: Vec::new(),
                force: Vec::new(),
                extra: mono,
                gain: 1.0,
            },
            params.sample_rate_hz as u32,
            params.duration_s,
        )?;
    }
    let s = &out.stats;
    Ok(json!({
        "output": a.output.display().to_string(),
        "bodies": bodies.len(),
        "duration_s": params.duration_s,
        "build_s": build_s,
        "simulate_s": sim_s,
        "physics_s": s.physics_s,
        "audio_s": s.audio_s,
        "realtime_factor": params.duration_s / sim_s.max(1e-9),
        "impacts": s.impacts,
        "sliding_steps": s.sliding_steps,
        "rolling_steps": s.rolling_steps,
        "max_voices": s.max_voices,
        "peak": peak,
        "gain_db": gain_db,
        "events": out.events.len(),
        "peak_rss_mb": peak_rss_mb(),
    }))
}

/// This process's peak resident memory (VmHWM), MB; 0 where /proc is unavailable.
fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}
