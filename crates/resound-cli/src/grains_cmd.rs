//! `resound grains`: grain dictionaries (Picard, Tsingos & Faure 2009).

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use resound::grain_files::{
    analyze_to_file, expand_recording_specs, load_recordings, parse_kind, recording_spec,
    resynthesize_for_file, summary, KindRule,
};
use resound::grains::resynth::ResynthParams;
use resound::grains::AnalyzeParams;
use std::path::PathBuf;

/// `resound grains …`.
#[derive(Subcommand, Debug)]
pub enum GrainsCmd {
    /// Cut recordings into grains and correlation patterns, saved as one dictionary file.
    Analyze(AnalyzeArgs),
    /// Rebuild a recording from a dictionary (optionally time-scaled or varied), to WAV.
    Resynth(ResynthArgs),
    /// Print a dictionary's contents and sizes.
    Info(InfoArgs),
}

/// Arguments of `grains analyze`.
#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    /// Recordings (WAV, FLAC, OGG, MP3; channels are mixed). Prefix one with `impact:`,
    /// `rolling:`, `sliding:` or `continuous:` to set its kind; wildcards behind a prefix
    /// (`impact:hit*.wav`, which no shell expands) are expanded here.
    #[arg(required = true)]
    pub recordings: Vec<String>,
    /// Kind of the recordings without a prefix: auto, impact, rolling, sliding or continuous.
    #[arg(long, default_value = "auto", value_parser = kind_rule)]
    pub kind: KindRule,
    /// Analysis sample rate (default: the first recording's); others are resampled.
    #[arg(long, value_name = "HZ")]
    pub sample_rate: Option<u32>,
    /// Drop grains this far below the loudest grain of their recording part, dB.
    #[arg(long, default_value_t = -50.0, allow_hyphen_values = true)]
    pub min_db: f64,
    /// Peaks kept per recording part (default: 3 per mean grain length, plus each grain's own).
    #[arg(long)]
    pub peaks: Option<usize>,
    /// Smallest correlation a pattern peak may have.
    #[arg(allow_hyphen_values = true, long, default_value_t = 0.5)]
    pub min_corr: f64,
    /// Keep only the grains needed: drop each grain that another grain can stand in for at
    /// this correlation (e.g. 0.8). Smaller file, less exact rebuilds.
    #[arg(allow_hyphen_values = true, long, value_name = "CORR")]
    pub prune: Option<f64>,
    /// Output dictionary (.grains).
    #[arg(short, long)]
    pub output: PathBuf,
    /// JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `grains resynth`.
#[derive(Args, Debug)]
pub struct ResynthArgs {
    /// Dictionary (.grains).
    pub dictionary: PathBuf,
    /// Recording to rebuild: its index (from 0) or name.
    #[arg(long)]
    pub recording: String,
    /// Time-scale factor α (2: twice as long).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Variation 0–1: pick among the grains within this of the best match (similar, not identical).
    #[arg(allow_hyphen_values = true, long, default_value_t = 0.0)]
    pub variation: f64,
    /// Seed of the variation.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The original recording: print the spectral convergence of the rebuild against it.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Output WAV.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output sample rate, Hz (the dictionary keeps its recordings' rate).
    #[arg(long, default_value_t = resound::core::limits::DEFAULT_SAMPLE_RATE_HZ)]
    pub sample_rate: u32,
    /// Output sample format.
    #[arg(long, value_name = "pcm16|pcm24|float", default_value = "pcm24", value_parser = crate::util::named::<resound::io::WavFormat>)]
    pub format: resound::io::WavFormat,
    /// Print the report (length, level, spectral convergence) as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `grains info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Dictionary (.grains).
    pub dictionary: PathBuf,
}

/// Runs `grains`.
fn kind_rule(s: &str) -> Result<KindRule> {
    parse_kind(s).context("one of auto, impact, rolling, sliding, continuous")
}

pub fn run(c: GrainsCmd) -> Result<()> {
    match c {
        GrainsCmd::Analyze(a) => {
            let specs = expand_recording_specs(&a.recordings)?;
            let inputs = specs.iter().map(|r| recording_spec(r, a.kind).1);
            crate::util::check_paths(inputs, [&a.output])?;
            let (recs, fs, _) = load_recordings(&specs, a.kind, a.sample_rate)?;
            let mut params = AnalyzeParams::default();
            params.segment.min_db = a.min_db;
            params.pattern.peaks_per_part = a.peaks;
            params.pattern.min_corr = a.min_corr;
            let made = crate::util::with_bar("grains", |cb| {
                analyze_to_file(&recs, fs, &params, a.prune, &a.output, cb)
            })?;
            if a.json {
                crate::util::print_json(&made)?;
            } else {
                eprintln!("wrote {}: {made}", a.output.display());
            }
        }
        GrainsCmd::Resynth(a) => {
            crate::util::check_paths([&a.dictionary].into_iter().chain(&a.reference), [&a.output])?;
            let d = resound::io::grains_file::load(&a.dictionary)?;
            let p = ResynthParams {
                time_scale: a.time_scale,
                variation: a.variation,
                seed: a.seed,
            };
            let r =
                resynthesize_for_file(&d, &a.recording, &p, a.reference.as_deref(), a.sample_rate)
                    .with_context(|| a.dictionary.display().to_string())?;
            crate::util::warn_all(&r.info.warnings);
            crate::util::notes(&r.info.notes);
            resound::io::write_wav(&a.output, &r.samples, a.sample_rate, a.format)?;
            if a.json {
                return crate::util::print_json(&r.info);
            }
            eprintln!("wrote {} ({})", a.output.display(), r.info);
        }
        GrainsCmd::Info(a) => {
            let d = resound::io::grains_file::load(&a.dictionary)?;
            crate::util::print_json(&summary(&d, None)?)?;
        }
    }
    Ok(())
}
