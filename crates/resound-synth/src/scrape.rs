//! Scraping (Traer, Cusimano & McDermott 2019 §4): a probe dragged over a surface profile.
//!
//! The probe follows the surface without slip or bounce, so its height is `z(t) = S(x(t))`.
//! The contact force (eq. 8) is
//! `f(t) = m_p z̈ + A |ż|^γ`, with `z̈ = S''(x) v²` and `ż = S'(x) v` along a straight path.
//! Both are formed from the sampled height track directly:
//! - `z_n` is the profile averaged over the probe tip's width (0.2 mm by default: a tip cannot
//!   follow narrower features) or the distance covered in one sample if that is wider (a boxcar
//!   anti-alias filter: a 10 µm profile scraped at 1 m/s has detail far above Nyquist);
//! - then `ż`, `z̈` are finite differences in time.
//!
//! Surfaces:
//! - [`Surface::fractal`]: a procedural 1/f^β profile (we use β = 2, a Brownian profile: with
//!   β = 1 the temporal spectrum of S(vt) is the same at every speed, so eq. 8 would not get
//!   louder with speed; real surfaces are steeper than 1/f at these scales);
//! - [`Surface::quilt`]: one-dimensional quilting of a measured profile (random segments
//!   concatenated, each shifted to continue at the height where the last one ended and
//!   cross-faded), as Traer quilt rows of a depth map.
//!
//! Location-dependent IRs (eq. 9): [`scrape`] renders one IR per centre point along the path.
//! Each has its mode powers perturbed by Gaussian noise of 20 % of the mean power. The outputs
//! are mixed with weights linear in the probe's distance to the two nearest centre points
//! (interpolation in waveform space).

use crate::bank::{BankMode, ModalBank};
use crate::SynthError;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;

/// A 1-D height profile `S(x)` (m) sampled every `spacing_m`, periodic.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Heights, m.
    pub heights_m: Vec<f64>,
    /// Sample spacing, m.
    pub spacing_m: f64,
    prefix: Vec<f64>,
}

impl Surface {
    /// A surface from measured heights.
    pub fn new(heights_m: Vec<f64>, spacing_m: f64) -> Result<Self, SynthError> {
        if heights_m.len() < 4 || !(spacing_m > 0.0 && spacing_m.is_finite()) {
            return Err(SynthError::Parameter(format!(
                "a surface needs at least 4 heights and a positive spacing ({} heights, {spacing_m} m)",
                heights_m.len()
            )));
        }
        if heights_m.iter().any(|h| !h.is_finite()) {
            return Err(SynthError::Parameter(
                "surface heights must be finite".into(),
            ));
        }
        let mut prefix = Vec::with_capacity(heights_m.len() + 1);
        prefix.push(0.0);
        for h in &heights_m {
            prefix.push(prefix[prefix.len() - 1] + h);
        }
        Ok(Self {
            heights_m,
            spacing_m,
            prefix,
        })
    }

    /// A procedural 1/f^β profile of `len` samples (rounded up to a power of two) with RMS
    /// height `rms_m`.
    pub fn fractal(
        len: usize,
        spacing_m: f64,
        beta: f64,
        rms_m: f64,
        seed: u64,
    ) -> Result<Self, SynthError> {
        let out = fractal_profile(len.max(16).next_power_of_two(), beta, seed)?;
        Self::new(out.iter().map(|v| v * rms_m).collect(), spacing_m)
    }

    /// One-dimensional quilting of `profile`: `len` samples from random segments of
    /// `patch` samples, each offset to continue where the previous ended and cross-faded over
    /// `patch / 8` samples.
    pub fn quilt(
        profile: &[f64],
        spacing_m: f64,
        len: usize,
        patch: usize,
        seed: u64,
    ) -> Result<Self, SynthError> {
        if profile.len() < 2 * patch || patch < 16 {
            return Err(SynthError::Parameter(format!(
                "quilting needs a profile of at least two patches ({} samples, patch {patch})",
                profile.len()
            )));
        }
        let mut rng = SmallRng::seed_from_u64(seed);
        let fade = patch / 8;
        let mut out: Vec<f64> = Vec::with_capacity(len + patch);
        while out.len() < len {
            let start = rng.random_range(0..profile.len() - patch);
            let seg = &profile[start..start + patch];
            if out.is_empty() {
                out.extend_from_slice(seg);
                continue;
            }
            // Overlap the last `fade` samples with the segment's first, the segment shifted so
            // the two agree in mean there.
            let tail_start = out.len() - fade;
            let shift = out[tail_start..].iter().sum::<f64>() / fade as f64
                - seg[..fade].iter().sum::<f64>() / fade as f64;
            for i in 0..fade {
                let w = (i as f64 + 0.5) / fade as f64;
                out[tail_start + i] = (1.0 - w) * out[tail_start + i] + w * (seg[i] + shift);
            }
            out.extend(seg[fade..].iter().map(|v| v + shift));
        }
        out.truncate(len);
        // Remove the drift the shifts accumulate (a linear trend), so the surface is level.
        let n = out.len() as f64;
        let mx = (n - 1.0) / 2.0;
        let my = out.iter().sum::<f64>() / n;
        let sxy: f64 = out
            .iter()
            .enumerate()
            .map(|(i, y)| (i as f64 - mx) * (y - my))
            .sum();
        let sxx: f64 = (0..out.len()).map(|i| (i as f64 - mx).powi(2)).sum();
        let slope = sxy / sxx.max(1e-300);
        out.iter_mut()
            .enumerate()
            .for_each(|(i, y)| *y -= my + slope * (i as f64 - mx));
        Self::new(out, spacing_m)
    }

    /// Mean height over `[a, b]` (m, a ≤ b), periodic.
    fn mean_over(&self, a: f64, b: f64) -> f64 {
        let n = self.heights_m.len();
        let total = self.prefix[n];
        // Cumulative sum as a piecewise-linear function of position (in samples).
        let cum = |x: f64| {
            let s = x / self.spacing_m;
            let periods = (s / n as f64).floor();
            let r = s - periods * n as f64;
            let i = (r.floor() as usize).min(n - 1);
            periods * total + self.prefix[i] + (r - i as f64) * self.heights_m[i]
        };
        if b - a < 1e-12 * self.spacing_m {
            let s = a / self.spacing_m;
            let i = (s.rem_euclid(n as f64).floor() as usize).min(n - 1);
            return self.heights_m[i];
        }
        (cum(b) - cum(a)) / ((b - a) / self.spacing_m)
    }
}

/// Constants of eq. 8.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScrapeParams {
    /// Probe mass m_p, kg.
    pub probe_mass_kg: f64,
    /// Shear-friction coefficient A (N per (m/s)^γ).
    pub friction: f64,
    /// Exponent γ.
    pub gamma: f64,
    /// Width of the probe's tip, m: it cannot follow features narrower than this, so the height
    /// it follows is the profile averaged over its width (a spatial low-pass whose temporal
    /// cut-off, v / width, rises with speed: faster scrapes are brighter).
    pub tip_width_m: f64,
}

impl Default for ScrapeParams {
    fn default() -> Self {
        Self {
            probe_mass_kg: 0.01,
            friction: 100.0,
            gamma: 1.0,
            tip_width_m: 2e-4,
        }
    }
}

/// The contact force (N per sample) of a probe at positions `x_m[n]` (along the surface, one
/// per sample at `sample_rate_hz`).
pub fn scrape_force(
    surface: &Surface,
    x_m: &[f64],
    sample_rate_hz: f64,
    p: &ScrapeParams,
) -> Vec<f32> {
    let n = x_m.len();
    if n < 3 {
        return vec![0.0; n];
    }
    // Height track: the profile averaged over the tip's width or the sample's travel, whichever
    // is wider (the tip's low-pass, and a boxcar against aliasing).
    let half_tip = 0.5 * p.tip_width_m.max(0.0);
    let z: Vec<f64> = (0..n)
        .map(|i| {
            let prev = if i > 0 { x_m[i - 1] } else { x_m[i] };
            let next = if i + 1 < n { x_m[i + 1] } else { x_m[i] };
            let (a, b) = (0.5 * (prev + x_m[i]), 0.5 * (x_m[i] + next));
            let (lo, hi) = (a.min(b), a.max(b));
            let half = (0.5 * (hi - lo)).max(half_tip);
            let c = 0.5 * (lo + hi);
            surface.mean_over(c - half, c + half)
        })
        .collect();
    let t = 1.0 / sample_rate_hz;
    let mut f: Vec<f64> = (0..n)
        .map(|i| {
            if i == 0 || i + 1 == n {
                return 0.0;
            }
            let zdd = (z[i + 1] - 2.0 * z[i] + z[i - 1]) / (t * t);
            let zd = (z[i + 1] - z[i - 1]) / (2.0 * t);
            p.probe_mass_kg * zdd + p.friction * zd.abs().powf(p.gamma)
        })
        .collect();
    // The friction term |ż|^γ is never negative: its mean (and its slow swell as the speed
    // changes) would deflect the object statically — no sound, but a DC drift in the output
    // (14 % of a scrape's energy below 5 Hz). A microphone hears pressure, not deflection:
    // what is below FORCE_HIGHPASS_HZ goes (zero-phase, so no delay).
    resound_signal::filter::highpass_zero_phase(&mut f, FORCE_HIGHPASS_HZ, sample_rate_hz);
    f.iter().map(|&v| v as f32).collect()
}

/// Scrape forces are high-passed here (Hz): below it they only deflect the object.
pub const FORCE_HIGHPASS_HZ: f64 = 20.0;

/// Positions along a trajectory given as (time s, position m) points, at the sample rate
/// (linear interpolation; before the first and after the last point the probe rests).
pub fn positions(trajectory: &[(f64, f64)], sample_rate_hz: f64, samples: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(samples);
    let mut j = 0;
    for k in 0..samples {
        let t = k as f64 / sample_rate_hz;
        while j + 1 < trajectory.len() && trajectory[j + 1].0 <= t {
            j += 1;
        }
        let x = match (trajectory.get(j), trajectory.get(j + 1)) {
            (Some(&(t0, x0)), Some(&(t1, x1))) if t >= t0 && t1 > t0 => {
                x0 + (x1 - x0) * ((t - t0) / (t1 - t0)).min(1.0)
            }
            (Some(&(_, x0)), _) => x0,
            _ => 0.0,
        };
        out.push(x);
    }
    out
}

/// Renders a scrape: `force` (from [`scrape_force`]) through `ir_count` location-dependent
/// variants of `modes` (eq. 9), centred evenly over the positions' range and mixed by the
/// probe's position. Gains are per N·s.
pub fn scrape(
    modes: &[BankMode],
    force: &[f32],
    x_m: &[f64],
    sample_rate_hz: f64,
    ir_count: usize,
    seed: u64,
) -> Result<Vec<f32>, SynthError> {
    let n = force.len().min(x_m.len());
    let k = ir_count.max(1);
    let (lo, hi) = x_m[..n]
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let span = (hi - lo).max(1e-9);
    let centres: Vec<f64> = (0..k)
        .map(|i| {
            if k == 1 {
                lo
            } else {
                lo + span * i as f64 / (k - 1) as f64
            }
        })
        .collect();
    let mut rng = SmallRng::seed_from_u64(seed);
    let mean_power = modes.iter().map(|m| m.gain * m.gain).sum::<f64>() / modes.len().max(1) as f64;
    let mut out = vec![0.0f32; n];
    let mut x = vec![0.0f32; n];
    let mut y = vec![0.0f32; n];
    for (c, &centre) in centres.iter().enumerate() {
        // Eq. 9: mode powers plus Gaussian noise of 20 % of the mean power.
        let variant: Vec<BankMode> = modes
            .iter()
            .map(|m| {
                let eps: f64 =
                    rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng);
                let power = (m.gain * m.gain + 0.2 * mean_power * eps).max(0.0);
                BankMode {
                    gain: power.sqrt() * m.gain.signum(),
                    ..*m
                }
            })
            .collect();
        // Weight of this IR at each sample: linear between neighbouring centres.
        let step = if k == 1 {
            f64::INFINITY
        } else {
            span / (k - 1) as f64
        };
        for i in 0..n {
            let w = if k == 1 {
                1.0
            } else {
                (1.0 - (x_m[i] - centre).abs() / step).max(0.0)
            };
            x[i] = force[i] * w as f32;
        }
        let _ = c;
        if x.iter().all(|&v| v == 0.0) {
            continue;
        }
        let mut bank = ModalBank::new(sample_rate_hz, &variant, 0.0)?;
        y.fill(0.0);
        bank.process(&x, &mut y);
        for (o, v) in out.iter_mut().zip(&y) {
            *o += v;
        }
    }
    Ok(out)
}

/// The one 1/f^β profile generator: `len` samples (a power of two) of periodic noise with
/// power ∝ k^(−β) at spatial frequency bin k and random phases (seeded), unit RMS. Scraping
/// surfaces scale it to their RMS height; scenes read it as their sliding/rolling texture.
///
/// # Errors
/// [`SynthError::Parameter`] when the inverse FFT fails (a length that is not a power of two).
pub fn fractal_profile(len: usize, beta: f64, seed: u64) -> Result<Vec<f64>, SynthError> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut planner = RealFftPlanner::<f64>::new();
    let inv = planner.plan_fft_inverse(len);
    let mut spec = inv.make_input_vec();
    let bins = spec.len();
    for (k, c) in spec.iter_mut().enumerate().skip(1) {
        let phase = if k + 1 == bins {
            0.0
        } else {
            rng.random::<f64>() * std::f64::consts::TAU
        };
        *c = Complex64::from_polar((k as f64).powf(-0.5 * beta), phase);
    }
    let mut out = inv.make_output_vec();
    inv.process(&mut spec, &mut out)
        .map_err(|e| SynthError::Parameter(format!("fft: {e}")))?;
    let rms = (out.iter().map(|v| v * v).sum::<f64>() / len as f64).sqrt();
    out.iter_mut().for_each(|v| *v /= rms.max(1e-300));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Power per FFT bin of `x` (zero-padded to a power of two) and the bin width, Hz.
    fn power_spectrum(x: &[f32], fs: f64) -> (Vec<f64>, f64) {
        let mut planner = RealFftPlanner::<f64>::new();
        let n = x.len().next_power_of_two();
        let fft = planner.plan_fft_forward(n);
        let mut buf: Vec<f64> = x.iter().map(|&v| f64::from(v)).collect();
        buf.resize(n, 0.0);
        let mut spec = fft.make_output_vec();
        let _ = fft.process(&mut buf, &mut spec);
        (spec.iter().map(|c| c.norm_sqr()).collect(), fs / n as f64)
    }

    fn centroid(x: &[f32], fs: f64) -> f64 {
        let (p, bin) = power_spectrum(x, fs);
        let num: f64 = p.iter().enumerate().map(|(k, v)| v * k as f64).sum();
        num / p.iter().sum::<f64>() * bin
    }

    /// Share of `x`'s energy below `hz`.
    fn share_below(x: &[f32], fs: f64, hz: f64) -> f64 {
        let (p, bin) = power_spectrum(x, fs);
        let low: f64 = p
            .iter()
            .enumerate()
            .filter(|(k, _)| (*k as f64) * bin < hz)
            .map(|(_, v)| v)
            .sum();
        low / p.iter().sum::<f64>()
    }

    #[test]
    fn issue_15_a_scrape_has_no_dc_drift_from_the_friction_force() {
        // A low mode (40 Hz, as sampled statistics can hold) and a start–stop trajectory: the
        // always-positive friction term deflected it statically (14 % below 5 Hz).
        let fs = 48_000.0;
        let surface = Surface::fractal(1 << 16, 1e-5, 2.0, 5e-6, 3).unwrap();
        let modes: Vec<BankMode> = [40.0, 700.0, 2500.0]
            .iter()
            .map(|&f| BankMode {
                freq_hz: f,
                damping_per_s: 10.0,
                gain: 0.05,
            })
            .collect();
        let x = positions(&[(0.0, 0.0), (0.5, 0.1), (1.5, 0.5)], fs, 96_000);
        let f = scrape_force(&surface, &x, fs, &ScrapeParams::default());
        let y = scrape(&modes, &f, &x, fs, 4, 1).unwrap();
        let low = share_below(&y, fs, 5.0);
        assert!(low < 0.01, "{:.1} % below 5 Hz", 100.0 * low);
        assert!(share_below(&f, fs, 5.0) < 1e-3);
    }

    #[test]
    fn a_faster_scrape_is_louder_and_brighter() {
        let fs = 48_000.0;
        let surface = Surface::fractal(1 << 16, 1e-5, 2.0, 5e-6, 3).unwrap();
        let modes: Vec<BankMode> = [300.0, 900.0, 2100.0, 4700.0, 9800.0]
            .iter()
            .map(|&f| BankMode {
                freq_hz: f,
                damping_per_s: 30.0,
                gain: 0.05,
            })
            .collect();
        let render = |speed: f64| {
            let x: Vec<f64> = (0..24_000).map(|i| speed * i as f64 / fs).collect();
            let f = scrape_force(&surface, &x, fs, &ScrapeParams::default());
            scrape(&modes, &f, &x, fs, 4, 1).unwrap()
        };
        let (slow, fast) = (render(0.1), render(0.4));
        let rms = |x: &[f32]| {
            (x.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
        };
        assert!(
            rms(&fast) > 2.0 * rms(&slow),
            "{} {}",
            rms(&fast),
            rms(&slow)
        );
        let (c0, c1) = (centroid(&slow, fs), centroid(&fast, fs));
        eprintln!(
            "scrape: rms {:.3e} → {:.3e}, centroid {c0:.0} → {c1:.0} Hz",
            rms(&slow),
            rms(&fast)
        );
        assert!(c1 > 1.2 * c0, "centroid {c0} → {c1}");
    }

    #[test]
    fn quilting_is_level_continuous_and_keeps_the_roughness() {
        let base = Surface::fractal(1 << 14, 1e-5, 1.0, 5e-6, 9).unwrap();
        let q = Surface::quilt(&base.heights_m, 1e-5, 50_000, 2048, 4).unwrap();
        assert_eq!(q.heights_m.len(), 50_000);
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let r = rms(&q.heights_m) / rms(&base.heights_m);
        assert!((0.5..2.0).contains(&r), "{r}");
        // No jumps: the largest step is of the order of the source's.
        let step = |v: &[f64]| {
            v.windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .fold(0.0, f64::max)
        };
        assert!(step(&q.heights_m) < 3.0 * step(&base.heights_m));
        assert!(Surface::quilt(&base.heights_m[..100], 1e-5, 1000, 64, 1).is_err());
    }

    #[test]
    fn trajectories_interpolate_and_rest_at_the_ends() {
        let x = positions(&[(0.0, 0.0), (1.0, 0.5), (2.0, 0.5)], 10.0, 30);
        assert!((x[5] - 0.25).abs() < 1e-12);
        assert_eq!(x[15], 0.5);
        assert_eq!(x[29], 0.5);
        // A resting probe makes no force.
        let s = Surface::fractal(1024, 1e-5, 1.0, 1e-6, 1).unwrap();
        let f = scrape_force(&s, &vec![0.01; 100], 48_000.0, &ScrapeParams::default());
        assert!(f.iter().all(|&v| v == 0.0));
    }
}
