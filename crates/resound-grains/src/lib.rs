//! Grain-based retargeting of recordings (Picard, Tsingos & Faure 2009): sound for what modes
//! do not describe — breaking, crumbling, rattling, a recorded roll — made from the recordings
//! themselves.
//!
//! Numeric only, no file I/O (the `.grains` file lives in `resound-io`). Audio is `f32`.
//!
//! **Analysis** ([`analyze`]):
//! 1. Recordings of continuous contact (rolling, sliding) are split into a *sinusoidal* and a
//!    *transient* part ([`sms::split`]: SMS peak tracking; stable tracks are taken out of the STFT
//!    and the rest is the transient part, so the two parts sum to the recording exactly).
//!    Impulsive recordings are used whole.
//! 2. Each part is cut into grains at the rising inflection points of its spectral flux
//!    ([`segment`]), 7–70 ms long (Picard's 300–3000 samples at 44.1 kHz), windowed by a Tukey
//!    window (r = 0.02) whose tapers are shared with the neighbours — the overlap-add of a
//!    recording's own grains is the recording. Grains more than `min_db` below the loudest grain
//!    of their recording (either part) are dropped.
//! 3. Every part is correlated with every grain of the same kind (normalized cross-correlation,
//!    FFT overlap-save, [`pattern`]); peaks are picked greedily and the `k` largest kept per part:
//!    its *correlation pattern*, each peak with the energy-matching gain of its grain there.
//!
//! **Synthesis**: [`resynth::resynthesize`] rebuilds a recording from its pattern (§4.1), also
//! time-scaled (§4.3) or varied (seeded); [`player::GrainPlayer`] retargets grains to contacts
//! (§4.2) in real time without allocating.

#![warn(missing_docs)]

pub mod pattern;
pub mod player;
pub mod prune;
pub mod quality;
pub mod resynth;
pub mod segment;
pub mod sms;
#[cfg(test)]
mod testing;

pub use resound_core::progress::{Progress, ProgressFn, Stage};
use serde::{Deserialize, Serialize};

/// Why grains cannot be made or used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GrainError {
    /// Unusable input audio.
    #[error("{0}")]
    Input(String),
    /// An absurd parameter.
    #[error("{0}")]
    Param(String),
    /// A dictionary that does not hold together.
    #[error("inconsistent grain dictionary: {0}")]
    Dictionary(String),
}

/// What part of which kind of recording a grain or pattern comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Part {
    /// A whole impulsive recording (impact, breaking).
    Impulsive,
    /// The steady sinusoidal part of a continuous-contact recording.
    Sinusoidal,
    /// The transient (residual) part of a continuous-contact recording.
    Transient,
}

/// The contact a recording captured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Contact {
    /// Impacts, hits, breaking: impulsive.
    Impact,
    /// Rolling.
    Rolling,
    /// Sliding, scraping.
    Sliding,
    /// Continuous contact of unknown kind (rolling and sliding mixed).
    Continuous,
}

impl Contact {
    /// Its name, as in files (serde's).
    pub fn name(self) -> &'static str {
        match self {
            Contact::Impact => "impact",
            Contact::Rolling => "rolling",
            Contact::Sliding => "sliding",
            Contact::Continuous => "continuous",
        }
    }

    /// Whether recordings of this contact are split into sinusoidal and transient parts.
    pub fn is_continuous(self) -> bool {
        self != Contact::Impact
    }

    /// The parts a recording of this contact is analysed into.
    pub fn parts(self) -> &'static [Part] {
        if self.is_continuous() {
            &[Part::Sinusoidal, Part::Transient]
        } else {
            &[Part::Impulsive]
        }
    }
}

/// Order of the parts (impulsive, sinusoidal, transient).
pub(crate) fn player_part_index(p: Part) -> usize {
    match p {
        Part::Impulsive => 0,
        Part::Sinusoidal => 1,
        Part::Transient => 2,
    }
}

/// One grain: windowed samples at the dictionary's rate and recorded level.
#[derive(Clone, Debug, PartialEq)]
pub struct Grain {
    /// Samples (Tukey-windowed).
    pub samples: Vec<f32>,
    /// Kind.
    pub part: Part,
    /// Index of the recording it was cut from.
    pub recording: u32,
    /// First sample in that recording's part.
    pub start: u32,
    /// Length of the rising taper, samples.
    pub fade_in: u32,
    /// Length of the falling taper, samples.
    pub fade_out: u32,
    /// Starts at an onset of its recording (impacts start here).
    pub onset: bool,
}

impl Grain {
    /// The grain's window at sample `n`: raised-cosine tapers, 1 in between.
    pub fn window(&self, n: usize) -> f64 {
        segment::taper(
            n,
            self.samples.len(),
            self.fade_in as usize,
            self.fade_out as usize,
        )
    }
}

/// One peak of a correlation pattern: grain `grain` matches the part at sample `time`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    /// Grain index in the dictionary.
    pub grain: u32,
    /// Sample of the part where the grain's first sample falls.
    pub time: u32,
    /// Normalized cross-correlation, −1…1.
    pub corr: f32,
    /// Gain that matches the grain's energy to the part's energy under its window there (signed
    /// like `corr`).
    pub gain: f32,
}

/// How one part of one recording is rebuilt from grains.
#[derive(Clone, Debug, PartialEq)]
pub struct Pattern {
    /// Recording index.
    pub recording: u32,
    /// Which part.
    pub part: Part,
    /// The part's length, samples.
    pub len: u32,
    /// Peaks in ascending time.
    pub peaks: Vec<Peak>,
}

/// A recording the dictionary was built from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordingInfo {
    /// Name (file stem).
    pub name: String,
    /// Contact it captured.
    pub contact: Contact,
    /// Length at the dictionary's rate, samples (mono).
    pub samples: u32,
}

/// Grains and correlation patterns of a set of recordings.
#[derive(Clone, Debug, PartialEq)]
pub struct Dictionary {
    /// Sample rate of every grain, Hz.
    pub sample_rate_hz: f64,
    /// The recordings.
    pub recordings: Vec<RecordingInfo>,
    /// The grains.
    pub grains: Vec<Grain>,
    /// One pattern per part of every recording.
    pub patterns: Vec<Pattern>,
}

/// Bytes per stored grain sample (16-bit PCM, as the original assets of Picard §5).
pub const GRAIN_SAMPLE_BYTES: usize = 2;
/// Bytes per stored pattern peak (grain u32, time u32, correlation f32, gain f32).
pub const PEAK_BYTES: usize = 16;

impl Dictionary {
    /// Checks indices, lengths and values.
    ///
    /// # Errors
    /// [`GrainError::Dictionary`] naming the first inconsistency.
    pub fn validate(&self) -> Result<(), GrainError> {
        let bad = |m: String| Err(GrainError::Dictionary(m));
        if !resound_core::limits::sample_rate_ok(self.sample_rate_hz) {
            return bad(format!("sample rate {} Hz", self.sample_rate_hz));
        }
        for (i, g) in self.grains.iter().enumerate() {
            if g.samples.is_empty() || g.samples.iter().any(|v| !v.is_finite()) {
                return bad(format!("grain {i} is empty or not finite"));
            }
            if g.recording as usize >= self.recordings.len() {
                return bad(format!("grain {i} names recording {}", g.recording));
            }
            if g.fade_in as usize + g.fade_out as usize > g.samples.len() {
                return bad(format!("grain {i}: tapers longer than the grain"));
            }
        }
        for (i, p) in self.patterns.iter().enumerate() {
            if p.recording as usize >= self.recordings.len() {
                return bad(format!("pattern {i} names recording {}", p.recording));
            }
            for k in &p.peaks {
                if k.grain as usize >= self.grains.len() {
                    return bad(format!("pattern {i} names grain {}", k.grain));
                }
                if k.time >= p.len.max(1) || !k.corr.is_finite() || !k.gain.is_finite() {
                    return bad(format!("pattern {i}: peak at {} out of range", k.time));
                }
            }
            if p.peaks.windows(2).any(|w| w[1].time < w[0].time) {
                return bad(format!("pattern {i}: peaks not in time order"));
            }
        }
        Ok(())
    }

    /// Grains of one part.
    pub fn grains_of(&self, part: Part) -> impl Iterator<Item = (usize, &Grain)> {
        self.grains
            .iter()
            .enumerate()
            .filter(move |(_, g)| g.part == part)
    }

    /// Median grain length (samples) of a part; of all grains when the part has none.
    pub fn median_len(&self, part: Part) -> usize {
        let mut l: Vec<usize> = self.grains_of(part).map(|(_, g)| g.samples.len()).collect();
        if l.is_empty() {
            l = self.grains.iter().map(|g| g.samples.len()).collect();
        }
        if l.is_empty() {
            return 0;
        }
        l.sort_unstable();
        l[l.len() / 2]
    }

    /// Bytes of the grains as 16-bit PCM.
    pub fn grain_bytes(&self) -> usize {
        self.grains.iter().map(|g| g.samples.len()).sum::<usize>() * GRAIN_SAMPLE_BYTES
    }

    /// Bytes of the patterns.
    pub fn pattern_bytes(&self) -> usize {
        self.patterns.iter().map(|p| p.peaks.len()).sum::<usize>() * PEAK_BYTES
    }

    /// Bytes of the recordings as mono 16-bit PCM at the dictionary's rate.
    pub fn original_bytes(&self) -> usize {
        self.recordings
            .iter()
            .map(|r| r.samples as usize)
            .sum::<usize>()
            * GRAIN_SAMPLE_BYTES
    }

    /// Patterns of a recording.
    pub fn patterns_of(&self, recording: usize) -> impl Iterator<Item = (usize, &Pattern)> {
        self.patterns
            .iter()
            .enumerate()
            .filter(move |(_, p)| p.recording as usize == recording)
    }
}

/// A recording to analyse: mono samples at the analysis rate.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Name.
    pub name: String,
    /// Contact it captured.
    pub contact: Contact,
    /// Samples.
    pub samples: Vec<f32>,
}

/// Analysis settings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalyzeParams {
    /// SMS split of continuous recordings.
    pub sms: sms::SmsParams,
    /// Grain segmentation.
    pub segment: segment::SegmentParams,
    /// Correlation patterns.
    pub pattern: pattern::PatternParams,
}

/// Figures of an analysis.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct AnalyzeInfo {
    /// Seconds splitting continuous recordings.
    pub sms_s: f64,
    /// Seconds cutting grains.
    pub grains_s: f64,
    /// Seconds correlating (patterns).
    pub patterns_s: f64,
    /// Grains cut before the energy threshold.
    pub grains_cut: usize,
    /// Grain–part pairs correlated.
    pub pairs: usize,
}

/// Builds a dictionary: split, cut grains, correlate. `progress` hears the stage ([`Stage::Splitting`],
/// [`Stage::Grains`], [`Stage::Patterns`]) and its fraction now and then.
///
/// # Errors
/// [`GrainError::Input`] for empty, silent or non-finite recordings; [`GrainError::Param`] for
/// absurd settings.
pub fn analyze(
    recordings: &[Recording],
    sample_rate_hz: f64,
    params: &AnalyzeParams,
    progress: ProgressFn<'_>,
) -> Result<(Dictionary, AnalyzeInfo), GrainError> {
    if !resound_core::limits::sample_rate_ok(sample_rate_hz) {
        return Err(GrainError::Param(
            resound_core::limits::sample_rate_message(sample_rate_hz),
        ));
    }
    if recordings.is_empty() {
        return Err(GrainError::Input("no recordings".into()));
    }
    params.segment.check()?;
    params.pattern.check()?;
    for r in recordings {
        if r.samples.is_empty() {
            return Err(GrainError::Input(format!(
                "recording '{}' is empty",
                r.name
            )));
        }
        if r.samples.iter().any(|v| !v.is_finite()) {
            return Err(GrainError::Input(format!(
                "recording '{}' has NaN or infinite samples",
                r.name
            )));
        }
        if r.samples.iter().all(|&v| v == 0.0) {
            return Err(GrainError::Input(format!(
                "recording '{}' is silent",
                r.name
            )));
        }
        if r.samples.len() > u32::MAX as usize / 2 {
            return Err(GrainError::Input(format!(
                "recording '{}' is too long",
                r.name
            )));
        }
    }
    let mut info = AnalyzeInfo::default();
    // 1. Parts.
    let t = std::time::Instant::now();
    let mut parts: Vec<(usize, Part, Vec<f32>)> = Vec::new();
    for (i, r) in recordings.iter().enumerate() {
        if r.contact.is_continuous() {
            let (s, tr) = sms::split(&r.samples, sample_rate_hz, &params.sms);
            parts.push((i, Part::Sinusoidal, s));
            parts.push((i, Part::Transient, tr));
        } else {
            parts.push((i, Part::Impulsive, r.samples.clone()));
        }
        progress(Progress::fraction(
            Stage::Splitting,
            (i + 1) as f64 / recordings.len() as f64,
        ));
    }
    info.sms_s = t.elapsed().as_secs_f64();
    // 2. Grains.
    let t = std::time::Instant::now();
    let mut grains = Vec::new();
    let cuts: Vec<Vec<segment::Cut>> = parts
        .iter()
        .map(|(_, _, x)| segment::cut(x, sample_rate_hz, &params.segment))
        .collect();
    // The energy threshold is relative to the loudest grain of the whole recording (both parts
    // of a continuous one): a faint sinusoidal part is not kept whole.
    let mut loudest = vec![0.0f64; recordings.len()];
    for ((rec, _, _), c) in parts.iter().zip(&cuts) {
        loudest[*rec] = c
            .iter()
            .map(segment::Cut::power)
            .fold(loudest[*rec], f64::max);
    }
    for (k, ((rec, part, _), c)) in parts.iter().zip(cuts).enumerate() {
        let cut = segment::threshold(c, loudest[*rec], params.segment.min_db);
        info.grains_cut += cut.total;
        grains.extend(cut.kept.into_iter().map(|g| Grain {
            samples: g.samples,
            part: *part,
            recording: *rec as u32,
            start: g.start as u32,
            fade_in: g.fade_in as u32,
            fade_out: g.fade_out as u32,
            onset: g.onset,
        }));
        progress(Progress::fraction(
            Stage::Grains,
            (k + 1) as f64 / parts.len() as f64,
        ));
    }
    info.grains_s = t.elapsed().as_secs_f64();
    // 3. Patterns.
    let t = std::time::Instant::now();
    let signals: Vec<pattern::Signal<'_>> = parts
        .iter()
        .map(|(rec, part, x)| pattern::Signal {
            samples: x,
            part: *part,
            recording: *rec as u32,
        })
        .collect();
    let (peaks, pairs) = pattern::patterns(&signals, &grains, &params.pattern, &|f| {
        progress(Progress::fraction(Stage::Patterns, f))
    });
    info.pairs = pairs;
    info.patterns_s = t.elapsed().as_secs_f64();
    let patterns = parts
        .iter()
        .zip(peaks)
        .map(|((rec, part, x), peaks)| Pattern {
            recording: *rec as u32,
            part: *part,
            len: x.len() as u32,
            peaks,
        })
        .collect();
    let dict = Dictionary {
        sample_rate_hz,
        recordings: recordings
            .iter()
            .map(|r| RecordingInfo {
                name: r.name.clone(),
                contact: r.contact,
                samples: r.samples.len() as u32,
            })
            .collect(),
        grains,
        patterns,
    };
    dict.validate()?;
    Ok((dict, info))
}

/// Classifies a recording as impulsive or continuous from its envelope: continuous when at
/// least 40 % of its 10 ms frames lie within 20 dB of its loudest frame (a sustained sound),
/// impulsive when its energy comes in short bursts.
pub fn guess_contact(x: &[f32], sample_rate_hz: f64) -> Contact {
    let frame = ((0.01 * sample_rate_hz) as usize).max(1);
    let levels: Vec<f64> = x
        .chunks(frame)
        .map(|c| c.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>() / c.len() as f64)
        .collect();
    let peak = levels.iter().copied().fold(0.0, f64::max);
    if !(peak > 0.0) {
        return Contact::Impact;
    }
    let sustained = levels.iter().filter(|&&l| l >= peak * 1e-2).count();
    if sustained as f64 >= 0.4 * levels.len() as f64 {
        Contact::Continuous
    } else {
        Contact::Impact
    }
}
