//! `resound analyze`: the damped sinusoids of a recorded strike.

use anyhow::Result;
use clap::Args;
use resound::recording::{analyze_file, AnalysisReport};
use resound::signal::AnalyzeParams;
use std::path::PathBuf;

/// Arguments of `analyze`.
#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    /// Audio file: WAV (PCM 8/16/24/32, float 32/64), FLAC, OGG Vorbis or MP3.
    pub audio: PathBuf,
    /// Write the JSON result to this file ("-" for stdout).
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Draw the spectrogram with the modes marked and the (f, d) feature plane to this PNG.
    #[arg(long, value_name = "OUT.png")]
    pub plot: Option<PathBuf>,
    /// Keep at most this many modes (the strongest by level: RMS over the first 0.25 s).
    #[arg(long, default_value_t = 64)]
    pub max_modes: usize,
    /// Drop modes whose level (RMS over the first 0.25 s) is more than this many dB below the
    /// strongest's.
    #[arg(allow_hyphen_values = true, long, default_value_t = 60.0)]
    pub min_db: f64,
    /// Zero-phase 4th-order Butterworth high-pass first (e.g. 100 against room rumble). Without
    /// it, one is chosen when rumble is measured before or after the strike (reported).
    #[arg(allow_hyphen_values = true, long, value_name = "HZ")]
    pub highpass_hz: Option<f64>,
    #[command(flatten)]
    pub take: crate::util::TakeArgs,
    /// Analyse at most this many seconds after the onset.
    #[arg(allow_hyphen_values = true, long, default_value_t = 5.0)]
    pub max_duration_s: f64,
    /// Stop after Ren's spectrogram stage (no time-domain refinement).
    #[arg(long)]
    pub stage1_only: bool,
}

/// Runs `analyze`.
pub fn run(a: AnalyzeArgs) -> Result<()> {
    crate::util::check_paths([&a.audio], a.json.iter().chain(&a.plot))?;
    let params = AnalyzeParams {
        max_modes: a.max_modes,
        min_db: a.min_db,
        highpass_hz: a.highpass_hz,
        strike: a.take.strike_index()?,
        max_duration_s: a.max_duration_s,
        refine: !a.stage1_only,
        ..AnalyzeParams::default()
    };
    let (rec, res) = analyze_file(&a.audio, &a.take.recording(), &params)?;
    crate::util::warn_all(&res.warnings);
    let out = AnalysisReport::new(&a.audio.display().to_string(), &rec.codec, &res);
    match &a.json {
        Some(p) if p.as_os_str() == "-" => crate::util::print_json(&out)?,
        Some(p) => resound::files::write_json(p, &out)?,
        None => {}
    }
    if let Some(p) = &a.plot {
        resound::plot::analysis_png(p, &res, &a.audio.display().to_string())?;
    }
    if a.json.as_ref().is_none_or(|p| p.as_os_str() != "-") {
        print!("{res}");
    }
    Ok(())
}
