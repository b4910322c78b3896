//! Grains (Picard 2009) from files: recordings with their contact kind, dictionary figures.

use crate::error::{invalid, Result};
use resound_grains::quality::spectral_convergence_db;
use resound_grains::resynth::{resynthesize, ResynthParams};
use resound_grains::{guess_contact, Contact, Dictionary, Part, Recording};
use serde::Serialize;
use std::path::Path;

/// How the contact kind of a recording is decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KindRule {
    /// From the file name (roll…, slid…/scrap…), else the envelope (sustained or bursts).
    Auto,
    /// This kind for every recording.
    Fixed(Contact),
}

/// A recording given as `PATH` or `KIND:PATH` (a file of that name wins): its kind rule
/// (`rule` unless the spec names one) and its path.
pub fn recording_spec(spec: &str, rule: KindRule) -> (KindRule, &Path) {
    match spec.split_once(':') {
        Some((p, rest)) if !Path::new(spec).exists() => match parse_kind(p) {
            Some(k) => (k, Path::new(rest)),
            None => (rule, Path::new(spec)),
        },
        _ => (rule, Path::new(spec)),
    }
}

/// Expands the wildcards (`*`, `?`, `[…]`) of recording specs, with or without a `KIND:`
/// prefix: no shell expands `impact:hit*.wav` (the prefix is part of the word), so the
/// tool does, in name order, keeping the prefix on every match. A spec naming an existing
/// file is kept as it is.
///
/// # Errors
/// A pattern that is malformed or matches no file.
pub fn expand_recording_specs(specs: &[String]) -> Result<Vec<String>> {
    let mut out = Vec::with_capacity(specs.len());
    for spec in specs {
        let (prefix, path) = match spec.split_once(':') {
            Some((p, rest)) if parse_kind(p).is_some() => (Some(p), rest),
            _ => (None, spec.as_str()),
        };
        if Path::new(spec).exists() || !path.contains(['*', '?', '[']) {
            out.push(spec.clone());
            continue;
        }
        let paths =
            glob::glob(path).map_err(|e| invalid(format!("recording pattern '{spec}': {e}")))?;
        let mut found: Vec<String> = paths
            .filter_map(std::result::Result::ok)
            .filter(|p| p.is_file())
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        if found.is_empty() {
            return Err(invalid(format!(
                "recording pattern '{spec}' matches no file"
            )));
        }
        found.sort();
        out.extend(found.into_iter().map(|p| match prefix {
            Some(k) => format!("{k}:{p}"),
            None => p,
        }));
    }
    Ok(out)
}

/// Parses a contact kind name (`impact`, `rolling`, `sliding`, `continuous`, `auto`).
pub fn parse_kind(name: &str) -> Option<KindRule> {
    Some(match name.to_ascii_lowercase().as_str() {
        "auto" => KindRule::Auto,
        "impact" => KindRule::Fixed(Contact::Impact),
        "rolling" => KindRule::Fixed(Contact::Rolling),
        "sliding" => KindRule::Fixed(Contact::Sliding),
        "continuous" => KindRule::Fixed(Contact::Continuous),
        _ => return None,
    })
}

fn contact_of(rule: KindRule, name: &str, x: &[f32], fs: f64) -> Contact {
    match rule {
        KindRule::Fixed(c) => c,
        KindRule::Auto => {
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

/// The shortest recording grains are cut from, s (a few grain lengths).
pub const MIN_RECORDING_S: f64 = 0.02;

/// The longest recording grains are cut from, s, and the longest all of them together. Every
/// grain's correlation pattern is taken over every recording of its kind (Picard 2009), so the
/// cost grows with the square of the length: 2 minutes take about half a minute here.
pub const MAX_RECORDING_S: f64 = 120.0;
/// See [`MAX_RECORDING_S`].
pub const MAX_TOTAL_S: f64 = 300.0;

/// Loads recordings (each spec a path, optionally prefixed `kind:`) as mono f32 at one rate
/// (`rate`, else the first file's): the recordings, the rate, and the bytes on disk.
///
/// # Errors
/// Unreadable files; failed resampling; recordings shorter than [`MIN_RECORDING_S`], longer
/// than [`MAX_RECORDING_S`] (or [`MAX_TOTAL_S`] together), or silent.
pub fn load_recordings(
    specs: &[String],
    rule: KindRule,
    rate: Option<u32>,
) -> Result<(Vec<Recording>, f64, usize)> {
    if let Some(r) = rate {
        // Checked before any resampling: a rate of gigahertz would ask for unbounded memory.
        if !resound_core::limits::sample_rate_ok(f64::from(r)) {
            return Err(invalid(resound_core::limits::sample_rate_message(
                f64::from(r),
            )));
        }
    }
    let specs = &expand_recording_specs(specs)?;
    let mut out = Vec::new();
    let mut fs: Option<u32> = rate;
    let mut bytes = 0usize;
    let mut total_s = 0.0;
    for spec in specs {
        let (k, path) = recording_spec(spec, rule);
        bytes += std::fs::metadata(path).map_or(0, |m| m.len() as usize);
        let clip = resound_io::load_audio(path)?;
        let x = clip.mono(None, path)?;
        let target = *fs.get_or_insert(clip.sample_rate_hz);
        let x = resound_signal::resample::resample(&x, clip.sample_rate_hz, target)
            .map_err(|e| invalid(e).at(path))?;
        let samples: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let name = path.file_stem().map_or(String::from("recording"), |s| {
            s.to_string_lossy().into_owned()
        });
        total_s += samples.len() as f64 / f64::from(target);
        let r =
            recording_from_samples(name, samples, f64::from(target), k).map_err(|e| e.at(path))?;
        if total_s > MAX_TOTAL_S {
            return Err(invalid(format!(
                "the recordings add up to more than {MAX_TOTAL_S:.0} s; analyse them in groups"
            ))
            .at(path));
        }
        out.push(r);
    }
    Ok((out, f64::from(fs.unwrap_or(44_100)), bytes))
}

/// One recording of samples at `sample_rate_hz` to cut grains from, its contact kind decided
/// by `rule` (from `name` or the envelope), checked as [`load_recordings`] checks files.
///
/// # Errors
/// Recordings shorter than [`MIN_RECORDING_S`] or longer than [`MAX_RECORDING_S`], silent or
/// with non-finite samples; a rate outside the supported range (`resound_core::limits`).
pub fn recording_from_samples(
    name: String,
    samples: Vec<f32>,
    sample_rate_hz: f64,
    rule: KindRule,
) -> Result<Recording> {
    if !resound_core::limits::sample_rate_ok(sample_rate_hz) {
        return Err(invalid(resound_core::limits::sample_rate_message(
            sample_rate_hz,
        )));
    }
    if samples.iter().any(|v| !v.is_finite()) {
        return Err(invalid("the recording has non-finite samples"));
    }
    let min = (MIN_RECORDING_S * sample_rate_hz).ceil() as usize;
    if samples.len() < min {
        return Err(invalid(format!(
            "{:.1} ms long: grains need at least {:.0} ms of audio",
            1e3 * samples.len() as f64 / sample_rate_hz,
            1e3 * MIN_RECORDING_S
        )));
    }
    if samples.iter().all(|&v| v == samples[0]) {
        return Err(invalid(
            "silent (every sample is the same): nothing to cut into grains",
        ));
    }
    let seconds = samples.len() as f64 / sample_rate_hz;
    if seconds > MAX_RECORDING_S {
        return Err(invalid(format!(
            "{seconds:.0} s long: grains take recordings of at most {MAX_RECORDING_S:.0} s \
             (each grain is matched over the whole recording, so the cost grows with the \
             square of the length); cut it into parts"
        )));
    }
    let contact = contact_of(rule, &name, &samples, sample_rate_hz);
    Ok(Recording {
        name,
        contact,
        samples,
    })
}

/// Figures of one recording in a dictionary.
#[derive(Clone, Debug, Serialize)]
pub struct RecordingSummary {
    /// Name.
    pub name: String,
    /// Contact kind.
    pub contact: Contact,
    /// Length, s.
    pub duration_s: f64,
    /// Grains cut from it.
    pub grains: usize,
    /// Pattern peaks.
    pub peaks: usize,
    /// Bytes of its grains.
    pub grain_bytes: usize,
    /// Its 16-bit size over what the dictionary stores for it.
    pub compression_ratio: f64,
    /// Rebuild quality against the original, dB (when the originals are given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectral_convergence_db: Option<f64>,
}

/// Figures of a dictionary.
#[derive(Clone, Debug, Serialize)]
pub struct DictionarySummary {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Grains.
    pub grains: usize,
    /// Impulsive grains.
    pub impulsive: usize,
    /// Sinusoidal grains.
    pub sinusoidal: usize,
    /// Transient grains.
    pub transient: usize,
    /// Median impulsive grain, ms.
    pub median_grain_ms: f64,
    /// 16-bit mono size of the recordings.
    pub original_bytes: usize,
    /// Bytes of grains.
    pub grain_bytes: usize,
    /// Bytes of patterns.
    pub pattern_bytes: usize,
    /// Original over stored.
    pub compression_ratio: f64,
    /// Per recording.
    pub recordings: Vec<RecordingSummary>,
}

/// Figures of `d`, with each recording's rebuild quality when the `originals` are given.
///
/// # Errors
/// A failed rebuild.
pub fn summary(d: &Dictionary, originals: Option<&[Recording]>) -> Result<DictionarySummary> {
    let mut recs = Vec::new();
    for (i, r) in d.recordings.iter().enumerate() {
        let mine = || d.grains.iter().filter(move |g| g.recording as usize == i);
        let peaks: usize = d.patterns_of(i).map(|(_, p)| p.peaks.len()).sum();
        let grain_bytes: usize = mine()
            .map(|g| g.samples.len() * resound_grains::GRAIN_SAMPLE_BYTES)
            .sum();
        let stored = grain_bytes + peaks * resound_grains::PEAK_BYTES;
        let spectral_convergence_db = match originals {
            Some(o) => {
                let y = resynthesize(d, i, &ResynthParams::default())?;
                Some(spectral_convergence_db(&o[i].samples, &y, d.sample_rate_hz))
            }
            None => None,
        };
        recs.push(RecordingSummary {
            name: r.name.clone(),
            contact: r.contact,
            duration_s: f64::from(r.samples) / d.sample_rate_hz,
            grains: mine().count(),
            peaks,
            grain_bytes,
            compression_ratio: (r.samples as usize * resound_grains::GRAIN_SAMPLE_BYTES) as f64
                / stored.max(1) as f64,
            spectral_convergence_db,
        });
    }
    let count = |p: Part| d.grains_of(p).count();
    let stored = d.grain_bytes() + d.pattern_bytes();
    Ok(DictionarySummary {
        sample_rate_hz: d.sample_rate_hz,
        grains: d.grains.len(),
        impulsive: count(Part::Impulsive),
        sinusoidal: count(Part::Sinusoidal),
        transient: count(Part::Transient),
        median_grain_ms: 1e3 * d.median_len(Part::Impulsive) as f64 / d.sample_rate_hz,
        original_bytes: d.original_bytes(),
        grain_bytes: d.grain_bytes(),
        pattern_bytes: d.pattern_bytes(),
        compression_ratio: d.original_bytes() as f64 / stored.max(1) as f64,
        recordings: recs,
    })
}

/// The index of a recording given by index or name.
///
/// # Errors
/// Unknown names (listing the known ones).
pub fn recording_index(d: &Dictionary, spec: &str) -> Result<usize> {
    if let Ok(k) = spec.parse::<usize>() {
        if k < d.recordings.len() {
            return Ok(k);
        }
    }
    d.recordings
        .iter()
        .position(|r| r.name == spec)
        .ok_or_else(|| {
            invalid(format!(
                "no recording '{spec}' (the dictionary has: {})",
                d.recordings
                    .iter()
                    .map(|r| r.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
}

/// Rebuilds recording `spec` (index or name) of `d` from its grains with `params`: samples
/// at the dictionary's rate, at the recording's level.
///
/// # Errors
/// An unknown recording; one with no grains to rebuild it from (nothing would be heard).
pub fn resynthesize_recording(
    d: &Dictionary,
    spec: &str,
    params: &ResynthParams,
) -> Result<Vec<f32>> {
    let k = recording_index(d, spec)?;
    let y = resynthesize(d, k, params)?;
    if y.is_empty() {
        return Err(invalid(format!(
            "recording {k} ('{}') has no grains to rebuild it from",
            d.recordings[k].name
        )));
    }
    Ok(y)
}

/// A recording rebuilt from a dictionary for a file (`grains resynth`): the samples and its
/// report.
#[derive(Clone, Debug)]
pub struct Resynthesis {
    /// Mono samples at the dictionary's rate, turned down when they would clip.
    pub samples: Vec<f32>,
    /// The report.
    pub info: ResynthInfo,
}

/// What [`resynthesize_for_file`] did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ResynthInfo {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Length, s.
    pub duration_s: f64,
    /// Spectral convergence against the reference recording, dB (lower is closer).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectral_convergence_db: Option<f64>,
    /// Peak before any level change, full scale = 1.
    pub peak: f32,
    /// Level change applied to avoid clipping, dB (0 or negative).
    pub gain_db: f32,
    /// Things the user should know (an inaudible render).
    pub warnings: Vec<resound_core::Warning>,
    /// Notes (the render turned down).
    pub notes: Vec<String>,
}

impl std::fmt::Display for ResynthInfo {
    /// Length, and the distance to the reference when there is one.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:.3} s", self.duration_s)?;
        if let Some(sc) = self.spectral_convergence_db {
            write!(f, ", spectral convergence {sc:.2} dB against the reference")?;
        }
        Ok(())
    }
}

/// Rebuilds recording `spec` of `d` as [`resynthesize_recording`] does, compares it with the
/// `reference` recording when given (read at the dictionary's rate), levels it for a file and
/// resamples it to `out_rate_hz` (the dictionary keeps its recordings' rate; files are written
/// at one rate, [`resound_core::limits::DEFAULT_SAMPLE_RATE_HZ`] unless asked otherwise).
///
/// # Errors
/// As [`resynthesize_recording`]; an unreadable reference; non-finite samples.
pub fn resynthesize_for_file(
    d: &Dictionary,
    spec: &str,
    params: &ResynthParams,
    reference: Option<&Path>,
    out_rate_hz: u32,
) -> Result<Resynthesis> {
    if !resound_core::limits::sample_rate_ok(f64::from(out_rate_hz)) {
        return Err(invalid(resound_core::limits::sample_rate_message(
            f64::from(out_rate_hz),
        )));
    }
    let mut samples = resynthesize_recording(d, spec, params)?;
    let spectral_convergence_db = match reference {
        Some(r) => {
            let (o, _, _) = load_recordings(
                &[r.to_string_lossy().into_owned()],
                KindRule::Fixed(Contact::Impact),
                Some(d.sample_rate_hz as u32),
            )?;
            Some(spectral_convergence_db(
                &o[0].samples,
                &samples,
                d.sample_rate_hz,
            ))
        }
        None => None,
    };
    let from_hz = d.sample_rate_hz.round() as u32;
    if from_hz != out_rate_hz {
        let x: Vec<f64> = samples.iter().map(|&v| f64::from(v)).collect();
        samples = resound_signal::resample::resample(&x, from_hz, out_rate_hz)
            .map_err(invalid)?
            .iter()
            .map(|&v| v as f32)
            .collect();
    }
    let level = resound_synth::render::normalize(&mut samples, resound_synth::render::CEILING)?;
    let info = ResynthInfo {
        sample_rate_hz: f64::from(out_rate_hz),
        duration_s: samples.len() as f64 / f64::from(out_rate_hz),
        spectral_convergence_db,
        peak: level.peak_before,
        gain_db: level.gain_db,
        warnings: level.quiet_warning().into_iter().collect(),
        notes: level.note().into_iter().collect(),
    };
    Ok(Resynthesis { samples, info })
}

/// What [`analyze_to_file`] made.
#[derive(Clone, Debug, Serialize)]
pub struct DictionaryFile {
    /// The saved dictionary's figures (rebuilt from the saved 16-bit grains).
    #[serde(flatten)]
    pub summary: DictionarySummary,
    /// Size of the file, bytes.
    pub file_bytes: u64,
    /// What the analysis did.
    pub analysis: resound_grains::AnalyzeInfo,
}

impl std::fmt::Display for DictionaryFile {
    /// The dictionary's grains, size and compression, then each recording's rebuild quality.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.summary;
        write!(
            f,
            "{} grains: {} impulsive, {} sinusoidal, {} transient; {} bytes, compression {:.2}:1",
            s.grains, s.impulsive, s.sinusoidal, s.transient, self.file_bytes, s.compression_ratio
        )?;
        for r in &s.recordings {
            write!(
                f,
                "\n  {:<28} {:<10} {:>6.2} s {:>5} grains, rebuild {:>6.1} dB",
                r.name,
                r.contact.name(),
                r.duration_s,
                r.grains,
                r.spectral_convergence_db.unwrap_or(f64::NAN)
            )?;
        }
        Ok(())
    }
}

/// Cuts `recordings` into grains and patterns, prunes them at correlation `prune` when given,
/// saves the dictionary to `output`, and measures each rebuild from what was saved.
///
/// # Errors
/// Unreadable recordings, a failed analysis, `prune` outside (0, 1), a failed write.
pub fn analyze_to_file(
    recordings: &[Recording],
    sample_rate_hz: f64,
    params: &resound_grains::AnalyzeParams,
    prune: Option<f64>,
    output: &Path,
    progress: resound_core::progress::ProgressFn<'_>,
) -> Result<DictionaryFile> {
    let (dict, analysis) = resound_grains::analyze(recordings, sample_rate_hz, params, progress)?;
    let dict = match prune {
        Some(c) if c > 0.0 && c < 1.0 => resound_grains::prune::prune(&dict, c),
        Some(c) => {
            return Err(invalid(format!(
                "the pruning threshold must be a correlation in (0, 1), got {c}"
            )))
        }
        None => dict,
    };
    let size = resound_io::grains_file::save(output, &dict)?;
    let saved = resound_io::grains_file::load(output)?;
    Ok(DictionaryFile {
        summary: summary(&saved, Some(recordings))?,
        file_bytes: size as u64,
        analysis,
    })
}
