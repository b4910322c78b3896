//! `resound demo`: the whole pipeline on bundled data (`resound::demo`), with no arguments.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

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
    let params = resound::demo::DemoParams {
        out_dir: a.out_dir,
        library: a.library,
        cache_dir: if a.no_cache {
            None
        } else {
            resound::model_cache::default_dir()
        },
    };
    let report = resound::demo::run(&params, &|line| eprintln!("demo: {line}"))?;
    println!("{}", report.text);
    Ok(())
}
