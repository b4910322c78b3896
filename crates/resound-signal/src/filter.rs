//! Butterworth high-pass filtering, applied forward and backward (zero phase) so that the
//! phases and amplitudes of modes well above the cut-off are untouched.

use std::f64::consts::PI;

/// One biquad section (transposed direct form II).
#[derive(Clone, Copy, Debug)]
struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
}

impl Biquad {
    /// Second-order high-pass by the bilinear transform with pre-warping.
    fn highpass(cutoff_hz: f64, q: f64, sample_rate_hz: f64) -> Self {
        let w0 = 2.0 * PI * cutoff_hz / sample_rate_hz;
        let (s, c) = w0.sin_cos();
        let alpha = s / (2.0 * q);
        let a0 = 1.0 + alpha;
        Self {
            b: [(1.0 + c) / 2.0 / a0, -(1.0 + c) / a0, (1.0 + c) / 2.0 / a0],
            a: [-2.0 * c / a0, (1.0 - alpha) / a0],
        }
    }

    fn run(&self, x: &mut [f64]) {
        let (mut z1, mut z2) = (0.0, 0.0);
        for v in x.iter_mut() {
            let y = self.b[0] * *v + z1;
            z1 = self.b[1] * *v - self.a[0] * y + z2;
            z2 = self.b[2] * *v - self.a[1] * y;
            *v = y;
        }
    }
}

/// Zero-phase 4th-order Butterworth high-pass (two biquads, run forward then backward: the
/// magnitude response is the square of the 4th-order one, −6 dB at `cutoff_hz`).
pub fn highpass_zero_phase(x: &mut [f64], cutoff_hz: f64, sample_rate_hz: f64) {
    if !(cutoff_hz > 0.0 && cutoff_hz < 0.5 * sample_rate_hz) {
        return;
    }
    // Pole-pair Q values of a 4th-order Butterworth filter.
    let sections = [
        Biquad::highpass(cutoff_hz, 0.541_196_100_146_197, sample_rate_hz),
        Biquad::highpass(cutoff_hz, 1.306_562_964_876_376_7, sample_rate_hz),
    ];
    for s in &sections {
        s.run(x);
    }
    x.reverse();
    for s in &sections {
        s.run(x);
    }
    x.reverse();
}

/// Causal 4th-order Butterworth high-pass (the two biquads, forward only). Nothing it outputs
/// precedes its input, so onsets found on its output are never early — unlike the zero-phase
/// filter, whose backward pass spreads a strike's first milliseconds before it.
pub fn highpass_causal(x: &mut [f64], cutoff_hz: f64, sample_rate_hz: f64) {
    if !(cutoff_hz > 0.0 && cutoff_hz < 0.5 * sample_rate_hz) {
        return;
    }
    for s in &[
        Biquad::highpass(cutoff_hz, 0.541_196_100_146_197, sample_rate_hz),
        Biquad::highpass(cutoff_hz, 1.306_562_964_876_376_7, sample_rate_hz),
    ] {
        s.run(x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gain(f: f64) -> f64 {
        let fs = 48000.0;
        let n = 48000;
        let x: Vec<f64> = (0..n)
            .map(|i| (2.0 * PI * f * i as f64 / fs).sin())
            .collect();
        let mut y = x.clone();
        highpass_zero_phase(&mut y, 100.0, fs);
        // Middle part, away from the edges.
        let r = |v: &[f64]| (v[12000..36000].iter().map(|a| a * a).sum::<f64>()).sqrt();
        r(&y) / r(&x)
    }

    #[test]
    fn butterworth_response() {
        // |H|² of a 4th-order Butterworth filter: 1 / (1 + (fc/f)^8).
        for f in [25.0, 50.0, 100.0, 200.0, 1000.0] {
            let expect = 1.0 / (1.0 + (100.0f64 / f).powi(8));
            assert!(
                (gain(f) - expect).abs() < 0.01 + 0.02 * expect,
                "{f} Hz: {} vs {expect}",
                gain(f)
            );
        }
    }
}
