//! Conditioning of a raw recording before anything is analysed: DC offset, rumble, the noise
//! floor, and which strike to analyse.
//!
//! Real recordings start with room noise, sit on a DC offset, carry rumble below ~100 Hz and
//! may hold several strikes. Every step here is measured from the data and reported
//! ([`Conditioning`]), so a user sees what was done to their file and why.
//!
//! 1. **DC offset**: the mean of the lead-in, removed; without a lead-in, the median of the whole
//!    file (the centre of any oscillation), removed only above −60 dB re the peak (the median of
//!    a decaying oscillation is slightly off its centre).
//! 2. **Noise**: measured on the quiet part — the lead-in before the first strike when it is at
//!    least [`MIN_LEAD_IN_S`] long, else the file's last [`TAIL_SHARE`].
//! 3. **Rumble**: where the quiet part's spectral density below [`RUMBLE_MAX_HZ`] stands more
//!    than [`RUMBLE_EXCESS_DB`] above its density over 300 Hz–3 kHz, a zero-phase high-pass is
//!    chosen at 1.6× the frequency where the excess falls to 6 dB (at most
//!    [`MAX_RUMBLE_CUTOFF_HZ`]), but never above 0.7 × the
//!    lowest spectral peak the strike has there (its own low mode). A cut-off the user gives
//!    replaces the choice.

use crate::filter::highpass_zero_phase;
use realfft::RealFftPlanner;

/// Shortest lead-in the noise is measured on, s.
pub const MIN_LEAD_IN_S: f64 = 0.01;
/// Share of the file at its end used for the noise when there is no lead-in.
pub const TAIL_SHARE: f64 = 0.2;
/// Highest frequency rumble is looked for at, Hz.
pub const RUMBLE_MAX_HZ: f64 = 150.0;
/// Highest cut-off chosen for rumble, Hz.
pub const MAX_RUMBLE_CUTOFF_HZ: f64 = 200.0;
/// Excess of low-frequency noise density over the mid band that counts as rumble, dB.
pub const RUMBLE_EXCESS_DB: f64 = 10.0;

/// Where the high-pass cut-off came from.
#[derive(Clone, Debug, PartialEq)]
pub enum HighpassChoice {
    /// The user's cut-off.
    User(f64),
    /// Chosen from the rumble measured in the quiet part.
    Rumble(f64),
    /// None applied (no rumble found, or the user turned it off).
    None,
}

impl HighpassChoice {
    /// The cut-off, Hz.
    pub fn hz(&self) -> Option<f64> {
        match self {
            Self::User(f) | Self::Rumble(f) => Some(*f),
            Self::None => None,
        }
    }
}

/// What conditioning did.
#[derive(Clone, Debug)]
pub struct Conditioning {
    /// DC offset removed, full scale.
    pub dc_offset: f64,
    /// The high-pass applied.
    pub highpass: HighpassChoice,
    /// Why (one line for reports).
    pub highpass_reason: String,
    /// RMS of the quiet part after conditioning, dBFS.
    pub noise_floor_dbfs: f64,
    /// Which part the noise was measured on: `"lead-in"` or `"tail"`.
    pub noise_from: &'static str,
}

/// Conditions `x` in place. `first_onset` finds the sample of the first strike (for the
/// lead-in; it must not be misled by a DC offset); `user_highpass` is `Some(f)` to force a cut-off, and
/// `auto_highpass` allows the rumble-driven choice when the user gives none.
pub fn condition(
    x: &mut [f64],
    sample_rate_hz: f64,
    user_highpass: Option<f64>,
    auto_highpass: bool,
    first_onset: impl Fn(&[f64]) -> Option<usize>,
) -> Conditioning {
    let n = x.len();
    let onset = first_onset(x).unwrap_or(0);
    let lead_in = onset as f64 / sample_rate_hz >= MIN_LEAD_IN_S;
    // The quiet part: the lead-in up to 5 ms before the onset, else the tail.
    let quiet = if lead_in {
        0..onset.saturating_sub((0.005 * sample_rate_hz) as usize)
    } else {
        n - ((TAIL_SHARE * n as f64) as usize).max(1).min(n)..n
    };
    // The lead-in's mean is the offset itself; without one, the median of the file is the
    // centre of its oscillation.
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let dc = if lead_in {
        x[quiet.clone()].iter().sum::<f64>() / quiet.len().max(1) as f64
    } else {
        // The median of a decaying oscillation is not exactly its centre: below −60 dB re the
        // peak an offset is left alone (removing a biased estimate would do more harm).
        let m = median(x);
        if m.abs() > 1e-3 * peak {
            m
        } else {
            0.0
        }
    };
    for v in x.iter_mut() {
        *v -= dc;
    }
    let noise_from = if lead_in { "lead-in" } else { "tail" };
    let (highpass, highpass_reason) = match user_highpass {
        Some(f) => (HighpassChoice::User(f), format!("{f:.0} Hz as given")),
        None if !auto_highpass => (HighpassChoice::None, "turned off".to_string()),
        None => choose_highpass(x, sample_rate_hz, quiet.clone(), onset, noise_from),
    };
    if let Some(f) = highpass.hz() {
        highpass_zero_phase(x, f, sample_rate_hz);
    }
    let q = &x[quiet];
    let rms = (q.iter().map(|v| v * v).sum::<f64>() / q.len().max(1) as f64).sqrt();
    Conditioning {
        dc_offset: dc,
        highpass,
        highpass_reason,
        noise_floor_dbfs: 20.0 * rms.max(1e-12).log10(),
        noise_from,
    }
}

fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut v = x.to_vec();
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, f64::total_cmp);
    v[mid]
}

/// Welch power spectral density (Hann, 50 % overlap) of `x` with frames of `len` samples.
fn welch(x: &[f64], len: usize) -> Vec<f64> {
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(len);
    let w = crate::stft::hann(len);
    let mut acc = vec![0.0; len / 2 + 1];
    let mut buf = vec![0.0; len];
    let mut out = fft.make_output_vec();
    let mut frames = 0;
    let mut start = 0;
    while start + len <= x.len() {
        for i in 0..len {
            buf[i] = x[start + i] * w[i];
        }
        if fft.process(&mut buf, &mut out).is_ok() {
            for (a, c) in acc.iter_mut().zip(&out) {
                *a += c.norm_sqr();
            }
            frames += 1;
        }
        start += len / 2;
    }
    for a in acc.iter_mut() {
        *a /= frames.max(1) as f64;
    }
    acc
}

fn choose_highpass(
    x: &[f64],
    sample_rate_hz: f64,
    quiet: std::ops::Range<usize>,
    onset: usize,
    noise_from: &str,
) -> (HighpassChoice, String) {
    // Frames of ~85 ms (4096 at 48 kHz): 12 Hz bins, enough to see rumble's edge.
    let len = ((0.085 * sample_rate_hz) as usize).next_power_of_two();
    let q = &x[quiet];
    if q.len() < len {
        return (
            HighpassChoice::None,
            format!("none: the {noise_from} is too short to measure rumble on"),
        );
    }
    // A tail still ringing is no measure of rumble: its low bins hold the strike's own modes.
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let rms = (q.iter().map(|v| v * v).sum::<f64>() / q.len() as f64).sqrt();
    if noise_from == "tail" && rms > peak * 0.01 {
        return (
            HighpassChoice::None,
            format!(
                "none: the tail still rings ({:.0} dB below the peak), so rumble cannot be told from the strike's low modes; give a high-pass frequency",
                20.0 * (peak / rms.max(1e-300)).log10()
            ),
        );
    }
    let psd = welch(q, len);
    let df = sample_rate_hz / len as f64;
    let bin = |f: f64| ((f / df).round() as usize).min(psd.len() - 1);
    let mut mid: Vec<f64> = psd[bin(300.0)..=bin(3000.0)].to_vec();
    mid.sort_by(f64::total_cmp);
    let mid_level = mid[mid.len() / 2].max(1e-300);
    let excess_db = |k: usize| 10.0 * (psd[k] / mid_level).max(1e-30).log10();
    let low = bin(RUMBLE_MAX_HZ);
    let worst = (1..=low).map(excess_db).fold(f64::NEG_INFINITY, f64::max);
    // Rumble is broadband: most bins up to 100 Hz stand above the mid band. A low mode still
    // ringing in the tail raises a few bins only.
    let top = bin(100.0).max(2);
    let raised = (1..=top)
        .filter(|&k| excess_db(k) > RUMBLE_EXCESS_DB)
        .count();
    // Rumble is stationary: in the tail it must be about as strong as in the strike's first
    // frames (a strike's own low content, or its leakage, decays with it).
    if noise_from == "tail" && onset + 2 * len <= x.len() {
        let s = welch(&x[onset..onset + 2 * len], len);
        let band = |p: &[f64]| p[1..=top].iter().sum::<f64>();
        if band(&psd) < 0.3 * band(&s) {
            return (
                HighpassChoice::None,
                format!(
                    "none: the low band of the tail is {:.0} dB below the strike's (it decays with the strike: not rumble)",
                    10.0 * (band(&s) / band(&psd).max(1e-300)).log10()
                ),
            );
        }
    }
    if worst < RUMBLE_EXCESS_DB || 2 * raised < top {
        return (
            HighpassChoice::None,
            format!(
                "none: no rumble in the {noise_from} ({raised} of {top} bins below 100 Hz raised, at most {worst:+.0} dB re 300 Hz–3 kHz)"
            ),
        );
    }
    // The edge: the highest frequency below RUMBLE_MAX_HZ where the excess is still > 6 dB.
    let edge_bin = (1..=low).rev().find(|&k| excess_db(k) > 6.0).unwrap_or(1);
    // 1.6× the edge: the zero-phase 4th-order filter takes 28 dB off the rumble's top.
    let mut cutoff = (1.6 * (edge_bin as f64 + 1.0) * df).min(MAX_RUMBLE_CUTOFF_HZ);
    let mut capped = None;
    // The strike's own low modes: peaks of the strike's spectrum standing 10 dB above the
    // quiet part's density there, or 10 dB above the strike's own neighbouring bins.
    let strike_end = (onset + len * 8).min(x.len());
    let strike = &x[onset.min(x.len())..strike_end];
    if strike.len() >= len {
        let s = welch(strike, len);
        // Same frame length: the densities compare directly.
        let lowest_mode = (2..=bin(cutoff * 1.5).min(s.len() - 4))
            .find(|&k| {
                let peak = s[k] > s[k - 1] && s[k] >= s[k + 1];
                let side = s[k - 2].max(s[k + 3]).max(s[k.saturating_sub(3).max(1)]);
                peak && (s[k] > 10.0 * psd[k].max(1e-300) || s[k] > 10.0 * side)
            })
            .map(|k| k as f64 * df);
        if let Some(f) = lowest_mode {
            if 0.7 * f < cutoff {
                cutoff = 0.7 * f;
                capped = Some(f);
            }
        }
    }
    if cutoff < 15.0 {
        return (
            HighpassChoice::None,
            format!("none: rumble in the {noise_from} overlaps the strike's lowest mode"),
        );
    }
    let cap = capped.map_or(String::new(), |f| {
        format!(" (capped below the strike's lowest mode at {f:.0} Hz: some rumble stays)")
    });
    (
        HighpassChoice::Rumble(cutoff),
        format!(
            "{cutoff:.0} Hz: rumble in the {noise_from} stands {worst:.0} dB above the 300 Hz–3 kHz noise{cap}"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn scan_onset(x: &[f64]) -> Option<usize> {
        crate::onset::scan(x, 48000.0).onsets.first().copied()
    }

    #[test]
    fn removes_dc_and_chooses_a_highpass_for_rumble_only() {
        let fs = 48000.0;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(2);
        let nrm = Normal::new(0.0, 1e-4).expect("valid");
        let n = 96000;
        let onset = 48000;
        let strike = resound_core::damped::synthesize(
            &[resound_core::DampedMode {
                freq_hz: 1200.0,
                damping_per_s: 8.0,
                amplitude: 0.5,
                phase_rad: 0.0,
            }],
            fs,
            n - onset,
        );
        let base: Vec<f64> = (0..n)
            .map(|i| {
                -0.0014 + nrm.sample(&mut rng) + if i >= onset { strike[i - onset] } else { 0.0 }
            })
            .collect();
        // Without rumble: DC removed, no high-pass.
        let mut x = base.clone();
        let c = condition(&mut x, fs, None, true, scan_onset);
        assert!((c.dc_offset + 0.0014).abs() < 1e-4, "{c:?}");
        assert_eq!(c.highpass, HighpassChoice::None, "{c:?}");
        assert_eq!(c.noise_from, "lead-in");
        assert!((c.noise_floor_dbfs + 80.0).abs() < 1.0, "{c:?}");
        // With 20–40 Hz rumble: a cut-off between 30 and 200 Hz.
        let mut x: Vec<f64> = base
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let t = i as f64 / fs;
                v + 0.01 * (std::f64::consts::TAU * 23.0 * t).sin()
                    + 0.006 * (std::f64::consts::TAU * 37.0 * t + 1.0).sin()
            })
            .collect();
        let c = condition(&mut x, fs, None, true, scan_onset);
        let f = c.highpass.hz().expect("a high-pass for rumble");
        assert!((30.0..200.0).contains(&f), "{c:?}");
        assert!(matches!(c.highpass, HighpassChoice::Rumble(_)));
    }
}
