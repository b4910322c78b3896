//! Acoustic transfer per mode: the pressure a mode radiates to a point in the air.
//!
//! Each mode's field outside the object is a multipole expansion about the object's centre,
//! `p(x) = Σ_{l ≤ L} Σ_m c_lm h_l(k r) Y_lm(θ, φ)` (outgoing spherical Hankel functions of the
//! first kind for the `e^{-iωt}` convention, real orthonormal spherical harmonics), with the
//! coefficients fitted (by `resound_modal::radiation`) to the mode's surface normal velocity.
//! It holds near and far: it converges outside the smallest sphere about the centre that
//! holds the object (`radius_m`), and points inside that sphere are moved out to it.
//!
//! A mode's frequency changes with the material (λ ∝ E/ρ), and its field with the frequency, so
//! the coefficients are stored on one log-spaced frequency grid (`grid_start_hz · 2^{i/n}`) at
//! the grid points within ± `span` octaves of the mode's frequency when the model was solved;
//! [`AcousticTransfer::pressure`] interpolates the pressure's magnitude linearly in log-log
//! between the two grid points around the mode's actual frequency.
//!
//! Units: coefficients are pascal per (m/s) of *modal* normal velocity, i.e. for a surface
//! normal velocity `q̇ · (φ_j · n)` with `φ_j` the stored (mass-normalised) shape.

use num_complex::Complex64 as C64;

pub use crate::limits::{AIR_DENSITY_KG_M3, SPEED_OF_SOUND_M_S as SOUND_SPEED_M_S};

/// The multipole coefficients of one mode on the frequency grid.
#[derive(Clone, Debug, PartialEq)]
pub struct ModeTransfer {
    /// Grid index of the first stored point.
    pub first: u32,
    /// Expansion order L at each stored grid point.
    pub orders: Vec<u8>,
    /// Coefficients `c_lm` (Pa per m/s), real and imaginary parts interleaved, `(L + 1)²` per
    /// stored grid point at index `l² + l + m`, points concatenated.
    pub coeffs: Vec<f32>,
    /// The relative RMS misfit of the surface normal velocity at each stored point.
    /// It counts what radiates little too (a jump of the normal velocity across a sharp edge,
    /// detail finer than the sources' spacing): a box's modes fit to about 0.7 while their
    /// levels at mirrored points agree to 0.1 dB (median), so only a misfit near 1 (the fit
    /// explains almost nothing) is reported as a warning.
    pub residuals: Vec<f32>,
}

/// Acoustic transfer of every mode of a model (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct AcousticTransfer {
    /// Expansion centre (model coordinates, m).
    pub centre_m: [f64; 3],
    /// Radius of the sphere about the centre that holds the surface, m.
    pub radius_m: f64,
    /// Speed of sound the fit used, m/s.
    pub sound_speed_m_s: f64,
    /// Air density the fit used, kg/m³.
    pub air_density_kg_m3: f64,
    /// Frequency of grid point 0, Hz.
    pub grid_start_hz: f64,
    /// Grid points per octave.
    pub per_octave: u32,
    /// One entry per mode of the model, in its order.
    pub modes: Vec<ModeTransfer>,
}

/// Outgoing spherical Hankel functions `h_l⁽¹⁾(x) = j_l(x) + i y_l(x)` for `l = 0..out.len()`,
/// by upward recurrence (stable for `h`: its `y_l` part dominates where `j_l`'s is not).
/// `x > 0`.
pub fn spherical_hankel(x: f64, out: &mut [C64]) {
    if out.is_empty() {
        return;
    }
    let e = C64::new(x.cos(), x.sin());
    // h0 = -i e^{ix}/x ; h1 = -e^{ix}(x + i)/x²
    out[0] = C64::new(0.0, -1.0) * e / x;
    if out.len() > 1 {
        out[1] = -e * C64::new(x, 1.0) / (x * x);
    }
    for l in 1..out.len().saturating_sub(1) {
        out[l + 1] = out[l] * ((2 * l + 1) as f64 / x) - out[l - 1];
    }
}

/// Regular spherical Bessel functions `j_l(x)` for `l = 0..out.len()`: upward recurrence where
/// it is stable (`l < x`), Miller's downward recurrence normalised to `j_0` or `j_1` below.
pub fn spherical_bessel(x: f64, out: &mut [f64]) {
    let n = out.len();
    if n == 0 {
        return;
    }
    if x < 1e-8 {
        out.iter_mut().for_each(|v| *v = 0.0);
        out[0] = 1.0;
        return;
    }
    let (s, c) = (x.sin(), x.cos());
    let j0 = s / x;
    let j1 = s / (x * x) - c / x;
    // Downward from well above max(n, x).
    let start = n + 16 + x as usize;
    let (mut hi, mut mid) = (0.0f64, 1e-300f64);
    let mut down = vec![0.0; n];
    for l in (1..=start).rev() {
        let lo = (2 * l + 1) as f64 / x * mid - hi;
        hi = mid;
        mid = lo;
        if l - 1 < n {
            down[l - 1] = lo;
        }
        if mid.abs() > 1e250 {
            // rescale to stay finite
            hi *= 1e-250;
            mid *= 1e-250;
            down.iter_mut().for_each(|v| *v *= 1e-250);
        }
    }
    let norm = if j0.abs() >= j1.abs() || n < 2 {
        j0 / down[0]
    } else {
        j1 / down[1]
    };
    for l in 0..n {
        out[l] = down[l] * norm;
    }
    // Upward is exact where l < x: overwrite those.
    out[0] = j0;
    if n > 1 {
        out[1] = j1;
    }
    let mut l = 1;
    while l + 1 < n && ((l + 1) as f64) < x {
        out[l + 1] = (2 * l + 1) as f64 / x * out[l] - out[l - 1];
        l += 1;
    }
}

/// Real orthonormal spherical harmonics `Y_lm` of the unit direction `u` for `l ≤ l_max`,
/// at index `l² + l + m` (`m < 0`: the `sin |m| φ` ones). `out.len() ≥ (l_max + 1)²`.
pub fn real_spherical_harmonics(l_max: usize, u: [f64; 3], out: &mut [f64]) {
    let ct = u[2].clamp(-1.0, 1.0);
    let st = (u[0] * u[0] + u[1] * u[1]).sqrt();
    let phi = u[1].atan2(u[0]);
    let inv4pi = 1.0 / (4.0 * std::f64::consts::PI);
    // p̄_mm, then upward in l for each m.
    let mut pmm = inv4pi.sqrt();
    for m in 0..=l_max {
        if m > 0 {
            pmm *= ((2 * m + 1) as f64 / (2 * m) as f64).sqrt() * st;
        }
        let (cm, sm) = if m == 0 {
            (1.0, 0.0)
        } else {
            let a = m as f64 * phi;
            (
                std::f64::consts::SQRT_2 * a.cos(),
                std::f64::consts::SQRT_2 * a.sin(),
            )
        };
        let put = |out: &mut [f64], l: usize, p: f64| {
            out[l * l + l + m] = p * cm;
            if m > 0 {
                out[l * l + l - m] = p * sm;
            }
        };
        put(out, m, pmm);
        if m == l_max {
            break;
        }
        let mut p_prev = pmm;
        let mut p = ((2 * m + 3) as f64).sqrt() * ct * pmm;
        put(out, m + 1, p);
        for l in m + 2..=l_max {
            let (lf, mf) = (l as f64, m as f64);
            let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
            let b = (((lf - 1.0).powi(2) - mf * mf) / (4.0 * (lf - 1.0).powi(2) - 1.0)).sqrt();
            let next = a * (ct * p - b * p_prev);
            p_prev = p;
            p = next;
            put(out, l, p);
        }
    }
}

/// Scratch for evaluating fields without allocating: sized for an order.
#[derive(Clone, Debug, Default)]
pub struct FieldScratch {
    ylm: Vec<f64>,
    h: Vec<C64>,
}

impl FieldScratch {
    /// Scratch for expansions up to order `l_max`.
    pub fn new(l_max: usize) -> Self {
        Self {
            ylm: vec![0.0; (l_max + 1) * (l_max + 1)],
            h: vec![C64::new(0.0, 0.0); l_max + 2],
        }
    }
}

/// The multipole fields `h_l(k r) Y_lm(x̂)` at `x` (relative to the centre) for `l ≤ l_max`,
/// into `out` (`(l_max + 1)²`). Grows `scratch` if it is too small.
pub fn multipole_fields(
    l_max: usize,
    k: f64,
    x: [f64; 3],
    scratch: &mut FieldScratch,
    out: &mut [C64],
) {
    let n = (l_max + 1) * (l_max + 1);
    if scratch.ylm.len() < n || scratch.h.len() < l_max + 1 {
        *scratch = FieldScratch::new(l_max);
    }
    let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    let u = [x[0] / r, x[1] / r, x[2] / r];
    real_spherical_harmonics(l_max, u, &mut scratch.ylm);
    spherical_hankel(k * r, &mut scratch.h[..=l_max]);
    for l in 0..=l_max {
        for i in l * l..(l + 1) * (l + 1) {
            out[i] = scratch.h[l] * scratch.ylm[i];
        }
    }
}

/// Scratch of [`AcousticTransfer::factors_into`].
#[derive(Clone, Debug, Default)]
pub struct BatchScratch {
    ylm: Vec<f64>,
    h: Vec<C64>,
    valid: Vec<bool>,
}

impl BatchScratch {
    /// Scratch sized for `t` (so that evaluating it does not allocate).
    pub fn for_transfer(t: &AcousticTransfer) -> Self {
        let mut s = Self::default();
        let freqs: Vec<f64> = (0..t.modes.len())
            .map(|j| t.range_hz(j).map_or(0.0, |r| r.0))
            .collect();
        let mut out = vec![0.0; t.modes.len()];
        t.factors_into(
            &freqs,
            [
                t.centre_m[0],
                t.centre_m[1],
                t.centre_m[2] + 2.0 * t.radius_m,
            ],
            &mut s,
            &mut out,
        );
        s
    }
}

impl AcousticTransfer {
    /// Frequency of grid point `i`, Hz.
    pub fn grid_hz(&self, i: u32) -> f64 {
        self.grid_start_hz * (f64::from(i) / f64::from(self.per_octave)).exp2()
    }

    /// The highest expansion order stored.
    pub fn max_order(&self) -> usize {
        self.modes
            .iter()
            .flat_map(|m| m.orders.iter())
            .map(|&l| usize::from(l))
            .max()
            .unwrap_or(0)
    }

    /// The frequency range (Hz) over which mode `j`'s transfer is stored.
    pub fn range_hz(&self, j: usize) -> Option<(f64, f64)> {
        let m = self.modes.get(j)?;
        let n = m.orders.len() as u32;
        (n > 0).then(|| (self.grid_hz(m.first), self.grid_hz(m.first + n - 1)))
    }

    /// The point where fields are evaluated for `x`: `x` itself outside the enclosing sphere,
    /// else moved out to it along the same direction (the expansion diverges inside).
    fn evaluation_point(&self, x: [f64; 3]) -> [f64; 3] {
        let mut d = [0.0; 3];
        for c in 0..3 {
            d[c] = x[c] - self.centre_m[c];
        }
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if r >= self.radius_m {
            d
        } else if r > 0.0 {
            d.map(|v| v * self.radius_m / r)
        } else {
            [0.0, 0.0, self.radius_m]
        }
    }

    /// Complex pressure (Pa per m/s of modal velocity) of mode `j` at its stored grid point
    /// `p` (0-based within the mode's points), at `x` (model coordinates, m).
    pub fn grid_pressure(
        &self,
        j: usize,
        p: usize,
        x: [f64; 3],
        scratch: &mut FieldScratch,
    ) -> C64 {
        let m = &self.modes[j];
        let mut off = 0;
        for &l in &m.orders[..p] {
            off += (usize::from(l) + 1).pow(2);
        }
        let l_max = usize::from(m.orders[p]);
        let k =
            2.0 * std::f64::consts::PI * self.grid_hz(m.first + p as u32) / self.sound_speed_m_s;
        let d = self.evaluation_point(x);
        let n = (l_max + 1) * (l_max + 1);
        if scratch.ylm.len() < n || scratch.h.len() < l_max + 1 {
            *scratch = FieldScratch::new(l_max);
        }
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        real_spherical_harmonics(l_max, d.map(|v| v / r), &mut scratch.ylm);
        spherical_hankel(k * r, &mut scratch.h[..=l_max]);
        let mut sum = C64::new(0.0, 0.0);
        for l in 0..=l_max {
            let mut s = C64::new(0.0, 0.0);
            for i in l * l..(l + 1) * (l + 1) {
                let c = C64::new(
                    f64::from(m.coeffs[2 * (off + i)]),
                    f64::from(m.coeffs[2 * (off + i) + 1]),
                );
                s += c * scratch.ylm[i];
            }
            sum += s * scratch.h[l];
        }
        sum
    }

    /// |p| (Pa per m/s of modal velocity) of mode `j` sounding at `freq_hz`, at `x` (model
    /// coordinates, m): log-log interpolation between the grid points around `freq_hz`, or the
    /// nearest end point outside the stored range (see [`AcousticTransfer::range_hz`]).
    /// `None` for a mode without a stored transfer.
    pub fn pressure(
        &self,
        j: usize,
        freq_hz: f64,
        x: [f64; 3],
        scratch: &mut FieldScratch,
    ) -> Option<f64> {
        let m = self.modes.get(j)?;
        let n = m.orders.len();
        if n == 0 || !(freq_hz > 0.0) {
            return None;
        }
        let pos =
            f64::from(self.per_octave) * (freq_hz / self.grid_start_hz).log2() - f64::from(m.first);
        if pos <= 0.0 || n == 1 {
            return Some(self.grid_pressure(j, 0, x, scratch).norm());
        }
        if pos >= (n - 1) as f64 {
            return Some(self.grid_pressure(j, n - 1, x, scratch).norm());
        }
        let i = pos.floor() as usize;
        let t = pos - i as f64;
        let a = self.grid_pressure(j, i, x, scratch).norm().max(1e-300);
        let b = self.grid_pressure(j, i + 1, x, scratch).norm().max(1e-300);
        Some((a.ln() * (1.0 - t) + b.ln() * t).exp())
    }

    /// The dimensionless radiation factor of mode `j` at `x`: `ω |p| r / (ρ c²)` with `r` the
    /// distance from the centre. Multiplied onto a mode's displacement gain (m per N·s) it gives
    /// the pressure × distance per N·s in units of `ρ c²` — so that the spatializer's `1/r` and
    /// delay still apply, and a compact pulsating sphere of radius a has factor ≈ (ka)².
    pub fn factor(
        &self,
        j: usize,
        freq_hz: f64,
        x: [f64; 3],
        scratch: &mut FieldScratch,
    ) -> Option<f64> {
        let p = self.pressure(j, freq_hz, x, scratch)?;
        let d = self.evaluation_point(x);
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let w = 2.0 * std::f64::consts::PI * freq_hz;
        Some(w * p * r / (self.air_density_kg_m3 * self.sound_speed_m_s.powi(2)))
    }

    /// The transfer of the same object whose shapes were scaled by `s` (a new density:
    /// [`crate::ModalModel::rescaled`]): the field is linear in the normal velocity.
    pub fn scaled(&self, s: f32) -> AcousticTransfer {
        let mut t = self.clone();
        for m in &mut t.modes {
            for c in &mut m.coeffs {
                *c *= s;
            }
        }
        t
    }

    /// Every mode's factor ([`AcousticTransfer::factor`]) at `x` when mode j sounds at
    /// `freqs_hz[j]`, into `out` (0 for a mode without a stored transfer). The harmonics of the
    /// direction are computed once and the Hankel functions once per grid point, so this costs
    /// about two dot products of `(L + 1)²` terms per mode. Allocates only when `batch` is
    /// smaller than this transfer needs.
    pub fn factors_into(
        &self,
        freqs_hz: &[f64],
        x: [f64; 3],
        batch: &mut BatchScratch,
        out: &mut [f64],
    ) {
        let l_top = self.max_order();
        let n = (l_top + 1) * (l_top + 1);
        if batch.ylm.len() < n {
            batch.ylm = vec![0.0; n];
        }
        let d = self.evaluation_point(x);
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        real_spherical_harmonics(l_top, d.map(|v| v / r), &mut batch.ylm);
        let top_grid = self
            .modes
            .iter()
            .map(|m| m.first as usize + m.orders.len())
            .max()
            .unwrap_or(0);
        if batch.h.len() < top_grid * (l_top + 1) || batch.valid.len() < top_grid {
            batch.h = vec![C64::new(0.0, 0.0); top_grid * (l_top + 1)];
            batch.valid = vec![false; top_grid];
        }
        batch.valid.iter_mut().for_each(|v| *v = false);
        let rho_c2 = self.air_density_kg_m3 * self.sound_speed_m_s.powi(2);
        for (j, (o, &f)) in out.iter_mut().zip(freqs_hz).enumerate() {
            *o = 0.0;
            let Some(m) = self.modes.get(j) else { continue };
            let np = m.orders.len();
            if np == 0 || !(f > 0.0) {
                continue;
            }
            let pos =
                f64::from(self.per_octave) * (f / self.grid_start_hz).log2() - f64::from(m.first);
            let (i0, t) = if pos <= 0.0 || np == 1 {
                (0, 0.0)
            } else if pos >= (np - 1) as f64 {
                (np - 1, 0.0)
            } else {
                (pos.floor() as usize, pos - pos.floor())
            };
            let mut mags = [0.0f64; 2];
            let mut off: usize = m.orders[..i0]
                .iter()
                .map(|&l| (usize::from(l) + 1).pow(2))
                .sum();
            for (k, mag) in mags.iter_mut().enumerate() {
                let p = i0 + k;
                if p >= np || (k == 1 && t == 0.0) {
                    break;
                }
                let g = m.first as usize + p;
                let l_max = usize::from(m.orders[p]);
                let h = &mut batch.h[g * (l_top + 1)..(g + 1) * (l_top + 1)];
                if !batch.valid[g] {
                    let kk =
                        2.0 * std::f64::consts::PI * self.grid_hz(g as u32) / self.sound_speed_m_s;
                    spherical_hankel(kk * r, h);
                    batch.valid[g] = true;
                }
                let mut sum = C64::new(0.0, 0.0);
                for l in 0..=l_max {
                    let (mut re, mut im) = (0.0, 0.0);
                    for i in l * l..(l + 1) * (l + 1) {
                        let y = batch.ylm[i];
                        re += f64::from(m.coeffs[2 * (off + i)]) * y;
                        im += f64::from(m.coeffs[2 * (off + i) + 1]) * y;
                    }
                    sum += C64::new(re, im) * h[l];
                }
                *mag = sum.norm().max(1e-300);
                off += (l_max + 1) * (l_max + 1);
            }
            let p = if t > 0.0 {
                (mags[0].ln() * (1.0 - t) + mags[1].ln() * t).exp()
            } else {
                mags[0]
            };
            *o = 2.0 * std::f64::consts::PI * f * p * r / rho_c2;
        }
    }

    /// The misfit of mode `j` where it sounds at `freq_hz` (the larger of the two grid points
    /// around it, or the nearest end point).
    pub fn misfit_at(&self, j: usize, freq_hz: f64) -> Option<f32> {
        let m = self.modes.get(j)?;
        let n = m.residuals.len();
        if n == 0 || !(freq_hz > 0.0) {
            return None;
        }
        let pos =
            f64::from(self.per_octave) * (freq_hz / self.grid_start_hz).log2() - f64::from(m.first);
        let i = (pos.floor().max(0.0) as usize).min(n - 1);
        let k = (pos.ceil().max(0.0) as usize).min(n - 1);
        Some(m.residuals[i].max(m.residuals[k]))
    }

    /// Bytes the coefficients take.
    pub fn coeff_bytes(&self) -> usize {
        self.modes.iter().map(|m| m.coeffs.len() * 4).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hankel_functions_match_closed_forms() {
        for &x in &[0.05, 0.7, 3.0, 20.0] {
            let mut h = [C64::new(0.0, 0.0); 4];
            spherical_hankel(x, &mut h);
            let (s, c) = (f64::sin(x), f64::cos(x));
            // j2, y2 closed forms
            let j2 = (3.0 / (x * x) - 1.0) * s / x - 3.0 * c / (x * x);
            let y2 = -(3.0 / (x * x) - 1.0) * c / x - 3.0 * s / (x * x);
            assert!((h[0].re - s / x).abs() < 1e-12 * h[0].norm(), "{x}");
            assert!((h[0].im + c / x).abs() < 1e-12 * h[0].norm(), "{x}");
            assert!(
                (h[2].re - j2).abs() < 1e-9 * h[2].norm(),
                "{x} {} {j2}",
                h[2].re
            );
            assert!((h[2].im - y2).abs() < 1e-9 * h[2].norm(), "{x}");
        }
    }

    #[test]
    fn bessel_functions_match_closed_forms_and_series() {
        for &x in &[1e-3, 0.05, 0.7, 3.0, 14.0, 30.0] {
            let mut j = [0.0; 20];
            spherical_bessel(x, &mut j);
            let (s, c) = (f64::sin(x), f64::cos(x));
            let j2 = (3.0 / (x * x) - 1.0) * s / x - 3.0 * c / (x * x);
            assert!((j[0] - s / x).abs() < 1e-12, "{x}");
            assert!(
                (j[2] - j2).abs() < 1e-9 * (1.0 + j2.abs()),
                "{x}: {} vs {j2}",
                j[2]
            );
            // j_l(x) ≈ x^l / (2l+1)!! for small x
            if x < 0.1 {
                let dfact: f64 = (1..=19).step_by(2).map(|k| k as f64).product::<f64>() * 21.0;
                let approx = x.powi(10) / dfact;
                assert!(
                    (j[10] / approx - 1.0).abs() < 1e-2,
                    "{x}: {} vs {approx}",
                    j[10]
                );
            }
            // the Wronskian-like identity j_{l-1} + j_{l+1} = (2l+1)/x j_l
            for l in 1..19 {
                let lhs = j[l - 1] + j[l + 1];
                let rhs = (2 * l + 1) as f64 / x * j[l];
                assert!(
                    (lhs - rhs).abs() <= 1e-8 * (lhs.abs() + rhs.abs()) + 1e-300,
                    "{x} {l}"
                );
            }
        }
    }

    #[test]
    fn spherical_harmonics_are_orthonormal() {
        // Gauss-free check: a fine (θ, φ) midpoint grid.
        let l_max = 6;
        let n = (l_max + 1) * (l_max + 1);
        let (nt, np) = (200, 400);
        let mut gram = vec![0.0; n * n];
        let mut y = vec![0.0; n];
        for it in 0..nt {
            let t = (it as f64 + 0.5) * std::f64::consts::PI / nt as f64;
            for ip in 0..np {
                let p = (ip as f64 + 0.5) * 2.0 * std::f64::consts::PI / np as f64;
                let u = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
                real_spherical_harmonics(l_max, u, &mut y);
                let w = t.sin()
                    * (std::f64::consts::PI / nt as f64)
                    * (2.0 * std::f64::consts::PI / np as f64);
                for a in 0..n {
                    for b in 0..n {
                        gram[a * n + b] += w * y[a] * y[b];
                    }
                }
            }
        }
        for a in 0..n {
            for b in 0..n {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!(
                    (gram[a * n + b] - want).abs() < 1e-3,
                    "{a} {b} {}",
                    gram[a * n + b]
                );
            }
        }
        // Y_10 = sqrt(3/4π) cos θ
        real_spherical_harmonics(1, [0.0, 0.6, 0.8], &mut y);
        assert!((y[2] - (3.0 / (4.0 * std::f64::consts::PI)).sqrt() * 0.8).abs() < 1e-12);
    }
}
