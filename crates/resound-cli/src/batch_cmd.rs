//! `resound batch`: render a jobs file (JSON lines) to content-addressed files, one shard per
//! process.

use crate::util::{print_json, warn_all};
use anyhow::{bail, Result};
use clap::Args;
use resound::batch::{parse_shard, run_batch, BatchParams};
use std::path::PathBuf;

/// Arguments of `batch`.
#[derive(Args, Debug)]
pub struct BatchArgs {
    /// Jobs: one JSON object per line (mesh, material, hits, speeds_m_s, listener, outputs, …;
    /// see the README). Paths in it are relative to this file.
    pub jobs: PathBuf,
    /// Output directory: `<2 hex>/<hash>.wav|json` and `manifest-<i>-of-<N>.jsonl`.
    #[arg(long)]
    pub out: PathBuf,
    /// This process's share of the jobs, `i/N` with 0 ≤ i < N (Slurm:
    /// `$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`, Kubernetes: `$JOB_COMPLETION_INDEX/N`).
    #[arg(long, default_value = "0/1")]
    pub shard: String,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Keep solved modal models here (`.rmodal` by content hash), shared across runs and shards.
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Print the run's figures as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `batch`.
pub fn run(a: BatchArgs) -> Result<()> {
    let params = BatchParams {
        out_dir: a.out.clone(),
        shard: parse_shard(&a.shard)?,
        library: a.library.clone(),
        cache_dir: a.cache.clone(),
    };
    let info = crate::util::with_bar("batch", |cb| run_batch(&a.jobs, &params, cb))?;
    warn_all(&info.warnings);
    if a.json {
        print_json(&info)?;
    } else {
        println!("shard {}: {info}", a.shard);
    }
    if let Some(failed) = info.failure_report(&a.jobs) {
        bail!("{failed}");
    }
    Ok(())
}
