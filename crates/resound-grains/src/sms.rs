//! Sinusoidal + residual split of continuous-contact recordings (Serra's SMS, Picard §3.1).
//!
//! Spectral peaks are picked in every STFT frame (local maxima standing `prominence_db` above
//! their neighbourhood and above an absolute floor), continued from frame to frame by nearest
//! frequency, and the tracks that last at least `min_track_s` are the stable sinusoids. Instead of
//! resynthesizing them with oscillators and subtracting (which needs exact phases), their main
//! lobes are taken out of the STFT itself: the sinusoidal part is the inverse STFT of those bins,
//! the transient part is the recording minus the sinusoidal part. The STFT (sine window, hop W/4)
//! is a tight frame, so the two parts sum to the recording exactly.

use resound_signal::sine_stft::Stft;

/// SMS settings.
#[derive(Clone, Debug, PartialEq)]
pub struct SmsParams {
    /// STFT window, s (rounded up to a power of two in samples).
    pub window_s: f64,
    /// Shortest track that counts as a stable sinusoid, s.
    pub min_track_s: f64,
    /// How far a peak must stand above the mean of its neighbourhood (3–10 bins away), dB.
    pub prominence_db: f64,
    /// Peaks below the recording's strongest bin by more than this are ignored, dB.
    pub floor_db: f64,
    /// Bins either side of a track's peak bin given to the sinusoidal part.
    pub lobe_bins: usize,
}

impl Default for SmsParams {
    fn default() -> Self {
        Self {
            window_s: 0.046,
            min_track_s: 0.06,
            prominence_db: 12.0,
            floor_db: -70.0,
            lobe_bins: 2,
        }
    }
}

struct Track {
    /// (frame, peak bin) pairs.
    points: Vec<(usize, usize)>,
    freq_bin: f64,
    last_frame: usize,
}

/// Splits `x` into (sinusoidal, transient) parts with `sinusoidal + transient = x`.
pub fn split(x: &[f32], sample_rate_hz: f64, p: &SmsParams) -> (Vec<f32>, Vec<f32>) {
    let w = ((p.window_s * sample_rate_hz) as usize)
        .next_power_of_two()
        .max(256);
    if x.len() < w {
        return (vec![0.0; x.len()], x.to_vec());
    }
    let hop = w / 4;
    let mut stft = Stft::with_hop(w, hop);
    let mut spec = Vec::new();
    stft.forward(x, &mut spec);
    let bins = stft.bins();
    let frames = spec.len() / bins;
    let mag: Vec<f32> = spec.iter().map(|c| c.norm()).collect();
    let top = mag.iter().copied().fold(0.0f32, f32::max);
    let floor = top * 10f32.powf(p.floor_db as f32 / 20.0);
    let prominence = 10f32.powf(p.prominence_db as f32 / 20.0);
    let min_frames = ((p.min_track_s * sample_rate_hz / hop as f64).ceil() as usize).max(2);
    let mut active: Vec<Track> = Vec::new();
    let mut stable: Vec<Track> = Vec::new();
    let mut peaks: Vec<(f32, usize, f64)> = Vec::new();
    for m in 0..frames {
        let row = &mag[m * bins..(m + 1) * bins];
        peaks.clear();
        for k in 10..bins.saturating_sub(10) {
            let v = row[k];
            if !(v > floor && v > row[k - 1] && v >= row[k + 1]) {
                continue;
            }
            let near: f32 = row[k - 10..k - 2]
                .iter()
                .chain(&row[k + 3..k + 11])
                .sum::<f32>()
                / 16.0;
            if v < prominence * near {
                continue;
            }
            // Parabolic interpolation on log magnitude.
            let (a, b, c) = (
                f64::from(row[k - 1].max(1e-30)).ln(),
                f64::from(v).ln(),
                f64::from(row[k + 1].max(1e-30)).ln(),
            );
            let den = a - 2.0 * b + c;
            let delta = if den < 0.0 { 0.5 * (a - c) / den } else { 0.0 };
            peaks.push((v, k, k as f64 + delta.clamp(-0.5, 0.5)));
        }
        peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut claimed = vec![false; active.len()];
        let mut born = Vec::new();
        for &(_, k, fb) in &peaks {
            let jump = (0.03 * fb).max(1.5);
            let mut best: Option<(usize, f64)> = None;
            for (i, t) in active.iter().enumerate() {
                let d = (t.freq_bin - fb).abs();
                if !claimed[i] && d <= jump && best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((i, d));
                }
            }
            match best {
                Some((i, _)) => {
                    claimed[i] = true;
                    let t = &mut active[i];
                    t.points.push((m, k));
                    t.freq_bin = fb;
                    t.last_frame = m;
                }
                None => born.push(Track {
                    points: vec![(m, k)],
                    freq_bin: fb,
                    last_frame: m,
                }),
            }
        }
        // Tracks not continued in this frame end.
        let mut i = 0;
        while i < active.len() {
            if active[i].last_frame != m {
                let t = active.swap_remove(i);
                if t.points.len() >= min_frames {
                    stable.push(t);
                }
            } else {
                i += 1;
            }
        }
        active.extend(born);
    }
    stable.extend(active.into_iter().filter(|t| t.points.len() >= min_frames));
    let mut sin_spec = vec![realfft::num_complex::Complex32::new(0.0, 0.0); spec.len()];
    for t in &stable {
        for &(m, k) in &t.points {
            let lo = k.saturating_sub(p.lobe_bins);
            let hi = (k + p.lobe_bins).min(bins - 1);
            let r = m * bins;
            sin_spec[r + lo..=r + hi].copy_from_slice(&spec[r + lo..=r + hi]);
        }
    }
    let mut sinusoidal = Vec::new();
    stft.inverse(&sin_spec, x.len(), &mut sinusoidal);
    let transient = x.iter().zip(&sinusoidal).map(|(&a, &s)| a - s).collect();
    (sinusoidal, transient)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn energy(x: &[f32]) -> f64 {
        x.iter().map(|&v| f64::from(v).powi(2)).sum()
    }

    #[test]
    fn sines_go_to_the_sinusoidal_part_and_clicks_to_the_transient_part() {
        let fs = 44_100.0;
        let n = 88_200;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(3);
        let sines: Vec<f32> = (0..n)
            .map(|i| {
                let t = i as f64 / fs;
                (0.3 * (std::f64::consts::TAU * 440.0 * t).sin()
                    + 0.2 * (std::f64::consts::TAU * 1234.5 * t + 1.0).sin()
                    + 0.1 * (std::f64::consts::TAU * 3010.0 * t + 2.0).sin()) as f32
            })
            .collect();
        let mut clicks = vec![0.0f32; n];
        for c in 0..8 {
            let at = 5000 + c * 10_000;
            for k in 0..220 {
                clicks[at + k] =
                    (rng.random::<f64>() * 2.0 - 1.0) as f32 * 0.8 * (-(k as f32) / 40.0).exp();
            }
        }
        let x: Vec<f32> = sines.iter().zip(&clicks).map(|(a, b)| a + b).collect();
        let (s, t) = split(&x, fs, &SmsParams::default());
        // Exact complement.
        for i in 0..n {
            assert!((s[i] + t[i] - x[i]).abs() < 1e-5);
        }
        // The sinusoidal part is the sines: error 20 dB under them.
        let err: Vec<f32> = s.iter().zip(&sines).map(|(a, b)| a - b).collect();
        let ratio = energy(&err) / energy(&sines);
        assert!(ratio < 0.01, "sinusoidal part error {ratio}");
        // The transient part holds the clicks, not the sines.
        let terr: Vec<f32> = t.iter().zip(&clicks).map(|(a, b)| a - b).collect();
        let tratio = energy(&terr) / energy(&clicks);
        assert!(tratio < 0.35, "transient part error {tratio}");
    }

    #[test]
    fn noise_stays_in_the_transient_part() {
        let mut rng = rand::rngs::SmallRng::seed_from_u64(5);
        let x: Vec<f32> = (0..44_100)
            .map(|_| (rng.random::<f64>() - 0.5) as f32)
            .collect();
        let (s, _) = split(&x, 44_100.0, &SmsParams::default());
        assert!(
            energy(&s) < 0.05 * energy(&x),
            "{}",
            energy(&s) / energy(&x)
        );
    }
}
