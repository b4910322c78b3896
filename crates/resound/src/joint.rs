//! Several takes of one object (files, channels, strikes) to one set of shared poles
//! ([`resound_signal::joint`]): what `resound analyze --joint` and Python's `analyze_joint` show.

use crate::error::{invalid, Result};
use crate::recording::{analyze_takes, RecordingParams, TakeSelection};
use resound_core::damped::ModeSigma;
use resound_core::progress::{Progress, ProgressFn, Stage, Warning, WarningKind};
use resound_signal::joint::{joint_fit, JointAnalysis, JointParams, JointTake};
use resound_signal::AnalyzeParams;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One take in a [`JointReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JointTakeReport {
    /// "file", "file channel C", "file strike K" (channels and strikes count from 1).
    pub label: String,
    /// Onset of the take's strike in its file, s.
    pub onset_s: f64,
    /// Length analysed, s.
    pub analysed_s: f64,
    /// The take's residual noise after the joint fit (robust standard deviation).
    pub noise_rms: f64,
    /// Modes the take's own analysis found.
    pub modes_alone: usize,
}

/// A take's own fit of a shared pole.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct OwnFit {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Damping, 1/s.
    pub damping_per_s: f64,
    /// Its Cramér–Rao bound in that take alone.
    pub sigma: Option<ModeSigma>,
}

/// One shared pole in a [`JointReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JointModeReport {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Damping, 1/s.
    pub damping_per_s: f64,
    /// What to believe: the larger of the joint bound and the takes' scatter over √takes.
    pub sigma: Option<ModeSigma>,
    /// The joint Cramér–Rao bound.
    pub crb: Option<ModeSigma>,
    /// Standard deviation of the takes' own fits.
    pub scatter: Option<ModeSigma>,
    /// How many takes hear the pole.
    pub heard_in: usize,
    /// RMS deviation of the takes' own fits from the pole, in their own σ.
    pub disagreement_sigmas: f64,
    /// The takes disagree beyond their σ.
    pub disagree: bool,
    /// Amplitude in each take (0 where not heard).
    pub amplitude: Vec<f64>,
    /// Phase at each take's onset, rad.
    pub phase_rad: Vec<f64>,
    /// Each take's own fit (null where the take does not hear the pole).
    pub own: Vec<Option<OwnFit>>,
}

/// The figures of a joint analysis as `resound analyze --joint --json` writes them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JointReport {
    /// Sample rate of every take, Hz.
    pub sample_rate: f64,
    /// The takes, in the order of the amplitude columns.
    pub takes: Vec<JointTakeReport>,
    /// The shared poles, by frequency.
    pub modes: Vec<JointModeReport>,
    /// Poles seeded from the takes' own analyses.
    pub seeds: usize,
    /// Skipped takes, the takes' own warnings, disagreeing poles.
    pub warnings: Vec<Warning>,
    /// Wall time, s.
    pub elapsed_s: f64,
}

impl JointReport {
    /// The modes of take `take` (shared f and d, its amplitude and phase) where it hears them
    /// (a non-zero amplitude).
    pub fn take_modes(&self, take: usize) -> Vec<resound_core::DampedMode> {
        self.modes
            .iter()
            .filter(|m| m.amplitude.get(take).is_some_and(|&a| a > 0.0))
            .map(|m| resound_core::DampedMode {
                freq_hz: m.freq_hz,
                damping_per_s: m.damping_per_s,
                amplitude: m.amplitude[take],
                phase_rad: m.phase_rad[take],
            })
            .collect()
    }
}

impl std::fmt::Display for JointReport {
    /// The takes, then one row per shared pole: f, d, σ, how many takes hear it and how far
    /// their own fits stray.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, t) in self.takes.iter().enumerate() {
            writeln!(
                f,
                "take {}: {} (onset {:.4} s, {:.3} s, noise {:.1} dBFS, {} modes alone)",
                i + 1,
                t.label,
                t.onset_s,
                t.analysed_s,
                20.0 * t.noise_rms.max(1e-12).log10(),
                t.modes_alone
            )?;
        }
        writeln!(
            f,
            "{} poles shared by {} takes ({} seeds, {:.2} s)",
            self.modes.len(),
            self.takes.len(),
            self.seeds,
            self.elapsed_s
        )?;
        writeln!(
            f,
            "{:>4} {:>12} {:>9} {:>12} {:>9} {:>6} {:>8} {:>9}",
            "#", "freq_hz", "±f_hz", "damping_1/s", "±d_1/s", "heard", "spread_σ", ""
        )?;
        let pm = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2e}"));
        for (i, m) in self.modes.iter().enumerate() {
            writeln!(
                f,
                "{:>4} {:>12.3} {:>9} {:>12.3} {:>9} {:>6} {:>8.1} {:>9}",
                i + 1,
                m.freq_hz,
                pm(m.sigma.map(|s| s.freq_hz)),
                m.damping_per_s,
                pm(m.sigma.map(|s| s.damping_per_s)),
                format!("{}/{}", m.heard_in, self.takes.len()),
                m.disagreement_sigmas,
                if m.disagree { "disagree" } else { "" }
            )?;
        }
        Ok(())
    }
}

/// Analyses every take `select` makes of every file in `paths` (all one object) and fits one
/// set of poles shared by all of them ([`resound_signal::joint::joint_fit`]).
///
/// # Errors
/// No files; as [`analyze_takes`]; takes at different sample rates (resample them to one);
/// the joint fit's errors.
pub fn analyze_joint<P: AsRef<Path>>(
    paths: &[P],
    recording: &RecordingParams,
    params: &AnalyzeParams,
    select: TakeSelection,
    joint: &JointParams,
    progress: ProgressFn<'_>,
) -> Result<(JointReport, JointAnalysis)> {
    let start = std::time::Instant::now();
    if paths.is_empty() {
        return Err(invalid("no recordings to analyse jointly"));
    }
    let mut takes = Vec::new();
    let mut warnings = Vec::new();
    for (i, path) in paths.iter().enumerate() {
        let path = path.as_ref();
        progress(
            Progress::fraction(Stage::Analyzing, i as f64 / paths.len() as f64)
                .with_label(path.display().to_string()),
        );
        let (t, skipped) = analyze_takes(path, recording, params, select)?;
        takes.extend(t);
        warnings.extend(skipped);
    }
    let fs = takes[0].analysis.sample_rate_hz;
    if let Some(t) = takes.iter().find(|t| t.analysis.sample_rate_hz != fs) {
        return Err(invalid(format!(
            "{} is at {} Hz and {} at {} Hz; joint takes need one rate (add --resample-hz {})",
            takes[0].label, fs, t.label, t.analysis.sample_rate_hz, fs
        )));
    }
    for t in &takes {
        for w in &t.analysis.warnings {
            warnings.push(Warning::new(w.kind, format!("{}: {}", t.label, w.message)));
        }
    }
    let inputs: Vec<JointTake> = takes
        .iter()
        .map(|t| JointTake {
            segment: &t.analysis.segment,
            noise_rms: t.analysis.noise_rms,
            modes: &t.analysis.modes,
        })
        .collect();
    progress(Progress::begin(Stage::Estimating).with_label("shared poles"));
    let res = joint_fit(&inputs, fs, joint)
        .map_err(|e| invalid(e.to_string()).context("cannot fit the takes jointly"))?;
    if res.modes.is_empty() {
        return Err(invalid(
            "the joint fit kept no pole: no take hears one above its noise",
        ));
    }
    if takes.len() == 1 {
        warnings.push(Warning::new(
            WarningKind::Input,
            "one take only: the poles are that take's (give several files, --every-channel or --every-strike)",
        ));
    }
    let flagged: Vec<String> = res
        .modes
        .iter()
        .filter(|m| m.disagree)
        .map(|m| format!("{:.1} Hz", m.freq_hz))
        .collect();
    if !flagged.is_empty() {
        warnings.push(Warning::new(
            WarningKind::Implausible,
            format!(
                "the takes disagree beyond their σ about {} of {} poles ({}): not one object, a pair fitted as one pole, or σ too small for this noise",
                flagged.len(),
                res.modes.len(),
                flagged.join(", ")
            ),
        ));
    }
    let loose: Vec<String> = res
        .modes
        .iter()
        .filter(|m| m.sigma.is_none_or(|s| s.damping_per_s >= m.damping_per_s))
        .map(|m| format!("{:.1} Hz", m.freq_hz))
        .collect();
    if !loose.is_empty() {
        warnings.push(Warning::new(
            WarningKind::Implausible,
            format!(
                "the damping of {} of {} poles is not determined (σ_d ≥ d: {}); longer takes, or takes where they ring alone, pin it",
                loose.len(),
                res.modes.len(),
                loose.join(", ")
            ),
        ));
    }
    let report = JointReport {
        sample_rate: fs,
        takes: takes
            .iter()
            .zip(&res.noise_rms)
            .map(|(t, &noise_rms)| JointTakeReport {
                label: t.label.clone(),
                onset_s: t.analysis.onset_s,
                analysed_s: t.analysis.samples as f64 / fs,
                noise_rms,
                modes_alone: t.analysis.modes.len(),
            })
            .collect(),
        modes: res
            .modes
            .iter()
            .map(|m| JointModeReport {
                freq_hz: m.freq_hz,
                damping_per_s: m.damping_per_s,
                sigma: m.sigma,
                crb: m.crb,
                scatter: m.scatter,
                heard_in: m.heard.iter().filter(|&&h| h).count(),
                disagreement_sigmas: m.disagreement_sigmas,
                disagree: m.disagree,
                amplitude: m
                    .amplitude
                    .iter()
                    .zip(&m.heard)
                    .map(|(&a, &h)| if h { a } else { 0.0 })
                    .collect(),
                phase_rad: m.phase_rad.clone(),
                own: m
                    .own
                    .iter()
                    .map(|o| {
                        o.map(|(mode, sigma)| OwnFit {
                            freq_hz: mode.freq_hz,
                            damping_per_s: mode.damping_per_s,
                            sigma,
                        })
                    })
                    .collect(),
            })
            .collect(),
        seeds: res.seeds,
        warnings,
        elapsed_s: start.elapsed().as_secs_f64(),
    };
    Ok((report, res))
}

/// Replaces the modes of several takes of one object (all at one rate) by the poles they
/// share ([`joint_fit`]): each take keeps its own amplitudes and phases at the shared f and d,
/// with the joint σ. Returns a note saying what was done, or why the takes were left alone
/// (one take, different rates, a failed fit).
pub fn share_poles(takes: &mut [crate::recording::AnalysedTake], joint: &JointParams) -> String {
    if takes.len() < 2 {
        return "one take: its own poles".into();
    }
    let fs = takes[0].analysis.sample_rate_hz;
    if takes.iter().any(|t| t.analysis.sample_rate_hz != fs) {
        return "the takes are at different rates: each keeps its own poles".into();
    }
    let inputs: Vec<JointTake> = takes
        .iter()
        .map(|t| JointTake {
            segment: &t.analysis.segment,
            noise_rms: t.analysis.noise_rms,
            modes: &t.analysis.modes,
        })
        .collect();
    let res = match joint_fit(&inputs, fs, joint) {
        Ok(r) => r,
        Err(e) => return format!("the joint fit failed ({e}): each take keeps its own poles"),
    };
    for (p, t) in takes.iter_mut().enumerate() {
        let heard: Vec<&resound_signal::joint::JointMode> =
            res.modes.iter().filter(|m| m.heard[p]).collect();
        // A take that hears no shared pole keeps its own modes (estimation needs some).
        if !heard.is_empty() {
            t.analysis.modes = res.take_modes(p);
            t.analysis.sigma = heard.iter().map(|m| m.sigma).collect();
        }
    }
    let flagged = res.modes.iter().filter(|m| m.disagree).count();
    format!(
        "the {} takes were fitted jointly: {} shared poles (f, d), each take with its own amplitudes; the takes disagree about {flagged}",
        takes.len(),
        res.modes.len()
    )
}
