//! Contact forces of impacts: the linear spring of Traer et al. 2019 (eq. 5) and Hertz contact.
//!
//! Both treat the impact as a frictionless normal collision of the impactor (mass `m₁`) with the
//! struck object (mass `m₂`, or immovable) at approaching speed `v`, through the reduced mass
//! `m = m₁m₂/(m₁+m₂)`. Without losses the bodies separate at the speed they met, so the impulse
//! is `J = 2mv` in both models.
//!
//! - **Spring** (Traer eq. 5): `F = kδ`, a half sine `F(t) = v√(km) sin(πt/τ)` lasting
//!   `τ = π√(m/k)`, whatever the speed.
//! - **Hertz**: `F = k_H δ^{3/2}` with `k_H = (4/3) E* √R` (sphere of radius `R` on a flat,
//!   `1/E* = (1−ν₁²)/E₁ + (1−ν₂²)/E₂`). The pulse is integrated numerically (RK4, 4000 steps per
//!   contact) and lasts `τ ≈ 2.94 δ_max / v`, `δ_max = (5mv²/(4k_H))^{2/5}`: faster impacts are
//!   shorter and brighter.
//!
//! The spring constant "determined by the materials" is taken as Hertz's secant stiffness at a
//! 1 m/s impact, `k = k_H √δ_max(1 m/s)`, so both models agree there.
//!
//! Pulses are sampled as the mean force over each sample interval, so the discrete impulse
//! `Σ F T` equals `J` exactly even for pulses shorter than a sample (the impulse limit).

use crate::SynthError;

/// Elastic constants of one side of a contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    /// Young's modulus, Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio.
    pub poisson_ratio: f64,
}

/// Which force law (named `spring`, `hertz`, `impulse` in files and on the command line).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactModel {
    /// Linear spring: half sine, duration independent of speed (Traer eq. 5).
    Spring,
    /// Hertz contact: duration ∝ v^(−1/5).
    Hertz,
    /// An ideal impulse (one sample).
    Impulse,
}

/// The longest contact an impact may have, s.
pub const MAX_CONTACT_S: f64 = 1.0;

/// An impact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Impact {
    /// Impactor mass, kg.
    pub impactor_mass_kg: f64,
    /// Impactor radius of curvature at the contact, m.
    pub impactor_radius_m: f64,
    /// Impactor elastic constants.
    pub impactor: Elastic,
    /// Struck object elastic constants.
    pub object: Elastic,
    /// Struck object mass, kg (`None`: immovable).
    pub object_mass_kg: Option<f64>,
    /// Approaching normal speed, m/s.
    pub speed_m_s: f64,
}

impl Impact {
    fn check(&self) -> Result<(), SynthError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let ok = pos(self.impactor_mass_kg)
            && pos(self.impactor_radius_m)
            && pos(self.impactor.youngs_modulus)
            && pos(self.object.youngs_modulus)
            && (0.0..0.5).contains(&self.impactor.poisson_ratio)
            && (0.0..0.5).contains(&self.object.poisson_ratio)
            && self.object_mass_kg.is_none_or(pos)
            && self.speed_m_s.is_finite()
            && self.speed_m_s >= 0.0
            && self.speed_m_s < 1000.0;
        if ok {
            Ok(())
        } else {
            Err(SynthError::Parameter(format!(
                "impact parameters out of range (masses, radius, moduli > 0; 0 ≤ ν < 0.5; 0 ≤ speed < 1000 m/s): impactor {} kg, radius {} m, E {} Pa and ν {} against E {} Pa and ν {}, speed {} m/s",
                self.impactor_mass_kg,
                self.impactor_radius_m,
                self.impactor.youngs_modulus,
                self.impactor.poisson_ratio,
                self.object.youngs_modulus,
                self.object.poisson_ratio,
                self.speed_m_s
            )))
        }
    }

    /// Reduced mass, kg.
    pub fn reduced_mass_kg(&self) -> f64 {
        match self.object_mass_kg {
            Some(m2) => self.impactor_mass_kg * m2 / (self.impactor_mass_kg + m2),
            None => self.impactor_mass_kg,
        }
    }

    /// Hertz constant k_H (N/m^1.5).
    pub fn hertz_constant(&self) -> f64 {
        let inv = (1.0 - self.impactor.poisson_ratio.powi(2)) / self.impactor.youngs_modulus
            + (1.0 - self.object.poisson_ratio.powi(2)) / self.object.youngs_modulus;
        4.0 / 3.0 / inv * self.impactor_radius_m.sqrt()
    }

    /// Hertz maximum compression at speed `v`, m.
    pub fn hertz_max_compression_m(&self, v: f64) -> f64 {
        (1.25 * self.reduced_mass_kg() * v * v / self.hertz_constant()).powf(0.4)
    }

    /// The linear spring constant (N/m): Hertz's secant stiffness at a 1 m/s impact.
    pub fn spring_constant(&self) -> f64 {
        self.hertz_constant() * self.hertz_max_compression_m(1.0).sqrt()
    }

    /// Impulse J = 2 m v, N·s.
    pub fn impulse_n_s(&self) -> f64 {
        2.0 * self.reduced_mass_kg() * self.speed_m_s
    }

    /// Contact duration of `model` at this speed, s.
    pub fn duration_s(&self, model: ContactModel) -> f64 {
        match model {
            ContactModel::Spring => {
                std::f64::consts::PI * (self.reduced_mass_kg() / self.spring_constant()).sqrt()
            }
            ContactModel::Hertz => {
                if self.speed_m_s > 0.0 {
                    2.943_5 * self.hertz_max_compression_m(self.speed_m_s) / self.speed_m_s
                } else {
                    0.0
                }
            }
            ContactModel::Impulse => 0.0,
        }
    }

    /// The force pulse sampled at `sample_rate_hz` (mean force per sample interval, N), from
    /// the instant of contact `offset_s` (0 ≤ offset < 1 sample) into sample 0.
    pub fn force_pulse(
        &self,
        model: ContactModel,
        sample_rate_hz: f64,
        offset_s: f64,
    ) -> Result<Vec<f32>, SynthError> {
        self.check()?;
        let t = 1.0 / sample_rate_hz;
        if !(offset_s >= 0.0 && offset_s < t) {
            return Err(SynthError::Parameter(format!(
                "contact offset {offset_s} s must lie within one sample"
            )));
        }
        let j = self.impulse_n_s();
        if j == 0.0 {
            return Ok(Vec::new());
        }
        let tau = self.duration_s(model);
        // A contact of more than a second is no impact (a 1e20 kg impactor asked for 33 GB of
        // pulse): refused before anything is sized by it.
        if !(tau <= MAX_CONTACT_S) {
            return Err(SynthError::Parameter(format!(
                "the contact would last {tau:.3e} s (impactor {:.3e} kg, radius {:.3e} m at {} m/s): more than {MAX_CONTACT_S} s is no impact",
                self.impactor_mass_kg, self.impactor_radius_m, self.speed_m_s
            )));
        }
        if model == ContactModel::Impulse || tau < 1e-3 * t {
            return Ok(vec![(j / t) as f32]);
        }
        // Cumulative impulse I(t) on a fine grid, then sample means = ΔI / T.
        let steps = 4000;
        let h = tau / steps as f64;
        let mut cumulative = Vec::with_capacity(steps + 1);
        cumulative.push(0.0);
        match model {
            ContactModel::Spring => {
                for i in 1..=steps {
                    let s = i as f64 * h;
                    // ∫₀ˢ F_max sin(πt/τ) dt
                    cumulative.push(j * 0.5 * (1.0 - (std::f64::consts::PI * s / tau).cos()));
                }
            }
            ContactModel::Hertz => {
                // Hertz pulses are one shape scaled in time and force: the cumulative impulse
                // of the unit problem (m = k = v = 1), tabulated once, stretched to τ.
                let unit = hertz_unit_curve();
                let h = tau / (unit.len() - 1) as f64;
                let cumulative: Vec<f64> = unit.iter().map(|c| c * j).collect();
                return Ok(sample_means(&cumulative, h, offset_s, t));
            }
            ContactModel::Impulse => {}
        }
        Ok(sample_means(&cumulative, h, offset_s, t))
    }
}

/// The cumulative impulse of the unit Hertz problem `δ'' = −δ^{3/2}`, `δ(0) = 0`, `δ'(0) = 1`,
/// normalized to 1 at separation, on 4001 points evenly spaced over the contact (RK4 with 20
/// substeps per point, once per process).
fn hertz_unit_curve() -> &'static [f64] {
    static CURVE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    CURVE.get_or_init(|| {
        let points = 4001;
        let dmax = 1.25f64.powf(0.4);
        let tau = 2.943_5 * dmax;
        let sub = 20;
        let h = tau / ((points - 1) * sub) as f64;
        let acc = |d: f64| -d.max(0.0).powf(1.5);
        let (mut d, mut u) = (0.0f64, 1.0f64);
        let mut out = Vec::with_capacity(points);
        out.push(0.0);
        for _ in 1..points {
            for _ in 0..sub {
                let (k1d, k1u) = (u, acc(d));
                let (k2d, k2u) = (u + 0.5 * h * k1u, acc(d + 0.5 * h * k1d));
                let (k3d, k3u) = (u + 0.5 * h * k2u, acc(d + 0.5 * h * k2d));
                let (k4d, k4u) = (u + h * k3u, acc(d + h * k3d));
                d += h / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d);
                u += h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
            }
            // Impulse so far m(v − u) with m = v = 1, of the total 2.
            out.push(if d <= 0.0 {
                1.0
            } else {
                ((1.0 - u) / 2.0).min(1.0)
            });
        }
        let last = out[points - 1];
        if last > 0.0 {
            out.iter_mut().for_each(|c| *c /= last);
        }
        out
    })
}

/// Mean force per sample from a cumulative impulse on a grid of step `h` starting at `offset`.
fn sample_means(cumulative: &[f64], h: f64, offset: f64, t: f64) -> Vec<f32> {
    let end = offset + (cumulative.len() - 1) as f64 * h;
    let n = (end / t).ceil() as usize;
    let at = |time: f64| -> f64 {
        let x = (time - offset) / h;
        if x <= 0.0 {
            return 0.0;
        }
        let i = x as usize;
        if i + 1 >= cumulative.len() {
            return cumulative[cumulative.len() - 1];
        }
        let f = x - i as f64;
        cumulative[i] + f * (cumulative[i + 1] - cumulative[i])
    };
    (0..n)
        .map(|k| ((at((k + 1) as f64 * t) - at(k as f64 * t)) / t) as f32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel_ball_on_glass(speed: f64) -> Impact {
        Impact {
            impactor_mass_kg: 0.0041,
            impactor_radius_m: 0.005,
            impactor: Elastic {
                youngs_modulus: 200e9,
                poisson_ratio: 0.29,
            },
            object: Elastic {
                youngs_modulus: 70e9,
                poisson_ratio: 0.22,
            },
            object_mass_kg: None,
            speed_m_s: speed,
        }
    }

    #[test]
    fn impulse_is_two_m_v_and_spring_lasts_pi_sqrt_m_over_k() {
        let fs = 192_000.0;
        let imp = steel_ball_on_glass(1.3);
        for model in [
            ContactModel::Spring,
            ContactModel::Hertz,
            ContactModel::Impulse,
        ] {
            let p = imp.force_pulse(model, fs, 0.3 / fs).unwrap();
            let j: f64 = p.iter().map(|&f| f64::from(f) / fs).sum();
            assert!((j / imp.impulse_n_s() - 1.0).abs() < 1e-5, "{model:?}: {j}");
        }
        let tau = imp.duration_s(ContactModel::Spring);
        let want = std::f64::consts::PI * (imp.reduced_mass_kg() / imp.spring_constant()).sqrt();
        assert!((tau - want).abs() < 1e-15);
        // The spring's pulse is a half sine: peak F = v √(k m) = π J / (2τ).
        let p = imp.force_pulse(ContactModel::Spring, 10.0e6, 0.0).unwrap();
        let peak = p.iter().copied().fold(0.0f32, f32::max) as f64;
        let want = imp.speed_m_s * (imp.spring_constant() * imp.reduced_mass_kg()).sqrt();
        assert!((peak / want - 1.0).abs() < 1e-3, "{peak} vs {want}");
    }

    #[test]
    fn hertz_duration_matches_theory_and_shrinks_with_speed() {
        let fs = 10.0e6;
        for v in [0.1, 1.0, 5.0] {
            let imp = steel_ball_on_glass(v);
            let p = imp.force_pulse(ContactModel::Hertz, fs, 0.0).unwrap();
            let nonzero = p.iter().filter(|&&f| f > 0.0).count() as f64 / fs;
            let want = imp.duration_s(ContactModel::Hertz);
            assert!(
                (nonzero / want - 1.0).abs() < 0.01,
                "v {v}: {nonzero} vs {want}"
            );
        }
        let slow = steel_ball_on_glass(0.1).duration_s(ContactModel::Hertz);
        let fast = steel_ball_on_glass(3.2).duration_s(ContactModel::Hertz);
        assert!((slow / fast - 32f64.powf(0.2)).abs() < 1e-9);
        // Both laws agree at 1 m/s by construction (same peak compression and impulse).
        let one = steel_ball_on_glass(1.0);
        let (s, h) = (
            one.duration_s(ContactModel::Spring),
            one.duration_s(ContactModel::Hertz),
        );
        assert!((s / h - 1.0).abs() < 0.1, "{s} {h}");
    }

    #[test]
    fn bad_parameters_are_errors() {
        let mut imp = steel_ball_on_glass(1.0);
        imp.impactor_mass_kg = -1.0;
        assert!(imp.force_pulse(ContactModel::Spring, 48000.0, 0.0).is_err());
        let imp = steel_ball_on_glass(f64::NAN);
        assert!(imp.force_pulse(ContactModel::Hertz, 48000.0, 0.0).is_err());
        let imp = steel_ball_on_glass(1.0);
        assert!(imp.force_pulse(ContactModel::Hertz, 48000.0, 1.0).is_err());
    }
}
