//! The whole analysis of one recorded strike: checks, high-pass, onset, stage 1 (Ren §4
//! spectrogram extraction), stage 2 (time-domain least squares), pruning, and a second round on
//! the residual for modes the first round hid.

use crate::extract::{extract_modes, ExtractParams};
use crate::filter::highpass_zero_phase;
use crate::onset::scan;
use crate::refine::{refine_modes, RefineInfo, RefineParams, Seed};
use resound_core::DampedMode;
use thiserror::Error;

/// Settings of [`analyze`].
#[derive(Clone, Debug)]
pub struct AnalyzeParams {
    /// Keep at most this many modes (the strongest by level).
    pub max_modes: usize,
    /// Drop modes more than this many dB below the strongest, by level ([`crate::mode_level`]:
    /// RMS amplitude over the first [`crate::LEVEL_WINDOW_S`]).
    pub min_db: f64,
    /// Zero-phase high-pass cut-off applied first (rooms add rumble below ~100 Hz).
    pub highpass_hz: Option<f64>,
    /// Which strike to analyse when the recording holds several (0 = first).
    pub strike: usize,
    /// Analyse at most this much audio after the onset, in seconds.
    pub max_duration_s: f64,
    /// Run the time-domain refinement (stage 2). Without it the result is Ren's stage 1 alone.
    pub refine: bool,
    /// Extraction rounds (the second finds modes hidden by stronger neighbours).
    pub rounds: usize,
    /// A mode must carry this much energy relative to the noise variance (Σ s² / σ²) to stay.
    pub min_energy_snr: f64,
}

impl Default for AnalyzeParams {
    fn default() -> Self {
        Self {
            max_modes: 64,
            min_db: 60.0,
            highpass_hz: None,
            strike: 0,
            max_duration_s: 5.0,
            refine: true,
            rounds: 2,
            min_energy_snr: 40.0,
        }
    }
}

/// What [`analyze`] found.
#[derive(Clone, Debug)]
pub struct Analysis {
    /// Sample rate of the analysed signal in Hz.
    pub sample_rate_hz: f64,
    /// Onset of the analysed strike in seconds from the start of the signal.
    pub onset_s: f64,
    /// Onsets of all strikes found, seconds.
    pub strikes_s: Vec<f64>,
    /// Modes sorted by frequency; t = 0 at the onset.
    pub modes: Vec<DampedMode>,
    /// Standard deviation of the residual (robust), full scale = 1.
    pub noise_rms: f64,
    /// Samples analysed after the onset.
    pub samples: usize,
    /// The very samples the modes were fitted to (high-passed as a whole signal, then cut at
    /// the onset; `samples` long). Estimation, the residual and plots use these, never a
    /// re-cut of the input.
    pub segment: Vec<f64>,
    /// Samples in flat runs at the peak (clipping).
    pub clipped_samples: usize,
    /// Human-readable warnings (clipping, several strikes).
    pub warnings: Vec<String>,
    /// Refinement statistics.
    pub refine: RefineInfo,
    /// Seconds spent in stage 1 (spectrogram extraction).
    pub extract_s: f64,
    /// Seconds for the whole analysis after the checks and the high-pass.
    pub total_s: f64,
}

/// Why a signal cannot be analysed.
#[derive(Debug, Error, PartialEq)]
pub enum AnalyzeError {
    /// No samples.
    #[error("the audio is empty")]
    Empty,
    /// NaN or infinite samples.
    #[error("the audio holds a non-finite sample (NaN or infinity) at index {0}")]
    NonFinite(usize),
    /// Every sample holds the same value (a DC offset only).
    #[error("the audio is constant ({value:+.4} full scale: a DC offset and nothing else); there is no strike in it")]
    Constant {
        /// The value every sample holds.
        value: f64,
    },
    /// All zero or below −140 dBFS.
    #[error("the audio is silent (peak {peak_dbfs:.1} dBFS)")]
    Silent {
        /// Peak level.
        peak_dbfs: f64,
    },
    /// Less than 20 ms after the onset.
    #[error("only {available_ms:.1} ms of audio after the onset at {onset_s:.3} s; at least 20 ms are needed")]
    TooShort {
        /// Audio available after the onset, ms.
        available_ms: f64,
        /// Onset, s.
        onset_s: f64,
    },
    /// Sample rate outside 8–192 kHz.
    #[error("sample rate {0} Hz is outside the supported 8000–192000 Hz; resample it first (`--resample-hz 48000`)")]
    SampleRate(f64),
    /// `strike` beyond the strikes found.
    #[error("strike {} requested (counting from 1) but only {found} strike(s) found", requested + 1)]
    NoSuchStrike {
        /// Requested index (0-based; the message counts from 1).
        requested: usize,
        /// Strikes found.
        found: usize,
    },
    /// Bad parameter.
    #[error("invalid parameter: {0}")]
    Param(String),
}

/// Analyses the strike in `signal` (mono, full scale = 1).
pub fn analyze(
    signal: &[f64],
    sample_rate_hz: f64,
    params: &AnalyzeParams,
) -> Result<Analysis, AnalyzeError> {
    if signal.is_empty() {
        return Err(AnalyzeError::Empty);
    }
    if let Some(i) = signal.iter().position(|v| !v.is_finite()) {
        return Err(AnalyzeError::NonFinite(i));
    }
    if !(8000.0..=192_000.0).contains(&sample_rate_hz) {
        return Err(AnalyzeError::SampleRate(sample_rate_hz));
    }
    if !(params.min_db > 0.0 && params.min_db <= 200.0) {
        return Err(AnalyzeError::Param(format!(
            "min_db must be in (0, 200], got {}",
            params.min_db
        )));
    }
    if params.max_modes == 0 || params.max_modes > 4096 {
        return Err(AnalyzeError::Param(format!(
            "max_modes must be in 1..=4096, got {}",
            params.max_modes
        )));
    }
    if let Some(f) = params.highpass_hz {
        if !(f > 0.0 && f < 0.45 * sample_rate_hz) {
            return Err(AnalyzeError::Param(format!(
                "high-pass cut-off {f} Hz must be in (0, {:.0}) Hz",
                0.45 * sample_rate_hz
            )));
        }
    }
    let mut x = signal.to_vec();
    if let Some(f) = params.highpass_hz {
        highpass_zero_phase(&mut x, f, sample_rate_hz);
    }
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(peak > 1e-7) {
        return Err(AnalyzeError::Silent {
            peak_dbfs: 20.0 * peak.max(1e-300).log10(),
        });
    }
    // A constant signal (a DC offset and nothing else) has no strike; it is not "clipped".
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if hi - lo <= 1e-7 {
        return Err(AnalyzeError::Constant { value: x[0] });
    }
    let sc = scan(&x, sample_rate_hz);
    let mut warnings = Vec::new();
    if sc.clipped_samples > 0 {
        warnings.push(format!(
            "the audio looks clipped: {} samples sit in flat runs at the peak; amplitudes of strong modes will be low",
            sc.clipped_samples
        ));
    }
    if sc.onsets.is_empty() {
        return Err(AnalyzeError::Silent {
            peak_dbfs: 20.0 * peak.log10(),
        });
    }
    if sc.onsets.len() > 1 {
        warnings.push(format!(
            "the audio holds {} strikes (at {}); analysing strike {}",
            sc.onsets.len(),
            sc.onsets
                .iter()
                .map(|&o| format!("{:.3} s", o as f64 / sample_rate_hz))
                .collect::<Vec<_>>()
                .join(", "),
            params.strike + 1
        ));
    }
    let Some(&onset) = sc.onsets.get(params.strike) else {
        return Err(AnalyzeError::NoSuchStrike {
            requested: params.strike,
            found: sc.onsets.len(),
        });
    };
    let end = sc.onsets.get(params.strike + 1).copied().unwrap_or(x.len());
    let max_len = (params.max_duration_s * sample_rate_hz) as usize;
    let end = end.min(onset + max_len.max(1));
    let seg = &x[onset..end];
    let onset_s = onset as f64 / sample_rate_hz;
    if (seg.len() as f64) < 0.02 * sample_rate_hz {
        return Err(AnalyzeError::TooShort {
            available_ms: 1e3 * seg.len() as f64 / sample_rate_hz,
            onset_s,
        });
    }

    let extract = ExtractParams {
        max_modes: params.max_modes,
        min_db: params.min_db,
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let mut extract_s = 0.0;
    let mut seeds: Vec<Seed> = extract_modes(seg, sample_rate_hz, &extract, &[], None)
        .into_iter()
        .map(Seed::from)
        .collect();
    extract_s += t0.elapsed().as_secs_f64();
    let mut info = RefineInfo::default();
    if params.refine && !seeds.is_empty() {
        let mut refine = RefineParams::default();
        for round in 0..params.rounds.max(1) {
            if round > 0 {
                // Earlier modes are converged; one pass places the new ones among them.
                refine.sweeps = 1;
            }
            let (residual, i) = refine_modes(seg, sample_rate_hz, &mut seeds, &refine);
            info = i;
            prune(
                &mut seeds,
                sample_rate_hz,
                seg.len(),
                info.noise_rms,
                params,
            );
            if round + 1 == params.rounds.max(1) || seeds.len() >= params.max_modes {
                break;
            }
            let strongest = seeds
                .iter()
                .map(|s| crate::mode_level(&s.mode, crate::LEVEL_WINDOW_S))
                .fold(0.0, f64::max);
            let more = ExtractParams {
                max_modes: params.max_modes - seeds.len(),
                ..extract.clone()
            };
            let known: Vec<DampedMode> = seeds.iter().map(|s| s.mode).collect();
            let t1 = std::time::Instant::now();
            let new: Vec<Seed> =
                extract_modes(&residual, sample_rate_hz, &more, &known, Some(strongest))
                    .into_iter()
                    .map(Seed::from)
                    .collect();
            extract_s += t1.elapsed().as_secs_f64();
            if new.is_empty() {
                break;
            }
            seeds.extend(new);
        }
    }
    if params.refine
        && crate::refine::merge_all_duplicates(&mut seeds, seg.len() as f64 / sample_rate_hz)
    {
        let refine = RefineParams {
            sweeps: 1,
            ..RefineParams::default()
        };
        let (_, i) = refine_modes(seg, sample_rate_hz, &mut seeds, &refine);
        info.iterations += i.iterations;
        info.noise_rms = i.noise_rms;
        prune(
            &mut seeds,
            sample_rate_hz,
            seg.len(),
            info.noise_rms,
            params,
        );
    }
    let mut modes: Vec<DampedMode> = seeds.iter().map(|s| s.mode).collect();
    let level = |m: &DampedMode| crate::mode_level(m, crate::LEVEL_WINDOW_S);
    modes.sort_by(|a, b| level(b).total_cmp(&level(a)));
    modes.truncate(params.max_modes);
    modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    Ok(Analysis {
        sample_rate_hz,
        onset_s,
        strikes_s: sc
            .onsets
            .iter()
            .map(|&o| o as f64 / sample_rate_hz)
            .collect(),
        modes,
        noise_rms: info.noise_rms,
        samples: seg.len(),
        segment: seg.to_vec(),
        clipped_samples: sc.clipped_samples,
        warnings,
        refine: info,
        extract_s,
        total_s: t0.elapsed().as_secs_f64(),
    })
}

/// Drops modes that are unphysical, too weak relative to the strongest, or not significant
/// against the noise.
fn prune(
    seeds: &mut Vec<Seed>,
    sample_rate_hz: f64,
    samples: usize,
    noise_rms: f64,
    params: &AnalyzeParams,
) {
    let nyquist = 0.5 * sample_rate_hz;
    let _ = nyquist;
    seeds.retain(|s| {
        let m = &s.mode;
        // A mode pinned at the damping cap did not converge to a physical decay.
        crate::plausible(m.freq_hz, m.damping_per_s, sample_rate_hz)
            && m.damping_per_s < 0.99 * crate::MAX_DAMPING_PER_S
            && m.amplitude > 0.0
            && m.amplitude.is_finite()
    });
    let level = |m: &DampedMode| crate::mode_level(m, crate::LEVEL_WINDOW_S);
    let strongest = seeds.iter().map(|s| level(&s.mode)).fold(0.0, f64::max);
    let min_level = strongest * 10f64.powf(-params.min_db / 20.0);
    let var = noise_rms * noise_rms;
    seeds.retain(|s| {
        let m = &s.mode;
        // Σ_n a² e^{−2dn/fs} sin² ≈ a² fs (1 − e^{−2dT}) / (4d) over the window T.
        let t = samples as f64 / sample_rate_hz;
        let energy =
            m.amplitude * m.amplitude * sample_rate_hz * (-(-2.0 * m.damping_per_s * t).exp_m1())
                / (4.0 * m.damping_per_s);
        level(m) >= min_level && energy >= params.min_energy_snr * var
    });
}
