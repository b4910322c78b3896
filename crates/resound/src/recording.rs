//! A recording from a file to its modes: decode, pick or mix channels, resample, analyse.
//!
//! The [`Analysis`] carries the very segment its modes were fitted to
//! ([`Analysis::segment`]); estimation, the residual and pictures use that, so every stage
//! sees the same samples.

use crate::error::{invalid, Error, Result};
use resound_core::progress::{Warning, WarningKind};
use resound_core::DampedMode;
use resound_io::load_audio;
use resound_signal::{analyze, Analysis, AnalyzeParams};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The figures of an analysis as `resound analyze --json` writes them (and `synth --modes`
/// reads them): the same document from the CLI and the Python package.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AnalysisReport {
    /// The analysed file (or `"<array>"`).
    pub file: String,
    /// The codec it was decoded with.
    pub codec: String,
    /// Sample rate, Hz.
    pub sample_rate: f64,
    /// Onset of the analysed strike, s.
    pub onset_s: f64,
    /// Onsets of every strike found, s.
    pub strikes_s: Vec<f64>,
    /// The strike analysed, counting from 1.
    pub strike: usize,
    /// Why that strike.
    pub strike_reason: String,
    /// What conditioning did.
    pub conditioning: ConditioningReport,
    /// Length analysed after the onset, s.
    pub analysed_s: f64,
    /// Residual noise (robust standard deviation), full scale = 1.
    pub noise_rms: f64,
    /// Samples in flat runs at the peak.
    pub clipped_samples: usize,
    /// Warnings (clipping, several strikes, …).
    pub warnings: Vec<resound_core::Warning>,
    /// Wall time of the analysis, s.
    pub elapsed_s: f64,
    /// The modes, by frequency; t = 0 at the onset.
    pub modes: Vec<DampedMode>,
}

/// What conditioning did, in an [`AnalysisReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ConditioningReport {
    /// DC offset removed.
    pub dc_offset: f64,
    /// High-pass corner, Hz (None: none).
    pub highpass_hz: Option<f64>,
    /// Why that high-pass.
    pub highpass_reason: String,
    /// Noise floor, dBFS.
    pub noise_floor_dbfs: f64,
    /// Where the noise was measured ("lead-in" or "tail").
    pub noise_from: String,
}

impl AnalysisReport {
    /// The report of `res`, an analysis of `file` decoded with `codec`.
    pub fn new(file: &str, codec: &str, res: &Analysis) -> Self {
        Self {
            file: file.to_string(),
            codec: codec.to_string(),
            sample_rate: res.sample_rate_hz,
            onset_s: res.onset_s,
            strikes_s: res.strikes_s.clone(),
            strike: res.strike + 1,
            strike_reason: res.strike_reason.clone(),
            conditioning: ConditioningReport {
                dc_offset: res.conditioning.dc_offset,
                highpass_hz: res.conditioning.highpass.hz(),
                highpass_reason: res.conditioning.highpass_reason.clone(),
                noise_floor_dbfs: res.conditioning.noise_floor_dbfs,
                noise_from: res.conditioning.noise_from.to_string(),
            },
            analysed_s: res.samples as f64 / res.sample_rate_hz,
            noise_rms: res.noise_rms,
            clipped_samples: res.clipped_samples,
            warnings: res.warnings.clone(),
            elapsed_s: res.total_s,
            modes: res.modes.clone(),
        }
    }
}

/// Analyses samples already in memory (full scale = 1) at `sample_rate_hz`; like
/// [`analyze_file`], finding no mode is an error.
///
/// # Errors
/// A rate outside 1 kHz–1 MHz, no samples, non-finite samples, a failed analysis, no modes.
pub fn analyze_samples(
    samples: &[f64],
    sample_rate_hz: f64,
    params: &AnalyzeParams,
) -> Result<Analysis> {
    if !resound_core::limits::sample_rate_ok(sample_rate_hz) {
        return Err(invalid(resound_core::limits::sample_rate_message(
            sample_rate_hz,
        )));
    }
    if samples.is_empty() {
        return Err(invalid("no samples"));
    }
    if let Some(i) = samples.iter().position(|x| !x.is_finite()) {
        return Err(invalid(format!("sample {i} is not finite")));
    }
    let res = analyze(samples, sample_rate_hz, params)?;
    if res.modes.is_empty() {
        return Err(invalid(format!(
            "no modes found above the noise and within {} dB of the strongest peak",
            params.min_db
        )));
    }
    Ok(res)
}

/// A decoded recording, one channel (or the mix), f64 at `sample_rate_hz`.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Samples, full scale = 1.
    pub samples: Vec<f64>,
    /// Sample rate, Hz.
    pub sample_rate_hz: u32,
    /// The codec the file was decoded with.
    pub codec: String,
}

/// Which part of a file to take.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecordingParams {
    /// Channel K (0-based) instead of the mix of all channels.
    pub channel: Option<usize>,
    /// Resample to this rate first (rubato), Hz.
    pub resample_hz: Option<u32>,
}

/// Decodes `path` (WAV, FLAC, OGG Vorbis, MP3).
///
/// # Errors
/// Unreadable, truncated or corrupt files; a channel that does not exist; a resampling rate
/// outside 8–192 kHz.
pub fn load_recording(path: &Path, params: &RecordingParams) -> Result<Recording> {
    let clip = load_audio(path)?;
    let (samples, sample_rate_hz) = take_channel(&clip, params, path)?;
    Ok(Recording {
        samples,
        sample_rate_hz,
        codec: clip.codec,
    })
}

/// One channel (or the mix) of a decoded clip, resampled when asked: samples and rate.
fn take_channel(
    clip: &resound_io::AudioClip,
    params: &RecordingParams,
    path: &Path,
) -> Result<(Vec<f64>, u32)> {
    let mut samples = clip.mono(params.channel, path)?;
    let mut fs = clip.sample_rate_hz;
    if let Some(to) = params.resample_hz {
        if !(8000..=192_000).contains(&to) {
            return Err(invalid(format!(
                "resampling rate {to} Hz is outside 8000–192000 Hz"
            )));
        }
        samples = resound_signal::resample::resample(&samples, fs, to)
            .map_err(|e| invalid(e).at(path))?;
        fs = to;
    }
    Ok((samples, fs))
}

/// Decodes and analyses `path`: the recording and its modes. An analysis that finds no mode is
/// an error (with a hint when the file holds several strikes).
///
/// # Errors
/// As [`load_recording`] and [`analyze()`]; no modes found.
pub fn analyze_file(
    path: &Path,
    recording: &RecordingParams,
    params: &AnalyzeParams,
) -> Result<(Recording, Analysis)> {
    let rec = load_recording(path, recording)?;
    let res = analyze(&rec.samples, f64::from(rec.sample_rate_hz), params)
        .map_err(|e| Error::from(e).context(format!("cannot analyse {}", path.display())))?;
    if res.modes.is_empty() {
        let hint = if res.strikes_s.len() > 1 {
            format!(
                " (strike {} of {} lasts {:.0} ms; try another)",
                res.strike + 1,
                res.strikes_s.len(),
                1e3 * res.samples as f64 / res.sample_rate_hz
            )
        } else {
            String::new()
        };
        return Err(invalid(format!(
            "no modes found in {} above the noise and within {} dB of the strongest peak{hint}",
            path.display(),
            params.min_db
        )));
    }
    Ok((rec, res))
}

/// Which takes of a file [`analyze_takes`] makes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TakeSelection {
    /// Every strike the file holds, each a take (else the one `AnalyzeParams::strike` names, or
    /// the loudest clean one).
    pub every_strike: bool,
    /// Every channel, each a take (else `RecordingParams::channel`, or the mix).
    pub every_channel: bool,
}

/// One analysed take of a file.
#[derive(Clone, Debug)]
pub struct AnalysedTake {
    /// "file", "file strike K", "file channel C", … (strikes and channels count from 1).
    pub label: String,
    /// Its analysis.
    pub analysis: Analysis,
}

/// Decodes `path` and analyses the takes `select` names: every strike and/or every channel
/// as separate recordings of one material (for [`crate::material::estimate_material_from`]).
/// With `every_strike`, strikes that give no modes (cut short by the next, silent) are
/// skipped and named in the second list.
///
/// # Errors
/// As [`analyze_file`]; no usable take at all.
pub fn analyze_takes(
    path: &Path,
    recording: &RecordingParams,
    params: &AnalyzeParams,
    select: TakeSelection,
) -> Result<(Vec<AnalysedTake>, Vec<resound_core::Warning>)> {
    let clip = load_audio(path)?;
    let channels: Vec<Option<usize>> = if select.every_channel {
        (0..clip.channels.len()).map(Some).collect()
    } else {
        vec![recording.channel]
    };
    let name = path.display().to_string();
    let mut takes = Vec::new();
    let mut skipped = Vec::new();
    for ch in channels {
        let rp = RecordingParams {
            channel: ch,
            ..*recording
        };
        let (samples, fs) = take_channel(&clip, &rp, path)?;
        let ch_label = match (select.every_channel, ch) {
            (true, Some(c)) => format!(" channel {}", c + 1),
            _ => String::new(),
        };
        let run = |p: &AnalyzeParams| {
            analyze(&samples, f64::from(fs), p)
                .map_err(|e| Error::from(e).context(format!("cannot analyse {name}{ch_label}")))
        };
        let first = run(params)?;
        if !select.every_strike {
            if first.modes.is_empty() {
                return Err(invalid(format!(
                    "no modes found in {name}{ch_label} above the noise and within {} dB of the strongest peak",
                    params.min_db
                )));
            }
            takes.push(AnalysedTake {
                label: format!("{name}{ch_label}"),
                analysis: first,
            });
            continue;
        }
        for k in 0..first.strikes_s.len() {
            let label = format!("{name}{ch_label} strike {}", k + 1);
            let a = if k == first.strike {
                Ok(first.clone())
            } else {
                run(&AnalyzeParams {
                    strike: Some(k),
                    ..params.clone()
                })
            };
            match a {
                Ok(a) if !a.modes.is_empty() => takes.push(AnalysedTake { label, analysis: a }),
                Ok(_) => skipped.push(Warning::new(
                    WarningKind::Input,
                    format!("{label}: no modes"),
                )),
                Err(e) => skipped.push(Warning::new(WarningKind::Input, format!("{label}: {e}"))),
            }
        }
    }
    if takes.is_empty() {
        return Err(invalid(format!(
            "no strike of {name} gives modes to estimate from ({})",
            skipped
                .iter()
                .map(|w| w.message.as_str())
                .collect::<Vec<_>>()
                .join("; ")
        )));
    }
    Ok((takes, skipped))
}

/// The log-mel distance ([`resound_signal::compare`]) between two recordings: `b` is
/// resampled to `a`'s rate when they differ; `channel_a`/`channel_b` pick a channel (else the
/// mix).
///
/// # Errors
/// A compared length of 50 ms or less, a floor outside (0, 200] dB; as [`load_recording`]
/// and [`resound_signal::compare::log_mel_distance`].
pub fn compare_files(
    a: &Path,
    channel_a: Option<usize>,
    b: &Path,
    channel_b: Option<usize>,
    params: &resound_signal::compare::LogMelParams,
) -> Result<resound_signal::compare::LogMelDistance> {
    if !(params.max_duration_s > 0.05 && params.max_duration_s.is_finite()) {
        return Err(Error::Param {
            field: "max_duration_s",
            message: format!(
                "the compared length must be above 0.05 s, got {} s",
                params.max_duration_s
            ),
        });
    }
    if !(params.floor_db > 0.0 && params.floor_db <= 200.0) {
        return Err(Error::Param {
            field: "floor_db",
            message: format!("the floor must be in (0, 200] dB, got {}", params.floor_db),
        });
    }
    let ra = load_recording(
        a,
        &RecordingParams {
            channel: channel_a,
            resample_hz: None,
        },
    )?;
    let rb = load_recording(
        b,
        &RecordingParams {
            channel: channel_b,
            resample_hz: Some(ra.sample_rate_hz),
        },
    )?;
    resound_signal::compare::log_mel_distance(
        &ra.samples,
        &rb.samples,
        f64::from(ra.sample_rate_hz),
        params,
    )
    .map_err(|e| {
        invalid(format!(
            "cannot compare {} with {}: {e}",
            a.display(),
            b.display()
        ))
    })
}
