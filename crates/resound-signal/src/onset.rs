//! Strike onsets and clipping.

/// What [`scan`] found in a signal.
#[derive(Clone, Debug, Default)]
pub struct Scan {
    /// Sample index of each strike onset, ascending; empty for a silent signal.
    pub onsets: Vec<usize>,
    /// Samples that sit in flat runs (≥ 3 samples) at the signal's peak magnitude.
    pub clipped_samples: usize,
    /// Peak magnitude.
    pub peak: f64,
    /// Estimated noise floor (magnitude) before the first strike or in the quietest blocks.
    pub noise_floor: f64,
}

/// Finds strike onsets and clipping.
///
/// The signal is cut into 1 ms blocks; the block envelope is the largest magnitude in the block.
/// The noise floor is the 5th percentile of block envelopes. A strike starts in the first block
/// whose envelope exceeds both 20 dB above the floor and −40 dB below the peak; the onset is the
/// first sample after the last quiet one (magnitude at most 3× the median envelope before the
/// strike) that precedes the first loud sample, so a signal that starts at sample 0 has its
/// onset at 0. A later strike is a block whose envelope rises 12 dB
/// above the largest envelope of the 10 ms before it, within 2 ms, and reaches −30 dB of the peak.
pub fn scan(x: &[f64], sample_rate_hz: f64) -> Scan {
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut out = Scan {
        peak,
        ..Default::default()
    };
    if !(peak > 0.0) {
        return out;
    }
    // Clipping: flat runs at the peak.
    let mut run = 0;
    for v in x {
        if v.abs() >= peak * (1.0 - 1e-6) {
            run += 1;
        } else {
            if run >= 3 {
                out.clipped_samples += run;
            }
            run = 0;
        }
    }
    if run >= 3 {
        out.clipped_samples += run;
    }
    let block = ((sample_rate_hz * 1e-3).round() as usize).max(1);
    let env: Vec<f64> = x
        .chunks(block)
        .map(|c| c.iter().fold(0.0f64, |m, v| m.max(v.abs())))
        .collect();
    let mut sorted = env.clone();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 20];
    out.noise_floor = floor;
    let loud = (10.0 * floor).clamp(peak * 1e-2, peak * 0.3);
    let Some(first_block) = env.iter().position(|&e| e > loud) else {
        return out;
    };
    let start = first_block * block;
    let first_loud = start + x[start..].iter().position(|v| v.abs() > loud).unwrap_or(0);
    // "Quiet" is judged against the signal before the strike: with nothing before it (the
    // strike starts at sample 0) any non-zero sample belongs to the strike.
    let quiet = if first_block == 0 {
        0.0
    } else {
        let mut pre = env[..first_block].to_vec();
        pre.sort_by(f64::total_cmp);
        3.0 * pre[pre.len() / 2]
    };
    // The onset is the first sample of the loud run that ends the quiet: from it on, the
    // signal is the strike alone (a model that starts there fits it exactly).
    // Never further back than where the signal is 40 dB below its peak: a band-limited strike
    // (resampled, filtered) rings faintly before it, and a model must not start there.
    let quiet = quiet.max(1e-2 * peak);
    let mut onset = first_loud;
    while onset > 0 && x[onset - 1].abs() > quiet {
        onset -= 1;
    }
    out.onsets.push(onset);
    // Later strikes.
    let (look_back, rise) = (10usize, 2usize);
    let mut b = first_block + look_back + rise;
    while b < env.len() {
        let before = env[b - rise - look_back..b - rise]
            .iter()
            .fold(0.0f64, |m, &v| m.max(v));
        if env[b] > 4.0 * before && env[b] > peak * 10f64.powf(-30.0 / 20.0) {
            let s = (b - rise) * block;
            let local = env[b - rise..=b].iter().fold(0.0f64, |m, &v| m.max(v));
            let thr = (before * 2.0).max(local * 0.1);
            let mut on = s + x[s..].iter().position(|v| v.abs() > thr).unwrap_or(0);
            while on > s && x[on - 1].abs() > before {
                on -= 1;
            }
            out.onsets.push(on);
            b += look_back + rise;
        } else {
            b += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::{damped::synthesize, DampedMode};

    #[test]
    fn onsets_of_two_strikes() {
        let fs = 44100.0;
        let m = DampedMode {
            freq_hz: 800.0,
            damping_per_s: 30.0,
            amplitude: 0.5,
            phase_rad: 0.0,
        };
        let hit = synthesize(&[m], fs, 20000);
        let mut x = vec![0.0; 60000];
        for (i, v) in hit.iter().enumerate() {
            x[1000 + i] += v;
            x[31000 + i] += 0.8 * v;
        }
        let s = scan(&x, fs);
        assert_eq!(s.onsets.len(), 2, "{:?}", s.onsets);
        assert!(s.onsets[0].abs_diff(1000) <= 1, "{:?}", s.onsets);
        assert!(s.onsets[1].abs_diff(31000) <= 2, "{:?}", s.onsets);
        assert_eq!(s.clipped_samples, 0);
        let clipped: Vec<f64> = x.iter().map(|v| v.clamp(-0.3, 0.3)).collect();
        assert!(scan(&clipped, fs).clipped_samples > 100);
    }
}
