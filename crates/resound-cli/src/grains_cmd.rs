//! `resound grains`: grain dictionaries (Picard, Tsingos & Faure 2009).

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use resound::grains::quality::spectral_convergence_db;
use resound::grains::resynth::{resynthesize, ResynthParams};
use resound::grains::{guess_contact, AnalyzeParams, Contact, Dictionary, Part, Recording, Stage};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

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

/// Kind of contact of the recordings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum KindArg {
    /// From the file name (roll…, slid…/scrap…) or else the envelope (sustained or bursts).
    Auto,
    /// Impacts, hits, breaking.
    Impact,
    /// Rolling.
    Rolling,
    /// Sliding, scraping.
    Sliding,
    /// Continuous contact of unknown kind.
    Continuous,
}

/// Arguments of `grains analyze`.
#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    /// Recordings (WAV, FLAC, OGG, MP3; channels are mixed). Prefix one with `impact:`,
    /// `rolling:`, `sliding:` or `continuous:` to set its kind.
    #[arg(required = true)]
    pub recordings: Vec<String>,
    /// Kind of the recordings without a prefix.
    #[arg(long, value_enum, default_value = "auto")]
    pub kind: KindArg,
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
    #[arg(long, default_value_t = 0.5)]
    pub min_corr: f64,
    /// Keep only the grains needed: drop each grain that another grain can stand in for at
    /// this correlation (e.g. 0.8). Smaller file, less exact rebuilds.
    #[arg(long, value_name = "CORR")]
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
    #[arg(long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Variation 0–1: pick among the grains within this of the best match (similar, not identical).
    #[arg(long, default_value_t = 0.0)]
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
}

/// Arguments of `grains info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Dictionary (.grains).
    pub dictionary: PathBuf,
}

fn contact_of(kind: KindArg, name: &str, x: &[f32], fs: f64) -> Contact {
    match kind {
        KindArg::Impact => Contact::Impact,
        KindArg::Rolling => Contact::Rolling,
        KindArg::Sliding => Contact::Sliding,
        KindArg::Continuous => Contact::Continuous,
        KindArg::Auto => {
            let n = name.to_lowercase();
            if n.contains("roll") {
                Contact::Rolling
            } else if n.contains("slid") || n.contains("scrap") {
                Contact::Sliding
            } else {
                guess_contact(x, fs)
            }
        }
    }
}

/// Loads recordings (with optional `kind:` prefixes) as mono f32 at one rate.
pub fn load_recordings(
    specs: &[String],
    kind: KindArg,
    rate: Option<u32>,
) -> Result<(Vec<Recording>, f64, usize)> {
    let mut out = Vec::new();
    let mut fs: Option<u32> = rate;
    let mut bytes = 0usize;
    for spec in specs {
        let (k, path) = match spec.split_once(':') {
            Some((p, rest)) if KindArg::from_str(p, true).is_ok() && !Path::new(spec).exists() => {
                (KindArg::from_str(p, true).unwrap_or(kind), rest)
            }
            _ => (kind, spec.as_str()),
        };
        let path = Path::new(path);
        bytes += std::fs::metadata(path).map_or(0, |m| m.len() as usize);
        let clip = resound::io::load_audio(path)?;
        let x = clip.mono(None, path)?;
        let target = *fs.get_or_insert(clip.sample_rate_hz);
        let x = resound::signal::resample::resample(&x, clip.sample_rate_hz, target)
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("{}", path.display()))?;
        let samples: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let name = path.file_stem().map_or(String::from("recording"), |s| {
            s.to_string_lossy().into_owned()
        });
        let contact = contact_of(k, &name, &samples, f64::from(target));
        out.push(Recording {
            name,
            contact,
            samples,
        });
    }
    Ok((out, f64::from(fs.unwrap_or(44_100)), bytes))
}

fn progress_bar() -> ProgressBar {
    let pb = ProgressBar::new(1000);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>9} [{elapsed}] {bar:30} {percent}%")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb
}

/// Figures of a dictionary, with each recording's rebuild quality when the originals are given.
pub fn summary(d: &Dictionary, originals: Option<&[Recording]>) -> Result<Value> {
    let mut recs = Vec::new();
    for (i, r) in d.recordings.iter().enumerate() {
        let grains = d
            .grains
            .iter()
            .filter(|g| g.recording as usize == i)
            .count();
        let peaks: usize = d.patterns_of(i).map(|(_, p)| p.peaks.len()).sum();
        let grain_bytes: usize = d
            .grains
            .iter()
            .filter(|g| g.recording as usize == i)
            .map(|g| g.samples.len() * resound::grains::GRAIN_SAMPLE_BYTES)
            .sum();
        let stored = grain_bytes + peaks * resound::grains::PEAK_BYTES;
        let mut v = json!({
            "name": r.name,
            "contact": r.contact,
            "duration_s": f64::from(r.samples) / d.sample_rate_hz,
            "grains": grains,
            "peaks": peaks,
            "grain_bytes": grain_bytes,
            "compression_ratio": (r.samples as usize * resound::grains::GRAIN_SAMPLE_BYTES) as f64
                / stored.max(1) as f64,
        });
        if let Some(o) = originals {
            let y = resynthesize(d, i, &ResynthParams::default())?;
            v["spectral_convergence_db"] =
                json!(spectral_convergence_db(&o[i].samples, &y, d.sample_rate_hz));
        }
        recs.push(v);
    }
    let count = |p: Part| d.grains_of(p).count();
    let stored = d.grain_bytes() + d.pattern_bytes();
    Ok(json!({
        "sample_rate_hz": d.sample_rate_hz,
        "grains": d.grains.len(),
        "impulsive": count(Part::Impulsive),
        "sinusoidal": count(Part::Sinusoidal),
        "transient": count(Part::Transient),
        "median_grain_ms": 1e3 * d.median_len(Part::Impulsive) as f64 / d.sample_rate_hz,
        "original_bytes": d.original_bytes(),
        "grain_bytes": d.grain_bytes(),
        "pattern_bytes": d.pattern_bytes(),
        "compression_ratio": d.original_bytes() as f64 / stored.max(1) as f64,
        "recordings": recs,
    }))
}

/// Runs `grains`.
pub fn run(c: GrainsCmd) -> Result<()> {
    match c {
        GrainsCmd::Analyze(a) => {
            let (recs, fs, _) = load_recordings(&a.recordings, a.kind, a.sample_rate)?;
            let mut params = AnalyzeParams::default();
            params.segment.min_db = a.min_db;
            params.pattern.peaks_per_part = a.peaks;
            params.pattern.min_corr = a.min_corr;
            let pb = progress_bar();
            let report = |s: Stage, f: f64| {
                pb.set_prefix(match s {
                    Stage::Split => "SMS",
                    Stage::Grains => "grains",
                    Stage::Patterns => "patterns",
                });
                pb.set_position((f * 1000.0) as u64);
            };
            let (dict, info) = resound::grains::analyze(&recs, fs, &params, &report)?;
            pb.finish_and_clear();
            let dict = match a.prune {
                Some(c) if (0.0..1.0).contains(&c) && c > 0.0 => {
                    resound::grains::prune::prune(&dict, c)
                }
                Some(c) => bail!("--prune must be a correlation in (0, 1), got {c}"),
                None => dict,
            };
            let size = resound::io::grains_file::save(&a.output, &dict)?;
            // Quality is measured on what was saved (16-bit grains).
            let saved = resound::io::grains_file::load(&a.output)?;
            let mut v = summary(&saved, Some(&recs))?;
            v["file_bytes"] = json!(size);
            v["analysis"] = serde_json::to_value(&info)?;
            if a.json {
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                eprintln!(
                    "wrote {} ({} grains: {} impulsive, {} sinusoidal, {} transient; {} bytes, compression {:.2}:1)",
                    a.output.display(),
                    v["grains"],
                    v["impulsive"],
                    v["sinusoidal"],
                    v["transient"],
                    size,
                    v["compression_ratio"].as_f64().unwrap_or(f64::NAN)
                );
                for r in v["recordings"].as_array().into_iter().flatten() {
                    eprintln!(
                        "  {:<28} {:<10} {:>6.2} s {:>5} grains, rebuild {:>6.1} dB",
                        r["name"].as_str().unwrap_or(""),
                        r["contact"].as_str().unwrap_or(""),
                        r["duration_s"].as_f64().unwrap_or(0.0),
                        r["grains"],
                        r["spectral_convergence_db"].as_f64().unwrap_or(f64::NAN)
                    );
                }
            }
        }
        GrainsCmd::Resynth(a) => {
            let d = resound::io::grains_file::load(&a.dictionary)?;
            let k = match a.recording.parse::<usize>() {
                Ok(k) => k,
                Err(_) => d
                    .recordings
                    .iter()
                    .position(|r| r.name == a.recording)
                    .with_context(|| {
                        format!(
                            "no recording '{}' in {} (it has: {})",
                            a.recording,
                            a.dictionary.display(),
                            d.recordings
                                .iter()
                                .map(|r| r.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        )
                    })?,
            };
            let p = ResynthParams {
                time_scale: a.time_scale,
                variation: a.variation,
                seed: a.seed,
            };
            let y = resynthesize(&d, k, &p)?;
            if y.is_empty() {
                bail!("recording {k} has no grains to rebuild it from");
            }
            if let Some(r) = &a.reference {
                let (o, _, _) = load_recordings(
                    &[r.to_string_lossy().into_owned()],
                    KindArg::Impact,
                    Some(d.sample_rate_hz as u32),
                )?;
                println!(
                    "spectral convergence {:.2} dB",
                    spectral_convergence_db(&o[0].samples, &y, d.sample_rate_hz)
                );
            }
            let peak = y.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            let scale = if peak > 0.999 { 0.891 / peak } else { 1.0 };
            if scale < 1.0 {
                eprintln!(
                    "note: turned down by {:.1} dB to stay below full scale",
                    -20.0 * scale.log10()
                );
            }
            let out: Vec<f32> = y.iter().map(|v| v * scale).collect();
            resound::io::write_wav(
                &a.output,
                &out,
                d.sample_rate_hz as u32,
                resound::io::WavFormat::Float32,
            )?;
            eprintln!(
                "wrote {} ({:.3} s)",
                a.output.display(),
                out.len() as f64 / d.sample_rate_hz
            );
        }
        GrainsCmd::Info(a) => {
            let d = resound::io::grains_file::load(&a.dictionary)?;
            println!("{}", serde_json::to_string_pretty(&summary(&d, None)?)?);
        }
    }
    Ok(())
}
