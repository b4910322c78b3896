//! Continuous contact forces, one physics step at a time: sliding over a generic rough profile,
//! rolling (van den Doel et al. 2001 style: the same profile low-passed at a speed-dependent
//! cut-off, modulated by the rolling body's rotation), and scraping over a measured or
//! procedural surface texture (Traer 2019 eq. 8, [`crate::scrape`]). Impacts are
//! [`crate::excitation::Impact`] pulses.
//!
//! Each contact keeps a [`ContactForce`]: its position along the profile and the rolling
//! low-pass, so that consecutive steps join without clicks.

use crate::scrape::{scrape_force, ScrapeParams, Surface};

/// Roughness: sliding force per unit normal force at 1 m/s and unit profile.
pub const ROUGHNESS: f64 = 0.05;
/// Generic profile samples per metre (0.1 mm resolution).
pub const SAMPLES_PER_M: f64 = 10_000.0;
/// The longest hop, in samples, between the points where a rolling force is computed.
pub const ROLL_MAX_HOP: usize = 16;

/// A periodic unit-RMS 1/f profile read by arc length ([`crate::scrape::fractal_profile`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Profile(Vec<f32>);

impl Profile {
    /// A 1/f^β profile of `len` samples (a power of two) with `seed`.
    pub fn fractal(len: usize, beta: f64, seed: u64) -> Self {
        Self(crate::scrape::fractal_profile(len, beta, seed).map_or_else(
            |_| vec![0.0; len],
            |p| p.iter().map(|&v| v as f32).collect(),
        ))
    }

    /// Linear interpolation at arc length `s` metres (periodic).
    #[inline]
    pub fn at(&self, s: f64) -> f32 {
        let profile = &self.0;
        let x = s * SAMPLES_PER_M;
        let n = profile.len();
        // floor() without SSE4.1 is a libm call; this is the same for every finite x.
        let t = x as i64;
        let t = if (t as f64) > x { t - 1 } else { t };
        let i = t as f64;
        let f = (x - i) as f32;
        let (i, j) = if n.is_power_of_two() {
            // Two's complement: the mask is the Euclidean remainder, without a division.
            let i = (t as usize) & (n - 1);
            (i, (i + 1) & (n - 1))
        } else {
            let i = t.rem_euclid(n as i64) as usize;
            (i, (i + 1) % n)
        };
        profile[i] + f * (profile[j] - profile[i])
    }

    /// The samples.
    pub fn samples(&self) -> &[f32] {
        &self.0
    }
}

/// The state of one continuous contact.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactForce {
    /// Path travelled so far, m.
    pub path_m: f64,
    /// Where along the profile this contact started, m (decorrelates contacts).
    pub offset_m: f64,
    lowpass: [f64; 2],
    /// The rolling force at the end of the last step, N (where the next step's grid starts).
    last_roll: f64,
}

impl ContactForce {
    /// A contact starting at `offset_m` along the profile.
    pub fn new(offset_m: f64) -> Self {
        Self {
            offset_m,
            ..Self::default()
        }
    }

    /// Sliding: `F = μ_r F_n (v / 1 m/s) n(s)` along the profile, `out.len()` samples.
    pub fn sliding(
        &mut self,
        profile: &Profile,
        normal_force_n: f64,
        speed_m_s: f64,
        fs: f64,
        out: &mut [f32],
    ) {
        for f in out.iter_mut() {
            self.path_m += speed_m_s / fs;
            let x = f64::from(profile.at(self.path_m + self.offset_m));
            *f = (ROUGHNESS * normal_force_n * speed_m_s * x) as f32;
        }
    }

    /// Rolling: the profile low-passed at 50 Hz + 300 Hz per m/s (two one-pole stages) and
    /// modulated by the rotation of a body of radius `roll_radius_m` (its phase interpolated
    /// across the step), at a third of sliding's level (×8 for the low-pass's loss).
    ///
    /// The force has little content above the low-pass and the profile is read at `speed ·
    /// SAMPLES_PER_M` points a second, so it is computed on a grid 16 times finer than the
    /// low-pass and 4 times finer than the profile points (at most every [`ROLL_MAX_HOP`]
    /// samples: slow rolling, the common case, costs a sixteenth) and interpolated linearly in
    /// between, within 3 % RMS of computing every sample; fast rolling is computed every sample.
    pub fn rolling(
        &mut self,
        profile: &Profile,
        normal_force_n: f64,
        speed_m_s: f64,
        roll_radius_m: f64,
        fs: f64,
        out: &mut [f32],
    ) {
        self.rolling_on_grid(
            profile,
            normal_force_n,
            speed_m_s,
            roll_radius_m,
            fs,
            ROLL_MAX_HOP,
            out,
        );
    }

    #[allow(clippy::too_many_arguments)]
    fn rolling_on_grid(
        &mut self,
        profile: &Profile,
        normal_force_n: f64,
        speed_m_s: f64,
        roll_radius_m: f64,
        fs: f64,
        max_hop: usize,
        out: &mut [f32],
    ) {
        let n = out.len();
        if n == 0 {
            return;
        }
        let fc = 50.0 + 300.0 * speed_m_s;
        // The grid is 16 times finer than the low-pass and 4 times finer than the profile points.
        let band_hz = fc.max(speed_m_s * SAMPLES_PER_M / 4.0);
        let hop = (fs / (16.0 * band_hz)).floor().clamp(1.0, max_hop as f64) as usize;
        let points = n.div_ceil(hop);
        // Grid spacing in samples (the step's samples split evenly).
        let h = n as f64 / points as f64;
        let a = (-std::f64::consts::TAU * fc * h / fs).exp();
        let b = 1.0 - a;
        let rot0 = (self.path_m / roll_radius_m).sin();
        let rot1 = ((self.path_m + speed_m_s * n as f64 / fs) / roll_radius_m).sin();
        let level = ROUGHNESS / 3.0 * normal_force_n * speed_m_s * 8.0;
        let d_rot = (rot1 - rot0) / n as f64;
        let ds = speed_m_s / fs;
        let (mut l0, mut l1) = (self.lowpass[0], self.lowpass[1]);
        // Grid point j sits `u = j·h` samples after the previous step's last sample; output
        // sample k at u = k + 1.
        let mut previous = self.last_roll;
        let mut k0 = 0usize;
        for j in 1..=points {
            let u = j as f64 * h;
            let x = f64::from(profile.at(self.path_m + ds * u + self.offset_m));
            // `l += (1 − a)(x − l)` written so that the serial chain is one multiply-add.
            l0 = a * l0 + b * x;
            l1 = a * l1 + b * l0;
            let rotation = rot0 + d_rot * (u - 1.0);
            let y = level * l1 * (1.0 + 0.5 * rotation);
            let k1 = if j == points {
                n
            } else {
                (u.floor() as usize).min(n)
            };
            let u0 = u - h;
            for (k, f) in out.iter_mut().enumerate().take(k1).skip(k0) {
                let t = ((k + 1) as f64 - u0) / h;
                *f = (previous + t * (y - previous)) as f32;
            }
            previous = y;
            k0 = k1;
        }
        self.lowpass = [l0, l1];
        self.last_roll = previous;
        self.path_m += ds * n as f64;
    }

    /// Scraping a textured `surface` (Traer eq. 8: probe mass 0.1 g, shear coefficient
    /// `friction · F_n`, γ = 1, 0.2 mm tip) for `n` samples, with one sample of context on
    /// either side so steps join.
    pub fn scraping(
        &mut self,
        surface: &Surface,
        normal_force_n: f64,
        speed_m_s: f64,
        friction: f64,
        fs: f64,
        n: usize,
    ) -> Vec<f32> {
        let start = self.path_m + self.offset_m;
        let xs: Vec<f64> = (0..n + 2)
            .map(|j| start + speed_m_s * (j as f64 - 1.0) / fs)
            .collect();
        let p = ScrapeParams {
            probe_mass_kg: 1e-4,
            friction: friction * normal_force_n,
            gamma: 1.0,
            tip_width_m: 2e-4,
        };
        let f = scrape_force(surface, &xs, fs, &p);
        self.path_m += speed_m_s * n as f64 / fs;
        f[1..=n].to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_is_unit_rms_and_pink() {
        let p = Profile::fractal(1 << 14, 1.0, 3);
        let s = p.samples();
        let rms = (s.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / s.len() as f64).sqrt();
        assert!((rms - 1.0).abs() < 1e-4);
        // 1/f: the first differences carry much less power than the values (white noise: 2×).
        let d: f64 = s
            .windows(2)
            .map(|w| f64::from(w[1] - w[0]).powi(2))
            .sum::<f64>()
            / s.len() as f64;
        assert!(d < 0.5, "{d}");
        assert_eq!(p.at(0.0), s[0]);
    }

    #[test]
    fn sliding_grows_with_speed_and_steps_join() {
        let p = Profile::fractal(1 << 14, 1.0, 5);
        let fs = 48_000.0;
        let rms = |speed: f64| {
            let mut c = ContactForce::new(0.3);
            let mut out = vec![0.0f32; 4800];
            c.sliding(&p, 1.0, speed, fs, &mut out);
            (out.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / 4800.0).sqrt()
        };
        assert!(rms(1.0) > 1.5 * rms(0.5));
        // Two steps of 200 samples are the same as one of 400.
        let (mut a, mut b) = (ContactForce::new(0.1), ContactForce::new(0.1));
        let mut one = vec![0.0f32; 400];
        a.rolling(&p, 2.0, 0.3, 0.01, fs, &mut one);
        let mut two = vec![0.0f32; 400];
        let (x, y) = two.split_at_mut(200);
        b.rolling(&p, 2.0, 0.3, 0.01, fs, x);
        b.rolling(&p, 2.0, 0.3, 0.01, fs, y);
        let lp = |v: &[f32]| v.iter().map(|x| f64::from(*x).abs()).sum::<f64>();
        assert!(
            (lp(&one) - lp(&two)).abs() < 0.05 * lp(&one),
            "{} {}",
            lp(&one),
            lp(&two)
        );
    }

    #[test]
    fn slow_rolling_on_the_coarse_grid_matches_every_sample_and_joins_steps() {
        let p = Profile::fractal(1 << 14, 1.0, 7);
        let fs = 48_000.0;
        for speed in [0.05, 0.2, 1.5] {
            let render = |max_hop: usize| {
                let mut c = ContactForce::new(0.2);
                let mut out = vec![0.0f32; 48_000];
                // 60 steps of 800 samples, as a 60 Hz scene makes them.
                for step in out.chunks_mut(800) {
                    c.rolling_on_grid(&p, 3.0, speed, 0.02, fs, max_hop, step);
                }
                out
            };
            let (fine, coarse) = (render(1), render(ROLL_MAX_HOP));
            let rms = |v: &[f32]| {
                (v.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
            };
            // Past the first 0.1 s (the low-pass settling from rest) the two agree sample by
            // sample to a few per cent of the force's RMS.
            let err: Vec<f32> = fine[4800..]
                .iter()
                .zip(&coarse[4800..])
                .map(|(a, b)| a - b)
                .collect();
            let (level, e) = (rms(&fine[4800..]), rms(&err));
            assert!(
                level > 0.0 && e < 0.05 * level,
                "{speed} m/s: error {e} of {level}"
            );
            // No step at the step boundaries larger than the largest inside a step.
            let jump = |i: usize| (coarse[i] - coarse[i - 1]).abs();
            let at_edges = (1..60).map(|s| jump(s * 800)).fold(0.0f32, f32::max);
            let inside = (1..48_000)
                .filter(|i| i % 800 != 0)
                .map(jump)
                .fold(0.0f32, f32::max);
            assert!(
                at_edges <= 1.01 * inside,
                "{speed} m/s: {at_edges} vs {inside}"
            );
        }
    }
}
