//! `resound scene`: render a physics scene (TOML) to audio and an event log.

use anyhow::Result;
use clap::Args;
use resound::io::{write_wav_channels, WavFormat};
use resound::scene::{render_scene, SceneRenderParams};
use std::path::PathBuf;

/// Arguments of `scene`.
#[derive(Args, Debug)]
#[command(after_long_help = resound::io::scene::FORMAT_HELP)]
pub struct SceneArgs {
    /// Scene file (TOML: bodies, materials, listener; the format is at the end of --help).
    pub scene: PathBuf,
    /// Output WAV (stereo unless the scene says `stereo = false`); not needed with `--live`.
    #[arg(short, long, required_unless_present = "live")]
    pub output: Option<PathBuf>,
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
    #[arg(long, hide = !cfg!(feature = "live"))]
    pub play: bool,
    /// Play the scene live on the default audio device while it is simulated: rapier steps on
    /// its own thread, the audio callback renders (needs the `live` build feature). The level
    /// is the physical one (σ-calibrated) times `--gain-db`.
    #[arg(long, conflicts_with = "play")]
    pub live: bool,
    /// Run the live path against a simulated device (no sound card needed) and write what it
    /// would have played to `--output`: physics thread, lock-free queues, device blocks.
    #[arg(long, conflicts_with = "live")]
    pub simulate_device: bool,
    /// Device block for `--live` and `--simulate-device`, samples.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub block: u32,
    /// Gain of `--live` playback, dB.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub gain_db: f64,
    /// Keep the physical level (σ-calibrated) instead of normalizing the peak to −1 dBFS; a mix
    /// that would clip is still turned down.
    #[arg(long)]
    pub keep_level: bool,
}

/// Runs `scene`.
pub fn run(a: SceneArgs) -> Result<()> {
    crate::util::check_paths([&a.scene], a.output.iter().chain(&a.events))?;
    let mut params = SceneRenderParams {
        library: a.library.clone(),
        cache_dir: if a.no_cache {
            None
        } else {
            a.cache.clone().or_else(resound::model_cache::default_dir)
        },
        keep_level: a.keep_level,
        live: None,
    };
    if a.live {
        let r = resound::live::play_scene(&a.scene, &params, a.block as usize, a.gain_db, &|p| {
            eprintln!("{p}")
        })?;
        eprintln!("played {} live: {r}", a.scene.display());
        return Ok(());
    }
    if a.simulate_device {
        params.live = Some(resound::physics::live::LiveParams {
            block: a.block as usize,
            ..Default::default()
        });
    }
    let Some(output) = a.output.as_ref() else {
        anyhow::bail!("--output is needed");
    };
    let r = crate::util::with_bar("scene", |cb| render_scene(&a.scene, &params, cb))?;
    crate::util::warn_all(&r.summary.warnings);
    crate::util::notes(&r.summary.notes);
    let refs: Vec<&[f32]> = r.channels.iter().map(|c| c.as_slice()).collect();
    write_wav_channels(output, &refs, r.sample_rate_hz, WavFormat::Pcm24)?;
    if let Some(p) = &a.events {
        resound::files::write_json_lines(p, &r.events)?;
    }
    if a.play {
        resound::live::play_channels(&r.channels, r.sample_rate_hz)?;
    }
    let s = &r.summary;
    if a.json {
        return crate::util::print_written(output, s);
    }
    eprintln!("wrote {} ({s})", output.display());
    Ok(())
}
