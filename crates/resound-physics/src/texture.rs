//! Fractal surface profiles: 1/f^β noise over distance, unit RMS, read by arc length.

/// Profile samples per metre (0.1 mm resolution).
pub const SAMPLES_PER_M: f64 = 10_000.0;

/// A periodic 1/f^β profile of `len` samples (a power of two), unit RMS, as f32
/// ([`resound_synth::scrape::fractal_profile`]).
pub fn fractal_profile(len: usize, beta: f64, seed: u64) -> Vec<f32> {
    resound_synth::scrape::fractal_profile(len, beta, seed).map_or_else(
        |_| vec![0.0; len],
        |p| p.iter().map(|&v| v as f32).collect(),
    )
}

/// Linear interpolation of the periodic `profile` at arc length `s` metres.
#[inline]
pub fn at(profile: &[f32], s: f64) -> f32 {
    let x = s * SAMPLES_PER_M;
    let n = profile.len();
    let i = x.floor();
    let f = (x - i) as f32;
    let i = (i as i64).rem_euclid(n as i64) as usize;
    let j = (i + 1) % n;
    profile[i] + f * (profile[j] - profile[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_is_unit_rms_and_pink() {
        let p = fractal_profile(1 << 14, 1.0, 3);
        let rms = (p.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / p.len() as f64).sqrt();
        assert!((rms - 1.0).abs() < 1e-4);
        // 1/f: the first differences carry much less power than the values (white noise: 2×).
        let d: f64 = p
            .windows(2)
            .map(|w| f64::from(w[1] - w[0]).powi(2))
            .sum::<f64>()
            / p.len() as f64;
        assert!(d < 0.5, "{d}");
        assert_eq!(at(&p, 0.0), p[0]);
    }
}
