//! The forward model of Ren 2013 eqs. 6–12: from the eigenvalues λ⁰ of a modal model computed
//! with a reference material (γ₀ = E₀/ρ₀) and the modes' unit-impulse amplitudes a⁰ at the hit
//! point, to the damped sinusoids the object makes for Rayleigh damping (α, β), material ratio
//! γ = E/ρ and impulse strength σ:
//!
//! - λ = (γ/γ₀) λ⁰ (eq. 10: with ν fixed, K scales with E and M with ρ),
//! - d = (α + βλ)/2 (eq. 6),
//! - f = sqrt(λ − d²) / 2π (eq. 7); over-damped modes (λ ≤ d²) do not oscillate and are left out,
//! - a = σ a⁰ (eq. 11).
//!
//! Our a⁰ are the modal displacement amplitudes `φ·n / ω` of [`resound_core::ModalModel::gains`]
//! at the reference material; eq. 11 keeps them fixed while γ changes (the common factor
//! sqrt(γ₀/γ) that 1/ω would add is absorbed by σ), as the paper does.

use resound_core::DampedMode;

/// Rayleigh damping and material parameters: C = αM + βK, γ = E/ρ, amplitude scale σ.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RayleighParams {
    /// Mass-proportional damping α, 1/s.
    pub alpha: f64,
    /// Stiffness-proportional damping β, s.
    pub beta: f64,
    /// E/ρ in m²/s².
    pub gamma: f64,
    /// Amplitude scale σ (impulse strength and recording gain).
    pub sigma: f64,
}

impl RayleighParams {
    /// Whether every parameter is finite with α, β ≥ 0 and γ, σ > 0.
    pub fn is_valid(&self) -> bool {
        self.alpha.is_finite()
            && self.beta.is_finite()
            && self.alpha >= 0.0
            && self.beta >= 0.0
            && self.gamma > 0.0
            && self.gamma.is_finite()
            && self.sigma > 0.0
            && self.sigma.is_finite()
    }
}

/// Damped sinusoids of the modes `(λ⁰_j, a⁰_j)` (eigenvalues in rad²/s² at `gamma0`) for `p`;
/// modes that come out over-damped or at or above `max_freq_hz` are left out. Phases are 0: the
/// object is at rest and struck at t = 0. Sorted by frequency.
pub fn forward_modes(
    eigenvalues0: &[f64],
    gains0: &[f64],
    gamma0: f64,
    p: &RayleighParams,
    max_freq_hz: f64,
) -> Vec<DampedMode> {
    let decay = |_: usize, lambda: f64| 0.5 * (p.alpha + p.beta * lambda);
    resound_core::rayleigh::damped_modes(
        eigenvalues0,
        gains0,
        p.gamma / gamma0,
        p.sigma,
        &decay,
        max_freq_hz,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn modes_lie_on_the_rayleigh_circle_and_scale_with_gamma() {
        let lambda0: Vec<f64> = [300.0, 1200.0, 5000.0, 9000.0]
            .iter()
            .map(|f| (TAU * f).powi(2))
            .collect();
        let gains = [1e-6, -2e-6, 5e-7, 1e-7];
        let p = RayleighParams {
            alpha: 20.0,
            beta: 2e-7,
            gamma: 2.0e7,
            sigma: 3.0,
        };
        let modes = forward_modes(&lambda0, &gains, 1.0e7, &p, 1e9);
        assert_eq!(modes.len(), 4);
        // Eq. 8: ω² + (d − 1/β)² = (sqrt(1 − αβ)/β)².
        let r2 = (1.0 - p.alpha * p.beta) / (p.beta * p.beta);
        for m in &modes {
            let w = TAU * m.freq_hz;
            let lhs = w * w + (m.damping_per_s - 1.0 / p.beta).powi(2);
            assert!((lhs / r2 - 1.0).abs() < 1e-9, "{m:?}");
        }
        // Doubling γ multiplies λ by 2: undamped frequencies by √2.
        let undamped: Vec<f64> = modes
            .iter()
            .map(|m| ((TAU * m.freq_hz).powi(2) + m.damping_per_s.powi(2)).sqrt() / TAU)
            .collect();
        for (u, f0) in undamped.iter().zip([300.0, 1200.0, 5000.0, 9000.0]) {
            assert!((u / f0 - 2f64.sqrt()).abs() < 1e-9);
        }
        assert!((modes[1].amplitude - 6e-6).abs() < 1e-18);
        assert!((modes[1].phase_rad - std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn overdamped_and_out_of_band_modes_are_dropped() {
        let lambda0 = [(TAU * 100.0f64).powi(2), (TAU * 30_000.0f64).powi(2)];
        // α large enough to over-damp the 100 Hz mode (d = α/2 > ω).
        let p = RayleighParams {
            alpha: 2.0 * TAU * 150.0,
            beta: 0.0,
            gamma: 1.0,
            sigma: 1.0,
        };
        assert!(forward_modes(&lambda0, &[1.0, 1.0], 1.0, &p, 20_000.0).is_empty());
        let p = RayleighParams { alpha: 1.0, ..p };
        let m = forward_modes(&lambda0, &[1.0, 1.0], 1.0, &p, 20_000.0);
        assert_eq!(m.len(), 1);
        assert!((m[0].freq_hz - 100.0).abs() < 0.01);
        assert!(!RayleighParams { gamma: 0.0, ..p }.is_valid());
    }
}
