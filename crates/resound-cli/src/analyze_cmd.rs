//! `resound analyze`: the damped sinusoids of a recorded strike.

use anyhow::{bail, Context, Result};
use clap::Args;
use resound::io::{atomic::write_atomic, load_audio};
use resound::signal::{analyze, resample::resample, Analysis, AnalyzeParams};
use serde_json::{json, Value};
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
    #[arg(long, default_value_t = 60.0)]
    pub min_db: f64,
    /// Zero-phase 4th-order Butterworth high-pass first (e.g. 100 against room rumble).
    #[arg(long, value_name = "HZ")]
    pub highpass_hz: Option<f64>,
    /// Analyse channel K (0-based) instead of the mix of all channels.
    #[arg(long, value_name = "K")]
    pub channel: Option<usize>,
    /// Resample to this rate first (rubato).
    #[arg(long, value_name = "HZ")]
    pub resample_hz: Option<u32>,
    /// Which strike to analyse when the file holds several (1 = first).
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub strike: usize,
    /// Analyse at most this many seconds after the onset.
    #[arg(long, default_value_t = 5.0)]
    pub max_duration_s: f64,
    /// Stop after Ren's spectrogram stage (no time-domain refinement).
    #[arg(long)]
    pub stage1_only: bool,
}

/// Runs `analyze`.
pub fn run(a: AnalyzeArgs) -> Result<()> {
    if a.strike == 0 {
        bail!("--strike counts from 1");
    }
    if !(a.max_duration_s > 0.02 && a.max_duration_s <= 600.0) {
        bail!("--max-duration-s must be in (0.02, 600]");
    }
    let clip = load_audio(&a.audio)?;
    let mut x = clip.mono(a.channel, &a.audio)?;
    let mut fs = clip.sample_rate_hz;
    if let Some(to) = a.resample_hz {
        if !(8000..=192_000).contains(&to) {
            bail!("--resample-hz must be in 8000..=192000");
        }
        x = resample(&x, fs, to).map_err(anyhow::Error::msg)?;
        fs = to;
    }
    let params = AnalyzeParams {
        max_modes: a.max_modes,
        min_db: a.min_db,
        highpass_hz: a.highpass_hz,
        strike: a.strike - 1,
        max_duration_s: a.max_duration_s,
        refine: !a.stage1_only,
        ..AnalyzeParams::default()
    };
    let res = analyze(&x, f64::from(fs), &params)
        .with_context(|| format!("cannot analyse {}", a.audio.display()))?;
    for w in &res.warnings {
        eprintln!("warning: {w}");
    }
    if res.modes.is_empty() {
        let hint = if res.strikes_s.len() > 1 {
            format!(
                " (strike {} of {} lasts {:.0} ms; try another with --strike)",
                a.strike,
                res.strikes_s.len(),
                1e3 * res.samples as f64 / res.sample_rate_hz
            )
        } else {
            String::new()
        };
        bail!(
            "no modes found in {} above the noise and within {} dB of the strongest peak{hint}",
            a.audio.display(),
            a.min_db
        );
    }
    let v = summary(&res, &a, &clip.codec);
    match &a.json {
        Some(p) if p.as_os_str() == "-" => println!("{}", serde_json::to_string_pretty(&v)?),
        Some(p) => {
            let text = serde_json::to_string_pretty(&v)?;
            write_atomic(p, |w| w.write_all(text.as_bytes()))?;
        }
        None => {}
    }
    if let Some(p) = &a.plot {
        let seg_start = (res.onset_s * res.sample_rate_hz).round() as usize;
        let mut seg = x[seg_start.min(x.len())..].to_vec();
        if let Some(f) = a.highpass_hz {
            resound::signal::filter::highpass_zero_phase(&mut seg, f, res.sample_rate_hz);
        }
        seg.truncate(res.samples);
        crate::plot::analysis_png(p, &seg, &res, &a.audio.display().to_string())?;
    }
    if a.json.as_ref().is_none_or(|p| p.as_os_str() != "-") {
        print_table(&res);
    }
    Ok(())
}

fn summary(r: &Analysis, a: &AnalyzeArgs, codec: &str) -> Value {
    json!({
        "file": a.audio.display().to_string(),
        "codec": codec,
        "sample_rate": r.sample_rate_hz,
        "onset_s": r.onset_s,
        "strikes_s": r.strikes_s,
        "analysed_s": r.samples as f64 / r.sample_rate_hz,
        "noise_rms": r.noise_rms,
        "clipped_samples": r.clipped_samples,
        "warnings": r.warnings,
        "elapsed_s": r.total_s,
        "modes": r.modes.iter().map(|m| json!({
            "freq_hz": m.freq_hz,
            "damping_per_s": m.damping_per_s,
            "amplitude": m.amplitude,
            "phase_rad": m.phase_rad,
        })).collect::<Vec<_>>(),
    })
}

fn print_table(r: &Analysis) {
    println!(
        "onset {:.4} s, {:.3} s analysed at {} Hz, noise {:.1} dBFS, {} modes ({:.2} s)",
        r.onset_s,
        r.samples as f64 / r.sample_rate_hz,
        r.sample_rate_hz,
        20.0 * r.noise_rms.max(1e-12).log10(),
        r.modes.len(),
        r.total_s
    );
    println!(
        "{:>4} {:>12} {:>12} {:>10} {:>9} {:>8}",
        "#", "freq_hz", "damping_1/s", "amplitude", "level_dB", "phase"
    );
    let strongest = r.modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
    for (i, m) in r.modes.iter().enumerate() {
        println!(
            "{:>4} {:>12.3} {:>12.3} {:>10.3e} {:>9.1} {:>8.3}",
            i + 1,
            m.freq_hz,
            m.damping_per_s,
            m.amplitude,
            20.0 * (m.amplitude / strongest).log10(),
            m.phase_rad
        );
    }
}
