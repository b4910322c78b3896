//! A moving body's radiation at the listener: each sounding mode's factor
//! ([`AcousticTransfer::factor`]) recomputed when the listener, seen from the body, has moved
//! enough to change it, for the physics side of a scene to send as a
//! [`crate::scene_audio::Cue::Radiation`].
//!
//! The factors scale a mode's force as it enters (like air absorption): a mode keeps the
//! directivity of the pose it was excited in while it rings, and takes the new one with the next
//! force. Continuous contacts (rolling, sliding) excite every step, so they follow the pose
//! step by step; a body that tumbles while it rings freely keeps the directivity of its last
//! impact.

use resound_core::radiation::BatchScratch;
use resound_core::AcousticTransfer;
use std::sync::Arc;

/// Smallest change of the listener's direction (seen from the body's transfer centre) that
/// recomputes the factors, rad (1°: an order-20 lobe is about 9° wide).
pub const MIN_TURN_RAD: f64 = 1.0 * std::f64::consts::PI / 180.0;
/// Smallest relative change of the listener's distance that recomputes the factors (the near
/// field changes with distance; the far field does not).
pub const MIN_DISTANCE_CHANGE: f64 = 0.02;

/// The factors of one body's sounding modes at a listener given in the body's frame.
#[derive(Clone, Debug)]
pub struct Radiator {
    transfer: Arc<AcousticTransfer>,
    /// Per transfer mode: the frequency it sounds at (0: not sounding).
    freqs: Vec<f64>,
    /// Per sounding mode: its transfer mode.
    keep: Vec<usize>,
    all: Vec<f64>,
    factors: Vec<f32>,
    batch: BatchScratch,
    last: Option<[f64; 3]>,
}

impl Radiator {
    /// A body whose sounding modes are `modes`: (index of its transfer mode, frequency Hz).
    /// `None` when an index is not a mode of `transfer` or a frequency is not positive.
    pub fn new(transfer: Arc<AcousticTransfer>, modes: &[(usize, f64)]) -> Option<Self> {
        let n = transfer.modes.len();
        let mut freqs = vec![0.0; n];
        for &(j, f) in modes {
            if j >= n || !(f > 0.0 && f.is_finite()) {
                return None;
            }
            freqs[j] = f;
        }
        let batch = BatchScratch::for_transfer(&transfer);
        Some(Self {
            keep: modes.iter().map(|&(j, _)| j).collect(),
            all: vec![0.0; n],
            factors: vec![0.0; modes.len()],
            freqs,
            transfer,
            batch,
            last: None,
        })
    }

    /// The transfer.
    pub fn transfer(&self) -> &AcousticTransfer {
        &self.transfer
    }

    /// The factors last computed (one per sounding mode; zeros before the first update).
    pub fn factors(&self) -> &[f32] {
        &self.factors
    }

    /// Forgets the last position: the next [`Radiator::update`] recomputes (its factors could
    /// not be sent).
    pub fn invalidate(&mut self) {
        self.last = None;
    }

    /// The factors at `listener` (body frame, m) when it has turned by more than
    /// [`MIN_TURN_RAD`] or its distance changed by more than [`MIN_DISTANCE_CHANGE`] since the
    /// factors were last computed (always the first time); `None` otherwise, or for a
    /// non-finite position. Does not allocate.
    pub fn update(&mut self, listener: [f64; 3]) -> Option<&[f32]> {
        if !listener.iter().all(|v| v.is_finite()) {
            return None;
        }
        let c = self.transfer.centre_m;
        let d = [listener[0] - c[0], listener[1] - c[1], listener[2] - c[2]];
        if let Some(l) = self.last {
            let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let (r0, r1) = (norm(l), norm(d));
            let dot = (l[0] * d[0] + l[1] * d[1] + l[2] * d[2]) / (r0 * r1).max(1e-300);
            let turn = dot.clamp(-1.0, 1.0).acos();
            if turn <= MIN_TURN_RAD && (r1 - r0).abs() <= MIN_DISTANCE_CHANGE * r0 {
                return None;
            }
        }
        self.last = Some(d);
        self.transfer
            .factors_into(&self.freqs, listener, &mut self.batch, &mut self.all);
        for (f, &j) in self.factors.iter_mut().zip(&self.keep) {
            let v = self.all[j];
            *f = if v.is_finite() { v as f32 } else { 0.0 };
        }
        Some(&self.factors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::radiation::{FieldScratch, ModeTransfer};

    /// Two modes, stored at three grid points (1, 1.26, 1.59 kHz): a monopole (c₀₀ = 1) and a
    /// z-dipole (c₁₀ = 1), each field exact outside the 5 cm sphere.
    fn monopole_and_dipole() -> Arc<AcousticTransfer> {
        let mode = |index: usize| {
            let mut coeffs = vec![0.0f32; 3 * 4 * 2];
            for p in 0..3 {
                coeffs[p * 8 + 2 * index] = 1.0;
            }
            ModeTransfer {
                first: 0,
                orders: vec![1; 3],
                coeffs,
                residuals: vec![0.0; 3],
            }
        };
        Arc::new(AcousticTransfer {
            centre_m: [0.0, 0.1, 0.0],
            radius_m: 0.05,
            sound_speed_m_s: resound_core::limits::SPEED_OF_SOUND_M_S,
            air_density_kg_m3: resound_core::limits::AIR_DENSITY_KG_M3,
            grid_start_hz: 1000.0,
            per_octave: 3,
            modes: vec![mode(0), mode(2)],
        })
    }

    #[test]
    fn factors_follow_the_listener_seen_from_the_body() {
        let t = monopole_and_dipole();
        // Sounding: the dipole first at 1.1 kHz, then the monopole at 1.4 kHz.
        let mut r = Radiator::new(Arc::clone(&t), &[(1, 1100.0), (0, 1400.0)]).unwrap();
        assert!(r.factors().iter().all(|&f| f == 0.0));
        let c = t.centre_m;
        let at =
            |theta: f64, dist: f64| [c[0] + dist * theta.sin(), c[1], c[2] + dist * theta.cos()];
        let on_axis = r.update(at(0.0, 2.0)).unwrap().to_vec();
        // Each factor is the single-mode evaluation, in the sounding order.
        let mut s = FieldScratch::default();
        let want_dipole = t.factor(1, 1100.0, at(0.0, 2.0), &mut s).unwrap();
        let want_monopole = t.factor(0, 1400.0, at(0.0, 2.0), &mut s).unwrap();
        assert!((f64::from(on_axis[0]) / want_dipole - 1.0).abs() < 1e-5);
        assert!((f64::from(on_axis[1]) / want_monopole - 1.0).abs() < 1e-5);
        assert!(on_axis.iter().all(|&f| f > 0.0));
        // Half a degree and 1 % farther: nothing to send.
        assert!(r.update(at(0.5f64.to_radians(), 2.02)).is_none());
        // 60° off the dipole's axis: the dipole falls to cos 60° = 1/2, the monopole stays.
        let off = r.update(at(60f64.to_radians(), 2.0)).unwrap().to_vec();
        assert!(
            (off[0] / on_axis[0] - 0.5).abs() < 1e-4,
            "dipole {} → {}",
            on_axis[0],
            off[0]
        );
        assert!((off[1] / on_axis[1] - 1.0).abs() < 1e-5);
        // Broadside: the dipole's null.
        let side = r.update(at(90f64.to_radians(), 2.0)).unwrap().to_vec();
        assert!(side[0] < 1e-5 * on_axis[0], "null {}", side[0]);
        // A distance change beyond 2 % recomputes, even straight out.
        assert!(r.update(at(90f64.to_radians(), 2.1)).is_some());
        // Not finite: nothing; invalidated: recomputed at the same place.
        assert!(r.update([f64::NAN, 0.0, 0.0]).is_none());
        assert!(r.update(at(90f64.to_radians(), 2.1)).is_none());
        r.invalidate();
        assert!(r.update(at(90f64.to_radians(), 2.1)).is_some());
    }

    #[test]
    fn modes_the_transfer_lacks_are_refused() {
        let t = monopole_and_dipole();
        assert!(Radiator::new(Arc::clone(&t), &[(2, 1000.0)]).is_none());
        assert!(Radiator::new(Arc::clone(&t), &[(0, 0.0)]).is_none());
        assert!(Radiator::new(Arc::clone(&t), &[(0, f64::NAN)]).is_none());
        assert!(Radiator::new(t, &[]).is_some());
    }
}
