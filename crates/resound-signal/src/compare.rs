//! How far apart two strikes sound: the multi-resolution log-mel distance.
//!
//! Used to judge a resynthesis against its recording (and a recording against another
//! microphone of the same strike, which sets the scale of "as close as it gets"):
//!
//! 1. **onset alignment**: each signal is cut at its first strike onset (DC removed first),
//!    and both are cut to the shorter length (at most [`LogMelParams::max_duration_s`]);
//! 2. **energy normalisation**: each is scaled to unit energy, so only the spectral-temporal
//!    shape is compared, not the level;
//! 3. for each FFT size (Hann frames, hop ¼), the power spectrum is summed into mel bands
//!    (triangular, HTK mel scale, [`LogMelParams::min_hz`] to Nyquist), and
//!    `log10(band + floor)` is taken, the floor [`LogMelParams::floor_db`] below the louder
//!    signal's loudest band so silence compares equal to silence;
//! 4. the distance is the mean absolute difference of the log-mel cells, averaged over the
//!    FFT sizes (short frames judge the attack, long ones the pitch and the decay).
//!
//! 0 means identical shapes; a 1 is a factor of 10 in band power on average.

use realfft::RealFftPlanner;

/// Settings of [`log_mel_distance`].
#[derive(Clone, Debug)]
pub struct LogMelParams {
    /// FFT sizes at 48 kHz (scaled to the sample rate, to powers of two).
    pub fft_sizes_48k: Vec<usize>,
    /// Mel bands.
    pub bands: usize,
    /// Lowest band edge, Hz.
    pub min_hz: f64,
    /// Cells this far below the loudest band of either signal count as the floor, dB.
    pub floor_db: f64,
    /// Longest stretch compared after the onsets, s.
    pub max_duration_s: f64,
}

impl Default for LogMelParams {
    fn default() -> Self {
        Self {
            fft_sizes_48k: vec![256, 512, 1024, 2048, 4096],
            bands: 64,
            min_hz: 20.0,
            floor_db: 80.0,
            max_duration_s: 2.0,
        }
    }
}

/// What [`log_mel_distance`] measured.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LogMelDistance {
    /// Mean over FFT sizes of the mean absolute log10 band-power difference.
    pub distance: f64,
    /// Per FFT size (at the signals' rate): (size, distance).
    pub per_resolution: Vec<(usize, f64)>,
    /// Onsets found, s from the start of each signal.
    pub onsets_s: (f64, f64),
    /// Length compared after the onsets, s.
    pub compared_s: f64,
}

impl std::fmt::Display for LogMelDistance {
    /// The distance with what it means, then one line per FFT size.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "log-mel distance {:.4} (onsets at {:.4} s and {:.4} s, {:.3} s compared; 0 = same \
             shape, 1 = a factor of 10 in band power on average)",
            self.distance, self.onsets_s.0, self.onsets_s.1, self.compared_s
        )?;
        for (size, v) in &self.per_resolution {
            writeln!(f, "  FFT {size:>5}: {v:.4}")?;
        }
        Ok(())
    }
}

/// Why two signals cannot be compared.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CompareError {
    /// A signal has no strike (silent or constant).
    #[error("signal {0} holds no strike (silent or constant)")]
    NoStrike(usize),
    /// Too little audio after an onset.
    #[error("only {0:.1} ms in common after the onsets; at least 50 ms are needed")]
    TooShort(f64),
    /// Non-finite samples or an invalid rate.
    #[error("invalid input: {0}")]
    Invalid(String),
}

/// The multi-resolution log-mel distance between strikes `a` and `b`, both at
/// `sample_rate_hz` (see the module documentation).
///
/// # Errors
/// A signal without a strike, less than 50 ms in common after the onsets, non-finite input.
pub fn log_mel_distance(
    a: &[f64],
    b: &[f64],
    sample_rate_hz: f64,
    params: &LogMelParams,
) -> Result<LogMelDistance, CompareError> {
    if !resound_core::limits::sample_rate_ok(sample_rate_hz) {
        return Err(CompareError::Invalid(
            resound_core::limits::sample_rate_message(sample_rate_hz),
        ));
    }
    if a.iter().chain(b).any(|v| !v.is_finite()) {
        return Err(CompareError::Invalid("a sample is not finite".into()));
    }
    let cut = |x: &[f64], which: usize| -> Result<(Vec<f64>, usize), CompareError> {
        let mut sorted = x.to_vec();
        if sorted.is_empty() {
            return Err(CompareError::NoStrike(which));
        }
        let mid = sorted.len() / 2;
        let centre = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
        let c: Vec<f64> = x.iter().map(|v| v - centre).collect();
        let onset = crate::onset::scan(&c, sample_rate_hz)
            .onsets
            .first()
            .copied()
            .ok_or(CompareError::NoStrike(which))?;
        Ok((c[onset..].to_vec(), onset))
    };
    let (mut xa, oa) = cut(a, 1)?;
    let (mut xb, ob) = cut(b, 2)?;
    let max_len = (params.max_duration_s * sample_rate_hz) as usize;
    let n = xa.len().min(xb.len()).min(max_len.max(1));
    if (n as f64) < 0.05 * sample_rate_hz {
        return Err(CompareError::TooShort(1e3 * n as f64 / sample_rate_hz));
    }
    xa.truncate(n);
    xb.truncate(n);
    for (which, x) in [(1, &mut xa), (2, &mut xb)] {
        let e = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(e > 0.0) {
            return Err(CompareError::NoStrike(which));
        }
        x.iter_mut().for_each(|v| *v /= e);
    }
    let mut per_resolution = Vec::new();
    let mut planner = RealFftPlanner::<f64>::new();
    for &size48 in &params.fft_sizes_48k {
        let size = ((size48 as f64 * sample_rate_hz / 48000.0).round() as usize)
            .next_power_of_two()
            .max(64);
        if size > n {
            continue;
        }
        let fb = mel_bank(size, sample_rate_hz, params.bands, params.min_hz);
        let ma = mel_frames(&xa, size, &fb, &mut planner);
        let mb = mel_frames(&xb, size, &fb, &mut planner);
        let top = ma.iter().chain(&mb).copied().fold(0.0, f64::max);
        if !(top > 0.0) {
            continue;
        }
        let floor = top * 10f64.powf(-params.floor_db / 10.0);
        let d = ma
            .iter()
            .zip(&mb)
            .map(|(p, q)| ((p + floor).log10() - (q + floor).log10()).abs())
            .sum::<f64>()
            / ma.len() as f64;
        per_resolution.push((size, d));
    }
    if per_resolution.is_empty() {
        return Err(CompareError::TooShort(1e3 * n as f64 / sample_rate_hz));
    }
    let distance = per_resolution.iter().map(|r| r.1).sum::<f64>() / per_resolution.len() as f64;
    Ok(LogMelDistance {
        distance,
        per_resolution,
        onsets_s: (oa as f64 / sample_rate_hz, ob as f64 / sample_rate_hz),
        compared_s: n as f64 / sample_rate_hz,
    })
}

/// Triangular mel filters over the `size/2 + 1` bins: (first bin, weights) per band.
fn mel_bank(size: usize, fs: f64, bands: usize, min_hz: f64) -> Vec<(usize, Vec<f64>)> {
    let mel = |f: f64| 2595.0 * (1.0 + f / 700.0).log10();
    let hz = |m: f64| 700.0 * (10f64.powf(m / 2595.0) - 1.0);
    let (lo, hi) = (mel(min_hz), mel(0.5 * fs));
    let edges: Vec<f64> = (0..bands + 2)
        .map(|i| hz(lo + (hi - lo) * i as f64 / (bands + 1) as f64))
        .collect();
    let bin_hz = fs / size as f64;
    (0..bands)
        .map(|b| {
            let (l, c, r) = (edges[b], edges[b + 1], edges[b + 2]);
            let first = (l / bin_hz).ceil() as usize;
            let last = ((r / bin_hz).floor() as usize).min(size / 2);
            let w: Vec<f64> = (first..=last.max(first))
                .map(|k| {
                    let f = k as f64 * bin_hz;
                    if f <= c {
                        ((f - l) / (c - l)).max(0.0)
                    } else {
                        ((r - f) / (r - c)).max(0.0)
                    }
                })
                .collect();
            // A band narrower than a bin takes the nearest bin whole.
            if w.iter().all(|&v| v == 0.0) {
                ((c / bin_hz).round() as usize, vec![1.0])
            } else {
                (first, w)
            }
        })
        .collect()
}

/// Mel band powers of every frame (frames × bands, row-major).
fn mel_frames(
    x: &[f64],
    size: usize,
    bank: &[(usize, Vec<f64>)],
    planner: &mut RealFftPlanner<f64>,
) -> Vec<f64> {
    let hop = size / 4;
    let fft = planner.plan_fft_forward(size);
    let window = crate::stft::hann(size);
    let mut buf = fft.make_input_vec();
    let mut spec = fft.make_output_vec();
    let mut out = Vec::new();
    let mut start = 0;
    while start + size <= x.len() {
        for (i, v) in buf.iter_mut().enumerate() {
            *v = x[start + i] * window[i];
        }
        if fft.process(&mut buf, &mut spec).is_err() {
            break;
        }
        for (first, w) in bank {
            let p: f64 = w
                .iter()
                .enumerate()
                .map(|(k, wk)| wk * spec.get(first + k).map_or(0.0, |c| c.norm_sqr()))
                .sum();
            out.push(p);
        }
        start += hop;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::{damped::synthesize, DampedMode};

    fn strike(f: &[(f64, f64)], lead_in: usize) -> Vec<f64> {
        let modes: Vec<DampedMode> = f
            .iter()
            .map(|&(f, d)| DampedMode {
                freq_hz: f,
                damping_per_s: d,
                amplitude: 0.2,
                phase_rad: 0.0,
            })
            .collect();
        let mut x = vec![0.0; lead_in];
        x.extend(synthesize(&modes, 48000.0, 48000));
        x
    }

    #[test]
    fn same_shape_is_zero_and_a_different_material_is_far() {
        let p = LogMelParams::default();
        let a = strike(&[(440.0, 6.0), (1210.0, 15.0), (2630.0, 40.0)], 0);
        // The same strike, later, quieter and with a DC offset: the same shape.
        let b: Vec<f64> = strike(&[(440.0, 6.0), (1210.0, 15.0), (2630.0, 40.0)], 4800)
            .iter()
            .map(|v| 0.3 * v + 0.01)
            .collect();
        let same = log_mel_distance(&a, &b, 48000.0, &p).unwrap();
        assert!(same.distance < 0.02, "{same:?}");
        assert!((same.onsets_s.1 - 0.1).abs() < 0.002, "{same:?}");
        // Damping ten times higher (wood-like): clearly apart; another pitch: further still.
        let wood = strike(&[(440.0, 60.0), (1210.0, 150.0), (2630.0, 400.0)], 0);
        let pitch = strike(&[(520.0, 6.0), (1430.0, 15.0), (3100.0, 40.0)], 0);
        let dw = log_mel_distance(&a, &wood, 48000.0, &p).unwrap().distance;
        let dp = log_mel_distance(&a, &pitch, 48000.0, &p).unwrap().distance;
        assert!(dw > 0.3 && dp > 0.3, "{dw} {dp}");
        // Symmetric.
        let back = log_mel_distance(&wood, &a, 48000.0, &p).unwrap().distance;
        assert!((back - dw).abs() < 1e-12);
        assert_eq!(
            log_mel_distance(&a, &vec![0.0; 48000], 48000.0, &p),
            Err(CompareError::NoStrike(2))
        );
    }
}
