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
    pub fn rolling(
        &mut self,
        profile: &Profile,
        normal_force_n: f64,
        speed_m_s: f64,
        roll_radius_m: f64,
        fs: f64,
        out: &mut [f32],
    ) {
        let n = out.len();
        let fc = 50.0 + 300.0 * speed_m_s;
        let a = (-std::f64::consts::TAU * fc / fs).exp();
        let rot0 = (self.path_m / roll_radius_m).sin();
        let rot1 = ((self.path_m + speed_m_s * n as f64 / fs) / roll_radius_m).sin();
        let level = ROUGHNESS / 3.0 * normal_force_n * speed_m_s * 8.0;
        let d_rot = (rot1 - rot0) / n.max(1) as f64;
        let ds = speed_m_s / fs;
        let (mut l0, mut l1) = (self.lowpass[0], self.lowpass[1]);
        for (k, f) in out.iter_mut().enumerate() {
            // The same path as adding `ds` each sample, without the serial dependency.
            let path = self.path_m + ds * (k + 1) as f64;
            let x = f64::from(profile.at(path + self.offset_m));
            l0 += (1.0 - a) * (x - l0);
            l1 += (1.0 - a) * (l0 - l1);
            let rotation = rot0 + d_rot * k as f64;
            *f = (level * l1 * (1.0 + 0.5 * rotation)) as f32;
        }
        self.lowpass = [l0, l1];
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
}
