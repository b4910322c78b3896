//! Damped sinusoids: the features of a recorded or synthesized impact (Ren 2013 eq. 5).
//!
//! Convention used across Resound:
//! `s(t) = Σ a_i e^(−d_i t) sin(2π f_i t + θ_i)`, with `t = 0` at the strike onset, `a_i` the
//! linear peak amplitude at the onset in sample units (full scale = 1.0), `d_i` the amplitude
//! decay rate in 1/s and `θ_i` in radians.

use serde::{Deserialize, Serialize};

/// One damped sinusoid `a e^(−d t) sin(2π f t + θ)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DampedMode {
    /// Frequency f in Hz.
    pub freq_hz: f64,
    /// Amplitude decay rate d in 1/s (the envelope is e^(−d t)).
    pub damping_per_s: f64,
    /// Linear peak amplitude a at t = 0 (full scale = 1.0).
    pub amplitude: f64,
    /// Phase θ in radians, in (−π, π].
    pub phase_rad: f64,
}

/// How sure an analysed mode is: the standard deviations of its frequency and damping (the
/// Cramér–Rao bound at the measured noise, `resound_signal::crb::mode_sigmas`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModeSigma {
    /// σ of the frequency, Hz.
    pub freq_hz: f64,
    /// σ of the damping, 1/s.
    pub damping_per_s: f64,
}

impl DampedMode {
    /// A mode with zero phase.
    pub fn new(freq_hz: f64, damping_per_s: f64, amplitude: f64) -> Self {
        Self {
            freq_hz,
            damping_per_s,
            amplitude,
            phase_rad: 0.0,
        }
    }

    /// Value at time `t_s` (zero before the onset).
    pub fn value(&self, t_s: f64) -> f64 {
        if t_s < 0.0 {
            return 0.0;
        }
        self.amplitude
            * (-self.damping_per_s * t_s).exp()
            * (std::f64::consts::TAU * self.freq_hz * t_s + self.phase_rad).sin()
    }

    /// Time after which the envelope stays below `floor` (absolute amplitude); infinite for
    /// undamped modes above the floor.
    pub fn time_to_floor_s(&self, floor: f64) -> f64 {
        if self.amplitude <= floor {
            return 0.0;
        }
        if self.damping_per_s <= 0.0 {
            return f64::INFINITY;
        }
        (self.amplitude / floor).ln() / self.damping_per_s
    }

    /// Adds this mode to `out`, whose sample 0 is at `t = 0`. Uses a complex rotation
    /// recurrence (two multiplies per sample) re-anchored every 1024 samples to stay exact.
    pub fn add_to(&self, sample_rate_hz: f64, out: &mut [f64]) {
        let dt = 1.0 / sample_rate_hz;
        let w = std::f64::consts::TAU * self.freq_hz * dt;
        let decay = (-self.damping_per_s * dt).exp();
        let (sw, cw) = w.sin_cos();
        let (rr, ri) = (decay * cw, decay * sw);
        for (block, chunk) in out.chunks_mut(1024).enumerate() {
            let n0 = (block * 1024) as f64;
            let env = self.amplitude * (-self.damping_per_s * n0 * dt).exp();
            if env == 0.0 {
                break;
            }
            let (s, c) = (w * n0 + self.phase_rad).sin_cos();
            // z = env · e^{j(w n + θ)}; the sample is Im z. Four interleaved recurrences
            // (stride 4, rotation r⁴) instead of one chain keep the multiplier busy.
            let mut z = [(env * c, env * s); 4];
            for q in 1..4 {
                let (pr, pi) = z[q - 1];
                z[q] = (pr * rr - pi * ri, pr * ri + pi * rr);
            }
            let (r2r, r2i) = (rr * rr - ri * ri, 2.0 * rr * ri);
            let (r4r, r4i) = (r2r * r2r - r2i * r2i, 2.0 * r2r * r2i);
            let mut quads = chunk.chunks_exact_mut(4);
            for quad in &mut quads {
                for (v, zq) in quad.iter_mut().zip(z.iter_mut()) {
                    *v += zq.1;
                    *zq = (zq.0 * r4r - zq.1 * r4i, zq.0 * r4i + zq.1 * r4r);
                }
            }
            for (v, zq) in quads.into_remainder().iter_mut().zip(z) {
                *v += zq.1;
            }
        }
    }
}

/// Sum of `modes` over `n` samples at `sample_rate_hz`, sample 0 at t = 0.
pub fn synthesize(modes: &[DampedMode], sample_rate_hz: f64, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    for m in modes {
        m.add_to(sample_rate_hz, &mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recurrence_matches_closed_form() {
        let m = DampedMode {
            freq_hz: 1234.5,
            damping_per_s: 3.0,
            amplitude: 0.7,
            phase_rad: 0.4,
        };
        let fs = 44100.0;
        // A length that leaves a partial block and a partial group of four at the end.
        let s = synthesize(&[m], fs, 50_003);
        for (n, v) in s
            .iter()
            .enumerate()
            .step_by(997)
            .chain(s.iter().enumerate().skip(49_995))
        {
            assert!((v - m.value(n as f64 / fs)).abs() < 1e-12, "sample {n}");
        }
        assert!((m.time_to_floor_s(0.7 * (-3.0f64).exp()) - 1.0).abs() < 1e-12);
    }
}
