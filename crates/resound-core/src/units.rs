//! Unit conversions, written once (STYLE.md §4).

use std::f64::consts::PI;

/// Angular frequency ω (rad/s) of a frequency in Hz.
pub fn omega(freq_hz: f64) -> f64 {
    2.0 * PI * freq_hz
}

/// Frequency in Hz of an angular frequency ω (rad/s).
pub fn freq_hz(omega: f64) -> f64 {
    omega / (2.0 * PI)
}

/// Frequency in Hz of an eigenvalue λ = ω² (rad²/s²). Negative round-off gives 0.
pub fn lambda_to_freq_hz(lambda: f64) -> f64 {
    freq_hz(lambda.max(0.0).sqrt())
}

/// Eigenvalue λ = ω² (rad²/s²) of a frequency in Hz.
pub fn freq_hz_to_lambda(freq_hz: f64) -> f64 {
    let w = omega(freq_hz);
    w * w
}

/// Rayleigh damping ratio ζ = (α + β·ω²) / (2ω) (dimensionless); α in 1/s, β in s, ω in rad/s.
pub fn rayleigh_zeta(alpha: f64, beta: f64, omega: f64) -> f64 {
    (alpha + beta * omega * omega) / (2.0 * omega)
}

/// Rayleigh amplitude decay rate (1/s): ζ·ω = (α + β·ω²) / 2.
pub fn rayleigh_decay(alpha: f64, beta: f64, omega: f64) -> f64 {
    0.5 * (alpha + beta * omega * omega)
}

/// Damped angular frequency ω_d = ω·√(1 − ζ²) (rad/s); 0 when over-damped (ζ ≥ 1).
pub fn damped_omega(omega: f64, zeta: f64) -> f64 {
    omega * (1.0 - zeta * zeta).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rayleigh_decay_is_zeta_times_omega() {
        for &(a, b, w) in &[(1.0, 1e-7, 100.0), (10.0, 3e-6, 5e4), (0.0, 1e-8, 1.0)] {
            let z = rayleigh_zeta(a, b, w);
            assert!((z * w - rayleigh_decay(a, b, w)).abs() <= 1e-12 * rayleigh_decay(a, b, w));
        }
    }

    #[test]
    fn lambda_freq_round_trip() {
        for f in [20.0, 440.0, 19_999.0] {
            assert!((lambda_to_freq_hz(freq_hz_to_lambda(f)) - f).abs() < 1e-9 * f);
        }
        assert_eq!(lambda_to_freq_hz(-1e-9), 0.0);
        assert!(damped_omega(10.0, 2.0) == 0.0);
    }
}
