//! `resound analyze`: the damped sinusoids of a recorded strike.

use anyhow::Result;
use clap::Args;
use resound::joint::analyze_joint;
use resound::recording::{analyze_file, AnalysisReport};
use resound::signal::AnalyzeParams;
use std::fmt::Display;
use std::path::{Path, PathBuf};

/// Arguments of `analyze`.
#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    /// Audio file: WAV (PCM 8/16/24/32, float 32/64), FLAC, OGG Vorbis or MP3. Several (the
    /// microphones or strikes of one object) need --joint.
    #[arg(required = true, num_args = 1..)]
    pub audio: Vec<PathBuf>,
    /// Fit one set of poles (f, d) shared by every take (files, and with --every-channel /
    /// --every-strike their channels and strikes), each take with its own amplitudes; poles
    /// whose takes disagree beyond their σ are flagged.
    #[arg(long, conflicts_with = "plot")]
    pub joint: bool,
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
    crate::util::check_paths(&a.audio, a.json.iter().chain(&a.plot))?;
    let params = AnalyzeParams {
        max_modes: a.max_modes,
        min_db: a.min_db,
        highpass_hz: a.highpass_hz,
        strike: a.take.strike_index()?,
        max_duration_s: a.max_duration_s,
        refine: !a.stage1_only,
        ..AnalyzeParams::default()
    };
    let select = a.take.selection();
    if a.joint {
        let rec = a.take.recording()?;
        let (out, _) = crate::util::with_bar("analyze", |cb| {
            analyze_joint(&a.audio, &rec, &params, select, &Default::default(), cb)
        })?;
        crate::util::warn_all(&out.warnings);
        return emit(a.json.as_deref(), &out, &out);
    }
    anyhow::ensure!(
        a.audio.len() == 1 && !select.every_channel && !select.every_strike,
        "several takes (files, --every-channel, --every-strike) are analysed together with --joint"
    );
    let (rec, res) = analyze_file(&a.audio[0], &a.take.recording()?, &params)?;
    crate::util::warn_all(&res.warnings);
    let out = AnalysisReport::new(&a.audio[0].display().to_string(), &rec.codec, &res);
    if let Some(p) = &a.plot {
        resound::plot::analysis_png(p, &res, &a.audio[0].display().to_string())?;
    }
    emit(a.json.as_deref(), &out, &res)
}

/// Writes the report as JSON where asked ("-": stdout) and prints the table unless stdout
/// holds the JSON.
fn emit(json: Option<&Path>, out: &impl serde::Serialize, table: &impl Display) -> Result<()> {
    match json {
        Some(p) if p.as_os_str() == "-" => return crate::util::print_json(out),
        Some(p) => resound::files::write_json(p, out)?,
        None => {}
    }
    print!("{table}");
    Ok(())
}
