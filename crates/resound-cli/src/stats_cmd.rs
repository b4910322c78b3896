//! `resound stats`: per-material mode statistics (Traer et al. 2019).

use anyhow::Result;
use clap::{Args, Subcommand};
use std::path::PathBuf;

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
    #[arg(allow_hyphen_values = true, long, value_name = "HZ")]
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

/// Runs `stats`.
pub fn run(c: StatsCmd) -> Result<()> {
    match c {
        StatsCmd::Fit(a) => {
            crate::util::check_paths(&a.recordings, [&a.output])?;
            let s = crate::util::with_bar("stats", |cb| {
                resound::files::fit_stats(&a.recordings, &a.material, a.modes, a.highpass_hz, cb)
            })?;
            resound::files::write_json(&a.output, &s)?;
            eprintln!(
                "wrote {} ({} recordings, {} modes)",
                a.output.display(),
                s.sources,
                s.modes
            );
        }
        StatsCmd::ImportPyimpact(a) => {
            let tables = resound::files::import_pyimpact_into(&a.dir, &a.output)?;
            eprintln!(
                "imported {} tables into {}",
                tables.len(),
                a.output.display()
            );
        }
    }
    Ok(())
}
