//! Resound recording analysis: find the damped sinusoids of a recorded impact.
//!
//! Numeric only, no file I/O (decoding lives in `resound-io`). Signals are `f64` slices with a
//! sample rate in Hz; time 0 is the strike onset. Modes follow [`resound_core::DampedMode`]:
//! `s(t) = Σ a e^(−d t) sin(2π f t + θ)`.
//!
//! ```
//! use resound_core::{damped::synthesize, DampedMode};
//! use resound_signal::{analyze, AnalyzeParams};
//! let truth = DampedMode { freq_hz: 440.0, damping_per_s: 5.0, amplitude: 0.5, phase_rad: 0.0 };
//! let x = synthesize(&[truth], 44100.0, 22050);
//! let found = analyze(&x, 44100.0, &AnalyzeParams::default()).unwrap();
//! assert!((found.modes[0].freq_hz - 440.0).abs() < 1e-6);
//! ```
#![warn(missing_docs)]

pub mod analyze;
pub mod compare;
pub mod condition;
pub mod crb;
pub mod extract;
pub mod filter;
pub mod joint;
pub mod onset;
pub mod psycho;
pub mod refine;
pub mod resample;
pub mod sine_stft;
pub mod stft;
pub mod subspace;

/// Lowest frequency a mode may have, Hz (below the audible range).
pub const MIN_FREQ_HZ: f64 = 15.0;
/// Highest damping a mode may have, 1/s: faster decays (< 2.3 ms to −60 dB) are transients,
/// which the residual (not the modes) describes.
pub const MAX_DAMPING_PER_S: f64 = 3000.0;
/// Lowest damping a mode may have, 1/s.
pub const MIN_DAMPING_PER_S: f64 = 1e-3;

/// Whether `(f, d)` lies in the range the analysis reports.
pub fn plausible(freq_hz: f64, damping_per_s: f64, sample_rate_hz: f64) -> bool {
    freq_hz >= MIN_FREQ_HZ
        && freq_hz < 0.5 * sample_rate_hz
        && (MIN_DAMPING_PER_S..=MAX_DAMPING_PER_S).contains(&damping_per_s)
}

/// Time over which [`mode_level`] averages, s: about the integration time of loudness.
pub const LEVEL_WINDOW_S: f64 = 0.25;

/// A mode's level: its RMS amplitude over the first `window_s` seconds,
/// `a · √((1 − e^(−2dT)) / (2dT))`, times √2 so that an undamped mode's level is its amplitude.
/// Comparing modes by level (not by initial amplitude) keeps a quiet, long-ringing mode from
/// being judged against a loud click that is over in a millisecond.
pub fn mode_level(mode: &resound_core::DampedMode, window_s: f64) -> f64 {
    let x = 2.0 * mode.damping_per_s.max(0.0) * window_s;
    let share = if x < 1e-9 { 1.0 } else { -(-x).exp_m1() / x };
    mode.amplitude.abs() * share.sqrt()
}

pub use analyze::{analyze, Analysis, AnalyzeError, AnalyzeParams};
