//! The whole analysis of one recorded strike: checks, high-pass, onset, stage 1 (Ren §4
//! spectrogram extraction), stage 2 (time-domain least squares), pruning, and a second round on
//! the residual for modes the first round hid.

use crate::extract::{extract_modes, ExtractParams};
use crate::onset::scan;
use crate::refine::{refine_modes, RefineInfo, RefineParams, Seed};
use resound_core::progress::{Warning, WarningKind};
use resound_core::DampedMode;
use thiserror::Error;

/// Settings of [`analyze`].
#[derive(Clone, Debug)]
pub struct AnalyzeParams {
    /// Keep at most this many modes (the strongest by level).
    pub max_modes: usize,
    /// Drop modes more than this many dB below the strongest, by level ([`crate::mode_level`]:
    /// RMS amplitude over the first [`crate::LEVEL_WINDOW_S`]), from the result. Modes down to
    /// 15 dB further are still fitted, so that they do not bias the reported ones.
    pub min_db: f64,
    /// Zero-phase high-pass cut-off applied first (rooms add rumble below ~100 Hz). Without
    /// one, [`crate::condition`] chooses one from the rumble it measures (see `auto_highpass`).
    pub highpass_hz: Option<f64>,
    /// Let conditioning choose a high-pass when rumble is measured and `highpass_hz` is unset.
    pub auto_highpass: bool,
    /// Which strike to analyse when the recording holds several (0 = first); `None`: the
    /// strongest clean one (not clipped, not cut short by the next).
    pub strike: Option<usize>,
    /// Analyse at most this much audio after the onset, in seconds.
    pub max_duration_s: f64,
    /// Run the time-domain refinement (stage 2). Without it the result is Ren's stage 1 alone.
    pub refine: bool,
    /// Extraction rounds (the second finds modes hidden by stronger neighbours).
    pub rounds: usize,
    /// A mode must carry this much energy relative to the noise variance (Σ s² / σ²) to stay.
    pub min_energy_snr: f64,
    /// The strikes' onsets in seconds when they were found elsewhere — on the mix of every
    /// channel, so that strike K of each channel is the same event — instead of on this
    /// signal (each onset is still refined on this signal, by a few samples at most).
    pub onsets_s: Option<Vec<f64>>,
    /// Search the residual with sub-band ESPRIT ([`crate::subspace`]) for modes the spectrogram
    /// stage cannot see: fast decays, beating doublets, low modes.
    pub subspace: bool,
}

impl Default for AnalyzeParams {
    fn default() -> Self {
        Self {
            max_modes: 64,
            min_db: 60.0,
            highpass_hz: None,
            auto_highpass: true,
            strike: None,
            max_duration_s: 5.0,
            refine: true,
            rounds: 2,
            min_energy_snr: 40.0,
            onsets_s: None,
            subspace: true,
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
    /// Which strike was analysed (0-based).
    pub strike: usize,
    /// Why that strike (one line).
    pub strike_reason: String,
    /// What conditioning did (DC, high-pass, noise floor).
    pub conditioning: crate::condition::Conditioning,
    /// Modes sorted by frequency; t = 0 at the onset.
    pub modes: Vec<DampedMode>,
    /// How sure each mode is (parallel to `modes`): σ of f and d, the Cramér–Rao bound at
    /// `noise_rms` over the samples analysed ([`crate::crb::mode_sigmas`]); `None` where the
    /// bound is singular.
    pub sigma: Vec<Option<resound_core::damped::ModeSigma>>,
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
    /// Warnings (clipping, several strikes, undetermined damping).
    pub warnings: Vec<Warning>,
    /// Refinement statistics.
    pub refine: RefineInfo,
    /// Seconds spent in stage 1 (spectrogram extraction).
    pub extract_s: f64,
    /// Seconds for the whole analysis after the checks and the high-pass.
    pub total_s: f64,
}

impl std::fmt::Display for Analysis {
    /// What was analysed (the strike, conditioning, onset, noise) and the table of modes,
    /// with each one's level below the strongest.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = &self.conditioning;
        writeln!(
            f,
            "{}; offset {:+.5} removed; high-pass {}; noise floor {:.1} dBFS (from the {})",
            self.strike_reason, c.dc_offset, c.highpass_reason, c.noise_floor_dbfs, c.noise_from
        )?;
        writeln!(
            f,
            "onset {:.4} s, {:.3} s analysed at {} Hz, noise {:.1} dBFS, {} modes ({:.2} s)",
            self.onset_s,
            self.samples as f64 / self.sample_rate_hz,
            self.sample_rate_hz,
            20.0 * self.noise_rms.max(1e-12).log10(),
            self.modes.len(),
            self.total_s
        )?;
        writeln!(
            f,
            "{:>4} {:>12} {:>9} {:>12} {:>9} {:>10} {:>9} {:>8}",
            "#", "freq_hz", "±f_hz", "damping_1/s", "±d_1/s", "amplitude", "level_dB", "phase"
        )?;
        let strongest = self.modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
        for (i, m) in self.modes.iter().enumerate() {
            let sigma = self.sigma.get(i).copied().flatten();
            let pm = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2e}"));
            writeln!(
                f,
                "{:>4} {:>12.3} {:>9} {:>12.3} {:>9} {:>10.3e} {:>9.1} {:>8.3}",
                i + 1,
                m.freq_hz,
                pm(sigma.map(|s| s.freq_hz)),
                m.damping_per_s,
                pm(sigma.map(|s| s.damping_per_s)),
                m.amplitude,
                20.0 * (m.amplitude / strongest).log10(),
                m.phase_rad
            )?;
        }
        Ok(())
    }
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
    #[error("sample rate {0} Hz is outside the supported 8000–192000 Hz; resample it first (to 48000 Hz, say)")]
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

/// Decays faster than this (under 4.6 ms to −60 dB) are the strike's transient — the contact
/// click, not a mode of the object: they stay in the residual, out of the modes that drive
/// estimation.
pub const TRANSIENT_DAMPING_PER_S: f64 = 1500.0;

/// Modes are extracted and fitted this many dB further under the strongest than
/// [`AnalyzeParams::min_db`] reports. On `bench analyze --wide` at 100 dB SNR (30 cases), 15 dB
/// took the median frequency error from 1.8 to 1.0 CRB at 1.4× the time; 40 dB gained nothing
/// more at 2× it.
const FIT_MARGIN_DB: f64 = 15.0;

/// Moves an onset the envelope scan put early to the first sample that stands 5 σ above the
/// lead-in's noise (and within 40 dB of the peak), searching from 20 ms before it (never before the previous strike) to 5 ms
/// after it. A model that starts before the strike has to explain a stretch of silence with a
/// burst of fast decays; one that starts a few samples late only sees a phase shift. Without a
/// lead-in (the strike starts the file) the scan's onset stands.
fn refine_onset(
    x: &[f64],
    onset: usize,
    previous: usize,
    sample_rate_hz: f64,
    conditioning: &crate::condition::Conditioning,
) -> usize {
    // Later strikes sit on the tail of the one before: no lead-in noise to compare with.
    if conditioning.noise_from != "lead-in" || onset == 0 || previous > 0 {
        return onset;
    }
    let from = onset
        .saturating_sub((0.02 * sample_rate_hz) as usize)
        .max(previous);
    let to = (onset + (0.005 * sample_rate_hz) as usize).min(x.len());
    // The noise of this very signal, on the lead-in up to 5 ms before the strike.
    let quiet_end = from.max(onset.saturating_sub((0.005 * sample_rate_hz) as usize));
    let quiet = &x[previous..quiet_end.max(previous)];
    let sigma = if quiet.len() >= 64 {
        (quiet.iter().map(|v| v * v).sum::<f64>() / quiet.len() as f64).sqrt()
    } else {
        10f64.powf(conditioning.noise_floor_dbfs / 20.0)
    };
    let peak = x[from..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let threshold = (5.0 * sigma).max(1e-2 * peak);
    x[from..to]
        .iter()
        .position(|v| v.abs() > threshold)
        .map_or(onset, |i| from + i)
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
    if !resound_core::limits::sample_rate_ok(sample_rate_hz) {
        return Err(AnalyzeError::SampleRate(sample_rate_hz));
    }
    if !(params.min_db > 0.0 && params.min_db <= 200.0) {
        return Err(AnalyzeError::Param(format!(
            "min_db must be in (0, 200], got {}",
            params.min_db
        )));
    }
    if !(params.max_duration_s > 0.02 && params.max_duration_s <= 600.0) {
        return Err(AnalyzeError::Param(format!(
            "max_duration_s must be in (0.02, 600] s, got {}",
            params.max_duration_s
        )));
    }
    if params.max_modes == 0 || params.max_modes > 4096 {
        return Err(AnalyzeError::Param(format!(
            "max_modes must be in 1..=4096, got {}",
            params.max_modes
        )));
    }
    // Modes under the reported range are still fitted, as nuisance parameters: left in the
    // residual, a quiet but energetic mode (a fast decay 70 dB under a ringing one) biases
    // every mode around it by far more than their Cramér–Rao bound. They are dropped from the
    // result at the end.
    let report_min_db = params.min_db;
    let fit_params = AnalyzeParams {
        min_db: (params.min_db + FIT_MARGIN_DB).min(200.0),
        ..params.clone()
    };
    let params = &fit_params;
    if let Some(f) = params.highpass_hz {
        if !(f > 0.0 && f < 0.45 * sample_rate_hz) {
            return Err(AnalyzeError::Param(format!(
                "high-pass cut-off {f} Hz must be in (0, {:.0}) Hz",
                0.45 * sample_rate_hz
            )));
        }
    }
    // A constant signal (a DC offset and nothing else) has no strike; it is not "clipped".
    let (lo, hi) = signal
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if hi - lo <= 1e-7 {
        if hi.abs().max(lo.abs()) <= 1e-7 {
            return Err(AnalyzeError::Silent {
                peak_dbfs: 20.0 * hi.abs().max(lo.abs()).max(1e-300).log10(),
            });
        }
        return Err(AnalyzeError::Constant { value: signal[0] });
    }
    let mut x = signal.to_vec();
    // The lead-in is located on a copy high-passed at 100 Hz, so rumble cannot pass for a strike.
    let first_onset = |y: &[f64]| {
        // Centred first: an offset would make the filter ring at the file's first sample.
        let mut sorted = y.to_vec();
        let mid = sorted.len() / 2;
        let centre = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
        let mut c: Vec<f64> = y.iter().map(|v| v - centre).collect();
        crate::filter::highpass_causal(&mut c, 100.0_f64.min(0.2 * sample_rate_hz), sample_rate_hz);
        scan(&c, sample_rate_hz).onsets.first().copied()
    };
    let conditioning = crate::condition::condition(
        &mut x,
        sample_rate_hz,
        params.highpass_hz,
        params.auto_highpass,
        first_onset,
    );
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(peak > 1e-7) {
        return Err(AnalyzeError::Silent {
            peak_dbfs: 20.0 * peak.max(1e-300).log10(),
        });
    }
    // Onsets are found on a causally filtered copy (DC removed, the same cut-off): the
    // zero-phase filter's backward pass puts a little of each strike before it.
    let causal: Vec<f64> = {
        let mut c: Vec<f64> = signal.iter().map(|v| v - conditioning.dc_offset).collect();
        if let Some(f) = conditioning.highpass.hz() {
            crate::filter::highpass_causal(&mut c, f, sample_rate_hz);
        }
        c
    };
    let mut sc = scan(&causal, sample_rate_hz);
    if let Some(given) = &params.onsets_s {
        sc.onsets = given
            .iter()
            .filter(|t| t.is_finite() && **t >= 0.0)
            .map(|t| (t * sample_rate_hz).round() as usize)
            .filter(|&o| o < causal.len())
            .collect();
        sc.onsets.sort_unstable();
        sc.onsets.dedup();
    }
    let mut warnings = Vec::new();
    if sc.clipped_samples > 0 {
        warnings.push(Warning::new(WarningKind::Input, format!(
            "the audio looks clipped: {} samples sit in flat runs at the peak; amplitudes of strong modes will be low",
            sc.clipped_samples
        )));
    }
    if sc.onsets.is_empty() {
        return Err(AnalyzeError::Silent {
            peak_dbfs: 20.0 * peak.log10(),
        });
    }
    let (strike, strike_reason) = match params.strike {
        Some(k) => (k, format!("strike {} as asked", k + 1)),
        None => strongest_clean(&x, &sc.onsets, sample_rate_hz),
    };
    if sc.onsets.len() > 1 {
        warnings.push(Warning::new(
            WarningKind::Input,
            format!(
                "the audio holds {} strikes (at {}); analysing {strike_reason}",
                sc.onsets.len(),
                sc.onsets
                    .iter()
                    .map(|&o| format!("{:.3} s", o as f64 / sample_rate_hz))
                    .collect::<Vec<_>>()
                    .join(", "),
            ),
        ));
    }
    let Some(&onset) = sc.onsets.get(strike) else {
        return Err(AnalyzeError::NoSuchStrike {
            requested: strike,
            found: sc.onsets.len(),
        });
    };
    let previous = if strike > 0 {
        sc.onsets[strike - 1].max(1)
    } else {
        0
    };
    let onset = refine_onset(&causal, onset, previous, sample_rate_hz, &conditioning);
    let end = sc.onsets.get(strike + 1).copied().unwrap_or(x.len());
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
    // The residual's spread overstates the noise while modes are still missing from the
    // model; the lead-in measures it directly.
    let lead_in_rms = (conditioning.noise_from == "lead-in")
        .then(|| 10f64.powf(conditioning.noise_floor_dbfs / 20.0));
    let base = RefineParams {
        noise_rms: lead_in_rms,
        ..RefineParams::default()
    };
    if params.refine && !seeds.is_empty() {
        let mut refine = base.clone();
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
            ..base.clone()
        };
        refine_and_prune(seg, sample_rate_hz, &mut seeds, &refine, &mut info, params);
    }
    // The squared error of a mode set over the segment (a pass that does not lower it is undone).
    let rss = |seeds: &[Seed]| {
        let mut r = seg.to_vec();
        for s in seeds {
            add_mode(&s.mode, sample_rate_hz, -1.0, &mut r);
        }
        r.iter().map(|v| v * v).sum::<f64>()
    };
    if params.refine && params.subspace && !seeds.is_empty() {
        for _pass in 0..2 {
            let noise = lead_in_rms.map_or(info.noise_rms, |r| r.min(info.noise_rms));
            // A pass that does not fit the segment better is undone (a pole LM drove somewhere
            // unphysical must not cost the modes around it).
            let (kept, kept_info, kept_rss) = (seeds.clone(), info.clone(), rss(&seeds));
            let t1 = std::time::Instant::now();
            let added = subspace_pass(seg, sample_rate_hz, &mut seeds, noise, params);
            extract_s += t1.elapsed().as_secs_f64();
            if !added {
                break;
            }
            let refine = RefineParams {
                sweeps: 2,
                ..base.clone()
            };
            refine_and_prune(seg, sample_rate_hz, &mut seeds, &refine, &mut info, params);
            if crate::refine::merge_all_duplicates(&mut seeds, seg.len() as f64 / sample_rate_hz) {
                let once = RefineParams {
                    sweeps: 1,
                    ..base.clone()
                };
                refine_and_prune(seg, sample_rate_hz, &mut seeds, &once, &mut info, params);
            }
            if rss(&seeds) >= kept_rss {
                seeds = kept;
                info = kept_info;
                break;
            }
        }
    }
    if params.refine && params.subspace && !seeds.is_empty() {
        let noise = if conditioning.noise_from == "lead-in" {
            info.noise_rms
                .min(10f64.powf(conditioning.noise_floor_dbfs / 20.0))
        } else {
            info.noise_rms
        };
        let (kept, kept_info, kept_rss) = (seeds.clone(), info.clone(), rss(&seeds));
        if split_beating(seg, sample_rate_hz, &mut seeds, noise) {
            let once = RefineParams {
                sweeps: 1,
                ..base.clone()
            };
            refine_and_prune(seg, sample_rate_hz, &mut seeds, &once, &mut info, params);
            if rss(&seeds) >= kept_rss {
                seeds = kept;
                info = kept_info;
            }
        }
    }
    if params.refine && params.subspace && !seeds.is_empty() {
        // The passes above each end after one sweep against a residual that later passes
        // changed; two more sweeps and a prune at the final noise drop what no longer stands
        // above it (fewer spurious modes in `bench analyze --wide`, at about 10 % more time).
        // The result is kept by the Bayesian information
        // criterion: each mode fewer may raise the squared error by at most 4 ln N σ² (four
        // parameters), so a sweep that pushes real modes out of range (a plastic's fast
        // decays over the transient limit) is undone.
        let (kept, kept_info, kept_rss) = (seeds.clone(), info.clone(), rss(&seeds));
        let refine = RefineParams {
            sweeps: 2,
            ..base.clone()
        };
        refine_and_prune(seg, sample_rate_hz, &mut seeds, &refine, &mut info, params);
        let fewer = kept.len().saturating_sub(seeds.len()) as f64;
        let sigma = kept_info.noise_rms;
        let allowance = fewer * 4.0 * (seg.len() as f64).ln() * sigma * sigma;
        if !(rss(&seeds) <= kept_rss + allowance) {
            seeds = kept;
            info = kept_info;
        }
    }
    if params.refine && !seeds.is_empty() {
        // The passes above fit clusters one at a time against the others' residual; one
        // joint fit of every mode on the whole segment ends where all of them agree (close
        // low doublets converge slowly along their valley, hence the many iterations; each
        // costs O(N·k) and stops once the cost no longer falls).
        let mut modes: Vec<DampedMode> = seeds.iter().map(|s| s.mode).collect();
        crate::refine::levenberg_marquardt_bounded(seg, sample_rate_hz, &mut modes, 100);
        // Moving every mode at once can also draw two close poles into a pair that cancels
        // itself (an envelope, not two modes), which the pair rule of the clusters refuses:
        // then the joint fit is not taken (on the ramp recording, 9674 / 9678 Hz, d 89,
        // opposite phases, each 10 dB above their sum).
        let ok = modes.len() == seeds.len()
            && modes.iter().all(|m| {
                m.freq_hz.is_finite() && m.damping_per_s.is_finite() && m.amplitude.is_finite()
            })
            && crate::refine::close_pairs_credible(&modes, seg, info.noise_rms, sample_rate_hz);
        if ok {
            for (s, m) in seeds.iter_mut().zip(&modes) {
                s.mode = *m;
            }
            prune(
                &mut seeds,
                sample_rate_hz,
                seg.len(),
                info.noise_rms,
                params,
            );
        }
    }
    // Below the high-pass cut-off the filter's own response (its edge transients on rumble)
    // is what a pole fits there, not the object.
    // They are left out, and said so: a real low mode under a cut-off set too high is lost
    // with them, and the user is the one who can lower it.
    let cut_hz = conditioning.highpass.hz().unwrap_or(0.0);
    let (mut modes, below): (Vec<DampedMode>, Vec<DampedMode>) = seeds
        .iter()
        .map(|s| s.mode)
        .partition(|m| m.freq_hz >= cut_hz);
    if !below.is_empty() {
        let freqs: Vec<String> = below
            .iter()
            .map(|m| format!("{:.1} Hz", m.freq_hz))
            .collect();
        warnings.push(Warning::new(
            WarningKind::Input,
            format!(
                "{} mode(s) below the {:.0} Hz high-pass ({}) were left out: under the cut-off a fit follows the filter's response, not the object; lower the high-pass if the object sounds there",
                below.len(),
                cut_hz,
                freqs.join(", ")
            ),
        ));
    }
    let level = |m: &DampedMode| crate::mode_level(m, crate::LEVEL_WINDOW_S);
    let strongest = modes.iter().map(level).fold(0.0, f64::max);
    modes.retain(|m| level(m) >= strongest * 10f64.powf(-report_min_db / 20.0));
    modes.sort_by(|a, b| level(b).total_cmp(&level(a)));
    modes.truncate(params.max_modes);
    modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    // A mode that loses less than a tenth of its amplitude over the whole segment has no
    // measured damping: it rings past the file's end, or something keeps exciting it.
    let window_s = seg.len() as f64 / sample_rate_hz;
    let undetermined: Vec<String> = modes
        .iter()
        .filter(|m| m.damping_per_s * window_s < 0.1)
        .map(|m| format!("{:.0} Hz", m.freq_hz))
        .collect();
    if !undetermined.is_empty() {
        warnings.push(Warning::new(WarningKind::Implausible, format!(
            "{} mode(s) ({}) lose less than 10 % of their amplitude over the {:.2} s analysed: their damping is not determined (they ring past the end, or the excitation goes on, as in rolling)",
            undetermined.len(),
            undetermined.join(", "),
            window_s
        )));
    }
    Ok(Analysis {
        sample_rate_hz,
        onset_s,
        strikes_s: sc
            .onsets
            .iter()
            .map(|&o| o as f64 / sample_rate_hz)
            .collect(),
        strike,
        strike_reason,
        conditioning,
        sigma: {
            let fitted = resound_core::damped::synthesize(&modes, sample_rate_hz, seg.len());
            let residual: Vec<f64> = seg.iter().zip(&fitted).map(|(x, f)| x - f).collect();
            let noise = crate::crb::NoiseProfile::of_residual(&residual, sample_rate_hz);
            crate::crb::mode_sigmas(&modes, sample_rate_hz, seg.len(), &noise)
        },
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

/// One refinement of all seeds, then [`prune`]; the iterations and noise go into `info`.
fn refine_and_prune(
    seg: &[f64],
    sample_rate_hz: f64,
    seeds: &mut Vec<Seed>,
    refine: &RefineParams,
    info: &mut RefineInfo,
    params: &AnalyzeParams,
) {
    let (_, i) = refine_modes(seg, sample_rate_hz, seeds, refine);
    info.iterations += i.iterations;
    info.noise_rms = i.noise_rms;
    prune(seeds, sample_rate_hz, seg.len(), info.noise_rms, params);
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
    seeds.retain(|s| {
        let m = &s.mode;
        // A mode pinned at the damping cap did not converge to a physical decay.
        crate::plausible(m.freq_hz, m.damping_per_s, sample_rate_hz)
            && m.damping_per_s < TRANSIENT_DAMPING_PER_S
            // A fast decay at the top of the band is the strike's click.
            && !(m.freq_hz > 0.95 * nyquist && m.damping_per_s > 300.0)
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

/// The strike to analyse by default: the loudest (peak over its first 50 ms) among the clean
/// ones — not clipped and with at least 100 ms before the next strike; the loudest of all when
/// none is clean. Returns its index and the reason.
fn strongest_clean(x: &[f64], onsets: &[usize], sample_rate_hz: f64) -> (usize, String) {
    if onsets.len() <= 1 {
        return (0, "strike 1 (the only one)".to_string());
    }
    let w = (0.05 * sample_rate_hz) as usize;
    let gap = (0.1 * sample_rate_hz) as usize;
    let peak_of = |i: usize| {
        let a = onsets[i];
        let b = (a + w)
            .min(onsets.get(i + 1).copied().unwrap_or(x.len()))
            .min(x.len());
        x[a..b].iter().fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let global = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let clean = |i: usize| {
        let long = onsets
            .get(i + 1)
            .map_or(x.len() - onsets[i], |&n| n - onsets[i])
            >= gap;
        let a = onsets[i];
        let b = onsets.get(i + 1).copied().unwrap_or(x.len()).min(a + w);
        let flat = x[a..b]
            .windows(3)
            .filter(|s| s.iter().all(|v| v.abs() >= global * (1.0 - 1e-6)))
            .count();
        long && flat == 0
    };
    let pick = |cands: Vec<usize>| {
        cands
            .into_iter()
            .max_by(|&a, &b| peak_of(a).total_cmp(&peak_of(b)))
            .unwrap_or(0)
    };
    let clean_ones: Vec<usize> = (0..onsets.len()).filter(|&i| clean(i)).collect();
    if clean_ones.is_empty() {
        let k = pick((0..onsets.len()).collect());
        return (
            k,
            format!(
                "strike {} (the loudest; none of the {} is clean: each is clipped or cut short by the next within 100 ms)",
                k + 1,
                onsets.len()
            ),
        );
    }
    let k = pick(clean_ones.clone());
    (
        k,
        format!(
            "strike {} (the loudest of {} clean strikes, peak {:.1} dBFS; another can be chosen by its number)",
            k + 1,
            clean_ones.len(),
            20.0 * peak_of(k).max(1e-12).log10()
        ),
    )
}

/// Searches the residual of `seeds` with sub-band ESPRIT and adds the poles no seed explains
/// (with least-squares amplitudes). A seed straddled by two new poles within 1 % (a doublet
/// it had fitted as one mode) is replaced by them. Returns whether anything changed.
fn subspace_pass(
    seg: &[f64],
    sample_rate_hz: f64,
    seeds: &mut Vec<Seed>,
    noise_rms: f64,
    params: &AnalyzeParams,
) -> bool {
    use crate::subspace::{find_poles, SubspaceParams};
    let mut residual = seg.to_vec();
    for s in seeds.iter() {
        add_mode(&s.mode, sample_rate_hz, -1.0, &mut residual);
    }
    // The poles of the whole segment: each seed explains at most one (the nearest), so a seed
    // that had fitted a doublet as one mode leaves the pair's second pole unexplained.
    let poles = find_poles(
        seg,
        sample_rate_hz,
        noise_rms,
        &SubspaceParams::default(),
        (crate::MIN_DAMPING_PER_S, TRANSIENT_DAMPING_PER_S),
        // Below 20 Hz a new pole is more likely a filter's or resampler's edge than a mode.
        crate::MIN_FREQ_HZ.max(20.0),
    );
    let tol = |p: &crate::subspace::Pole, m: &DampedMode| {
        0.3 / p.window_s + 0.1 * (p.damping_per_s + m.damping_per_s) / std::f64::consts::PI
    };
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, p) in poles.iter().enumerate() {
        for (j, s) in seeds.iter().enumerate() {
            let e = (p.freq_hz - s.mode.freq_hz).abs();
            if e < tol(p, &s.mode) {
                pairs.push((e / tol(p, &s.mode), i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut pole_used = vec![false; poles.len()];
    let mut seed_used = vec![false; seeds.len()];
    for (_, i, j) in pairs {
        if !pole_used[i] && !seed_used[j] {
            pole_used[i] = true;
            seed_used[j] = true;
        }
    }
    let new: Vec<crate::subspace::Pole> = poles
        .into_iter()
        .zip(pole_used)
        .filter(|(_, used)| !used)
        .map(|(p, _)| p)
        .collect();
    if new.is_empty() {
        return false;
    }
    // Straddled seeds: one mode fitted to a doublet.
    seeds.retain(|s| {
        let f = s.mode.freq_hz;
        let below = new.iter().any(|p| p.freq_hz < f && p.freq_hz > f * 0.99);
        let above = new.iter().any(|p| p.freq_hz > f && p.freq_hz < f * 1.01);
        if below && above {
            add_mode(&s.mode, sample_rate_hz, 1.0, &mut residual);
            false
        } else {
            true
        }
    });
    let room = params
        .max_modes
        .saturating_sub(seeds.len())
        .max(new.len().min(8));
    let mut new = new;
    new.sort_by(|a, b| b.strength.total_cmp(&a.strength));
    new.truncate(room);
    new.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    for m in least_squares_amplitudes(&residual, sample_rate_hz, &new) {
        if m.amplitude > 0.0 && m.amplitude.is_finite() {
            let window_len = (new
                .iter()
                .find(|p| p.freq_hz == m.freq_hz)
                .map_or(0.05, |p| p.window_s)
                * sample_rate_hz) as usize;
            seeds.push(Seed {
                mode: m,
                window_len: (window_len / 2).max(128),
            });
        }
    }
    true
}

fn add_mode(mode: &DampedMode, sample_rate_hz: f64, scale: f64, out: &mut [f64]) {
    DampedMode {
        amplitude: scale * mode.amplitude,
        ..*mode
    }
    .add_to(sample_rate_hz, out);
}

/// Amplitudes and phases of `poles` on `x` by linear least squares, jointly within groups of
/// poles whose lines overlap.
fn least_squares_amplitudes(
    x: &[f64],
    sample_rate_hz: f64,
    poles: &[crate::subspace::Pole],
) -> Vec<DampedMode> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < poles.len() {
        let mut j = i + 1;
        while j < poles.len()
            && j - i < 6
            && poles[j].freq_hz - poles[j - 1].freq_hz
                < 5.0
                    * ((poles[j].damping_per_s + poles[j - 1].damping_per_s) / std::f64::consts::PI
                        + 1.0 / poles[j].window_s)
        {
            j += 1;
        }
        let group = &poles[i..j];
        let dmin = group
            .iter()
            .map(|p| p.damping_per_s)
            .fold(f64::INFINITY, f64::min);
        let len =
            ((7.0 / dmin.max(1e-3) * sample_rate_hz) as usize).clamp(64.min(x.len()), x.len());
        let k = 2 * group.len();
        let mut g = vec![0.0; k * k];
        let mut b = vec![0.0; k];
        let mut row = vec![0.0; k];
        for (n, &xn) in x[..len].iter().enumerate() {
            let t = n as f64 / sample_rate_hz;
            for (q, p) in group.iter().enumerate() {
                let e = (-p.damping_per_s * t).exp();
                let (s, c) = (std::f64::consts::TAU * p.freq_hz * t).sin_cos();
                row[2 * q] = e * s;
                row[2 * q + 1] = e * c;
            }
            for r in 0..k {
                b[r] += row[r] * xn;
                for c in 0..=r {
                    g[r * k + c] += row[r] * row[c];
                }
            }
        }
        for r in 0..k {
            for c in 0..r {
                g[c * k + r] = g[r * k + c];
            }
            g[r * k + r] *= 1.0 + 1e-9;
        }
        if let Some(sol) = crate::refine::cholesky_solve(&mut g, &b, k) {
            for (q, p) in group.iter().enumerate() {
                // u sin + v cos = A sin(ωt + θ) with A cos θ = u, A sin θ = v.
                let (u, v) = (sol[2 * q], sol[2 * q + 1]);
                out.push(DampedMode {
                    freq_hz: p.freq_hz,
                    damping_per_s: p.damping_per_s,
                    amplitude: u.hypot(v),
                    phase_rad: v.atan2(u),
                });
            }
        }
        i = j;
    }
    out
}

/// Beating pairs: a mode that is really two poles closer than the spectrogram resolves (a
/// degenerate pair split by asymmetry) is fitted first as one mode with a wrong damping, and
/// the residual near it stays louder than the noise. Each such mode (the strongest 24 whose
/// neighbourhood in the residual stands 1.5× above the noise, `crb::NoiseProfile`) is tried
/// as two poles, from three spacings (0.08, 0.4 and 1.2 over the window); the pair replaces
/// it when it lowers the squared error by more than the Bayesian information criterion asks
/// for four more parameters (4 ln N σ², σ the residual's level beside the mode — at the mode
/// its own misfit dominates it — and never below the broadband noise) and both members carry
/// at least a tenth of the pair's amplitude, their gap resolvable (`refine::resolvable_gap`).
/// Returns whether any mode was split.
fn split_beating(seg: &[f64], fs: f64, seeds: &mut Vec<Seed>, noise_rms: f64) -> bool {
    if seeds.is_empty() || !(noise_rms > 0.0) {
        return false;
    }
    let mut residual = seg.to_vec();
    for s in seeds.iter() {
        add_mode(&s.mode, fs, -1.0, &mut residual);
    }
    let profile = crate::crb::NoiseProfile::of_residual(&residual, fs);
    let level = |m: &DampedMode| crate::mode_level(m, crate::LEVEL_WINDOW_S);
    let mut order: Vec<usize> = (0..seeds.len()).collect();
    order.sort_by(|&a, &b| level(&seeds[b].mode).total_cmp(&level(&seeds[a].mode)));
    order.truncate(24);
    let mut pairs: Vec<(usize, [DampedMode; 2])> = Vec::new();
    for i in order {
        let m = seeds[i].mode;
        let local = profile.rms_at(m.freq_hz);
        if local < 1.5 * noise_rms {
            continue;
        }
        let len = seg.len();
        let n =
            ((m.time_to_floor_s(0.3 * noise_rms) * fs).ceil() as usize).clamp(len.min(256), len);
        let mut y = residual[..n].to_vec();
        add_mode(&m, fs, 1.0, &mut y);
        let c1: f64 = residual[..n].iter().map(|v| v * v).sum();
        let t = n as f64 / fs;
        let mut best: Option<(f64, [DampedMode; 2])> = None;
        for spacing in [0.08, 0.4, 1.2] {
            let delta = spacing / t;
            let half = DampedMode {
                amplitude: m.amplitude / std::f64::consts::SQRT_2,
                ..m
            };
            let mut pair = vec![
                DampedMode {
                    freq_hz: m.freq_hz - 0.5 * delta,
                    ..half
                },
                DampedMode {
                    freq_hz: m.freq_hz + 0.5 * delta,
                    ..half
                },
            ];
            crate::refine::levenberg_marquardt(&y, fs, &mut pair, 20);
            if pair.len() != 2 {
                continue;
            }
            let ok = pair.iter().all(|p| {
                crate::plausible(p.freq_hz, p.damping_per_s, fs)
                    && p.damping_per_s < TRANSIENT_DAMPING_PER_S
            }) && crate::refine::resolvable_gap(&pair[0], &pair[1], t, noise_rms, fs, n)
                && pair[0].amplitude.min(pair[1].amplitude)
                    > 0.1 * pair[0].amplitude.max(pair[1].amplitude);
            if !ok {
                continue;
            }
            let p = crate::refine::to_params(&pair);
            let c2 = crate::refine::cost(&y, &p, fs);
            if best.as_ref().is_none_or(|b| c2 < b.0) {
                best = Some((c2, [pair[0], pair[1]]));
            }
        }
        // The noise the criterion weighs against: the residual beside the mode (its own misfit
        // dominates the residual at it), never below the broadband noise.
        let side = 2.0 * (0.02 * m.freq_hz).max(25.0) + m.damping_per_s / std::f64::consts::PI;
        let beside = profile
            .rms_at(m.freq_hz - side)
            .min(profile.rms_at(m.freq_hz + side));
        let floor = beside.max(noise_rms).min(local);
        if let Some((c2, pair)) = best {
            if c1 - c2 > 4.0 * (n as f64).ln() * floor * floor {
                add_mode(&m, fs, 1.0, &mut residual);
                for p in &pair {
                    add_mode(p, fs, -1.0, &mut residual);
                }
                pairs.push((i, pair));
            }
        }
    }
    if pairs.is_empty() {
        return false;
    }
    for (i, pair) in pairs {
        let window_len = seeds[i].window_len;
        seeds[i].mode = pair[0];
        seeds.push(Seed {
            mode: pair[1],
            window_len,
        });
    }
    true
}
