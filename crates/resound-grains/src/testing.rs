//! Test signals shared by the unit tests.

use rand::Rng;

/// A decaying event: a few partials and a noise burst, distinct per `k`.
pub(crate) fn event(k: usize, len: usize, fs: f64, rng: &mut impl Rng) -> Vec<f32> {
    let f0 = 300.0 * (1.0 + k as f64 * 0.37);
    (0..len)
        .map(|i| {
            let t = i as f64 / fs;
            let env = (-t * (40.0 + 10.0 * k as f64)).exp();
            let tonal = (1..4)
                .map(|h| (std::f64::consts::TAU * f0 * h as f64 * 1.13 * t).sin() / h as f64)
                .sum::<f64>();
            let noise = (rng.random::<f64>() - 0.5) * (-t * 400.0).exp();
            ((0.4 * tonal + 0.8 * noise) * env * (0.5 + 0.1 * k as f64)) as f32
        })
        .collect()
}
