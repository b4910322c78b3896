//! `resound stats`: per-material mode statistics (Traer et al. 2019).

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use resound::io::atomic::write_atomic;
use resound::stats::ModeStatistics;
use std::path::{Path, PathBuf};

/// `resound stats …`.
#[derive(Subcommand, Debug)]
pub enum StatsCmd {
    /// Fit mode statistics to recordings of one material.
    Fit(FitArgs),
    /// Convert the TDW PyImpact material tables (material_data/*.json) into statistics files.
    ImportPyimpact(ImportArgs),
}

/// Arguments of `stats fit`.
#[derive(Args, Debug)]
pub struct FitArgs {
    /// Recordings (one strike each; the first strike is used).
    #[arg(required = true)]
    pub recordings: Vec<PathBuf>,
    /// Material name.
    #[arg(long)]
    pub material: String,
    /// Modes per impulse response (Traer: 15).
    #[arg(long, default_value_t = 15)]
    pub modes: usize,
    /// Zero-phase high-pass before analysis.
    #[arg(long, value_name = "HZ")]
    pub highpass_hz: Option<f64>,
    /// Output statistics file (JSON).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Arguments of `stats import-pyimpact`.
#[derive(Args, Debug)]
pub struct ImportArgs {
    /// Directory of PyImpact tables (`<material>_<size>_mm.json`).
    pub dir: PathBuf,
    /// Output directory for `<material>_<size>.stats.json`.
    #[arg(short, long, default_value = ".")]
    pub output: PathBuf,
}

fn save(path: &Path, s: &ModeStatistics) -> Result<()> {
    let text = serde_json::to_string_pretty(s)?;
    write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// Reads a statistics file.
pub fn load(path: &Path) -> Result<ModeStatistics> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let s: ModeStatistics = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a statistics file", path.display()))?;
    let dim = 3 * s.modes;
    if s.modes == 0 || s.mean.len() != dim || s.covariance.len() != dim * dim {
        bail!(
            "{}: inconsistent statistics ({} modes)",
            path.display(),
            s.modes
        );
    }
    Ok(s)
}

/// Runs `stats`.
pub fn run(c: StatsCmd) -> Result<()> {
    match c {
        StatsCmd::Fit(a) => {
            let mut all = Vec::new();
            let mut transients = Vec::new();
            for p in &a.recordings {
                let clip = resound::io::load_audio(p)?;
                let x = clip.mono(None, p)?;
                let params = resound::signal::AnalyzeParams {
                    highpass_hz: a.highpass_hz,
                    ..Default::default()
                };
                let r = resound::signal::analyze(&x, f64::from(clip.sample_rate_hz), &params)
                    .with_context(|| format!("analysing {}", p.display()))?;
                eprintln!("{}: {} modes", p.display(), r.modes.len());
                // The transient: what the modes leave of the strike (Traer eq. 3).
                let fs = f64::from(clip.sample_rate_hz);
                let onset = (r.onset_s * fs).round() as usize;
                let mut seg = x[onset.min(x.len())..].to_vec();
                if let Some(f) = a.highpass_hz {
                    resound::signal::filter::highpass_zero_phase(&mut seg, f, fs);
                }
                seg.truncate(r.samples);
                let modal = resound::core::damped::synthesize(&r.modes, fs, seg.len());
                let residual: Vec<f64> = seg.iter().zip(&modal).map(|(a, b)| a - b).collect();
                transients.push(resound::stats::transient::fit_transient(&residual, fs, 30));
                all.push(r.modes);
            }
            let mut s = ModeStatistics::fit(&a.material, &all, a.modes)?;
            s.transient = resound::stats::TransientStats::fit(&transients).ok();
            save(&a.output, &s)?;
            eprintln!(
                "wrote {} ({} recordings, {} modes)",
                a.output.display(),
                s.sources,
                s.modes
            );
        }
        StatsCmd::ImportPyimpact(a) => {
            let mut n = 0;
            let mut entries: Vec<PathBuf> = std::fs::read_dir(&a.dir)
                .with_context(|| format!("reading {}", a.dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "json"))
                .collect();
            entries.sort();
            if entries.is_empty() {
                bail!("{}: no PyImpact tables (*.json)", a.dir.display());
            }
            std::fs::create_dir_all(&a.output)?;
            for p in entries {
                let stem = p
                    .file_stem()
                    .map_or(String::new(), |s| s.to_string_lossy().into_owned());
                let name = stem.strip_suffix("_mm").unwrap_or(&stem).to_string();
                let text = std::fs::read_to_string(&p)
                    .with_context(|| format!("reading {}", p.display()))?;
                let s = ModeStatistics::from_pyimpact_json(&name, &text)
                    .with_context(|| format!("{}", p.display()))?;
                save(&a.output.join(format!("{name}.stats.json")), &s)?;
                n += 1;
            }
            eprintln!("imported {n} tables into {}", a.output.display());
        }
    }
    Ok(())
}
