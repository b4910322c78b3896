//! `resound compare`: how far apart two strikes sound (multi-resolution log-mel distance).

use anyhow::Result;
use clap::Args;
use resound::recording::compare_files;
use resound::signal::compare::LogMelParams;
use std::path::PathBuf;

/// Arguments of `compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The reference recording.
    pub a: PathBuf,
    /// The sound to compare with it (resampled to the reference's rate if needed).
    pub b: PathBuf,
    /// Channel of A (1 = the first, as in `analyze --channel`; default: the mix).
    #[arg(long, value_name = "K")]
    pub channel_a: Option<usize>,
    /// Channel of B (1 = the first; default: the mix).
    #[arg(long, value_name = "K")]
    pub channel_b: Option<usize>,
    /// Longest stretch compared after the onsets, s.
    #[arg(long, default_value_t = 2.0)]
    pub max_duration_s: f64,
    /// Band powers this far below the loudest band of either sound count as silence, dB (a
    /// rendered sound has no room noise: set it near the recording's noise floor).
    #[arg(long, default_value_t = 80.0)]
    pub floor_db: f64,
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `compare`.
pub fn run(a: CompareArgs) -> Result<()> {
    let params = LogMelParams {
        max_duration_s: a.max_duration_s,
        floor_db: a.floor_db,
        ..LogMelParams::default()
    };
    let (channel_a, channel_b) = (
        resound::recording::index_from_1("channel", a.channel_a)?,
        resound::recording::index_from_1("channel", a.channel_b)?,
    );
    let d = compare_files(&a.a, channel_a, &a.b, channel_b, &params)?;
    crate::util::show(a.json, &d)
}
