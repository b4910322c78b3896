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
    /// How sure each mode is (parallel to `modes`): σ of f and d, the Cramér–Rao bound at the
    /// measured noise; `null` where it is singular.
    #[serde(default)]
    pub sigma: Vec<Option<resound_core::damped::ModeSigma>>,
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
            sigma: res.sigma.clone(),
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

/// The index behind a count from 1, as every front end numbers channels and strikes (1 is
/// the first: the left channel of a stereo file, the first strike of a file); `what` names the
/// setting (`channel`, `strike`).
///
/// # Errors
/// [`Error::Param`] for 0.
pub fn index_from_1(what: &'static str, k: Option<usize>) -> Result<Option<usize>> {
    match k {
        Some(0) => Err(Error::Param {
            field: what,
            message: format!("{what}s count from 1 (1 is the first), not 0"),
        }),
        k => Ok(k.map(|k| k - 1)),
    }
}

/// Which part of a file to take.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecordingParams {
    /// Channel index (0 is the first) instead of the mix of all channels; front ends count
    /// channels from 1 ([`index_from_1`]).
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
    // Every strike of every channel: the strikes are found once, on the mix, so strike K is
    // the same event in every channel (each channel finding its own would pair different hits).
    let mut params = params.clone();
    if select.every_strike && channels.len() > 1 && params.onsets_s.is_none() {
        let mix = RecordingParams {
            channel: None,
            ..*recording
        };
        let (samples, fs) = take_channel(&clip, &mix, path)?;
        let found = analyze(&samples, f64::from(fs), &params)
            .map_err(|e| Error::from(e).context(format!("cannot find the strikes of {name}")))?;
        params.onsets_s = Some(found.strikes_s);
    }
    let params = &params;
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

/// An analysed strike split for listening (the studio's A/B): what was recorded, what its
/// modes make, and what they miss — each the analysed length from the onset, full scale = 1.
#[derive(Clone, Debug, PartialEq)]
pub struct Resynthesis {
    /// The analysed segment (conditioned as the modes were fitted to it).
    pub recording: Vec<f64>,
    /// The modes, resynthesized.
    pub modes: Vec<f64>,
    /// The recording minus the modes.
    pub residual: Vec<f64>,
}

/// Splits an analysis into its [`Resynthesis`] parts.
pub fn resynthesis(res: &Analysis) -> Resynthesis {
    let recording = res.segment.clone();
    let modes = resound_core::damped::synthesize(&res.modes, res.sample_rate_hz, recording.len());
    let residual = recording.iter().zip(&modes).map(|(x, m)| x - m).collect();
    Resynthesis {
        recording,
        modes,
        residual,
    }
}

/// Peak of a single mode played alone ([`one_mode`]): −6 dBFS.
pub const ONE_MODE_PEAK: f64 = 0.5;

/// Mode `k` (counting from 1, by frequency) of an analysis alone, for listening: the analysed
/// length, normalized to [`ONE_MODE_PEAK`] (its level among the others is in the report).
///
/// # Errors
/// No mode `k`; a mode that is silent over the analysed length.
pub fn one_mode(res: &Analysis, k: usize) -> Result<Vec<f32>> {
    let m = k
        .checked_sub(1)
        .and_then(|i| res.modes.get(i))
        .ok_or_else(|| {
            invalid(format!(
                "no mode {k}: the analysis has {} (counting from 1)",
                res.modes.len()
            ))
        })?;
    let x = resound_core::damped::synthesize(
        std::slice::from_ref(m),
        res.sample_rate_hz,
        res.samples.max(1),
    );
    let peak = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if !(peak > 0.0 && peak.is_finite()) {
        return Err(invalid(format!(
            "mode {k} is silent over the analysed length"
        )));
    }
    Ok(x.iter()
        .map(|v| (ONE_MODE_PEAK * v / peak) as f32)
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strike(modes: &[DampedMode], fs: f64) -> Vec<f64> {
        // 50 ms of silence with a little noise, then the strike.
        let mut x: Vec<f64> = (0..2400)
            .map(|i| 1e-5 * ((i * 7919 % 13) as f64 - 6.0))
            .collect();
        x.extend(resound_core::damped::synthesize(modes, fs, 48_000));
        x
    }

    #[test]
    fn the_resynthesis_parts_add_up_and_the_modes_explain_a_clean_strike() {
        let fs = 48_000.0;
        let truth = [
            DampedMode::new(440.0, 6.0, 0.3),
            DampedMode::new(1230.0, 15.0, 0.2),
            DampedMode::new(3100.0, 40.0, 0.1),
        ];
        let res = analyze_samples(&strike(&truth, fs), fs, &AnalyzeParams::default()).unwrap();
        let p = resynthesis(&res);
        assert_eq!(p.recording.len(), res.samples);
        assert_eq!(p.modes.len(), res.samples);
        for i in (0..res.samples).step_by(97) {
            assert!((p.recording[i] - p.modes[i] - p.residual[i]).abs() < 1e-12);
        }
        let e = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>();
        assert!(
            e(&p.residual) < 1e-3 * e(&p.recording),
            "residual {:.3e} of {:.3e}",
            e(&p.residual),
            e(&p.recording)
        );
    }

    #[test]
    fn one_mode_alone_is_that_mode_at_minus_6_dbfs() {
        let fs = 48_000.0;
        let truth = [
            DampedMode::new(440.0, 6.0, 0.3),
            DampedMode::new(1230.0, 15.0, 0.2),
        ];
        let res = analyze_samples(&strike(&truth, fs), fs, &AnalyzeParams::default()).unwrap();
        let x = one_mode(&res, 2).unwrap();
        let peak = x.iter().fold(0.0f32, |a, v| a.max(v.abs()));
        assert!((f64::from(peak) - ONE_MODE_PEAK).abs() < 1e-6);
        // Its pitch: zero crossings over the first 0.5 s.
        let n = 24_000.min(x.len());
        let crossings = x[..n]
            .windows(2)
            .filter(|w| w[0] <= 0.0 && w[1] > 0.0)
            .count();
        let f = crossings as f64 / (n as f64 / fs);
        assert!((f - 1230.0).abs() < 5.0, "{f} Hz");
        assert!(one_mode(&res, 0).is_err());
        assert!(one_mode(&res, res.modes.len() + 1).is_err());
    }
}
