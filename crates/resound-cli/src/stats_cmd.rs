//! `resound stats`: per-material mode statistics (Traer et al. 2019).

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
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
    Ok(resound::files::write_json(path, s)?)
}

/// Runs `stats`.
pub fn run(c: StatsCmd) -> Result<()> {
    match c {
        StatsCmd::Fit(a) => {
            let mut all = Vec::new();
            let mut transients = Vec::new();
            for p in &a.recordings {
                let params = resound::signal::AnalyzeParams {
                    highpass_hz: a.highpass_hz,
                    ..Default::default()
                };
                let rp = resound::recording::RecordingParams::default();
                let (_, r) = resound::recording::analyze_file(p, &rp, &params)?;
                eprintln!("{}: {} modes", p.display(), r.modes.len());
                // The transient: what the modes leave of the analysed strike (Traer eq. 3).
                let fs = r.sample_rate_hz;
                let modal = resound::core::damped::synthesize(&r.modes, fs, r.segment.len());
                let residual: Vec<f64> = r.segment.iter().zip(&modal).map(|(a, b)| a - b).collect();
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
