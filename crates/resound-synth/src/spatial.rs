//! Placing sources at a listener: 1/r distance attenuation (1 at 1 m, capped at 10 cm), the
//! propagation delay r / 343 m/s, and an equal-power pan from the source's direction along x
//! (stereo) or a first-order ambisonic encoding (B-format, AmbiX), with an optional floor
//! reflection (an image source) — the mixer of scenes, offline and live alike.
//!
//! A source's block is added into per-channel delay rings at its delay; [`Spatializer::render`]
//! reads the next samples out. Additions happen in the order sources are placed, so the result
//! is the same, sample for sample, as adding each block straight into a whole-length output at
//! its delayed position. `new` allocates; `place` and `render` do not.

use crate::SynthError;

/// Speed of sound, m/s.
pub const SPEED_OF_SOUND_M_S: f64 = 343.0;

/// A listener with one or two output channels and a delay ring per channel.
#[derive(Debug)]
pub struct Spatializer {
    rings: Vec<Vec<f32>>,
    /// Ring index of the next sample `render` reads.
    read: usize,
    listener: [f64; 3],
    sample_rate_hz: f64,
    max_delay: usize,
    max_block: usize,
    reflection: Option<FloorReflection>,
}

/// A floor that reflects sound: the plane `y = height_m`, and its pressure reflection
/// coefficient (0–1; hard floors 0.9–0.98, carpet 0.3–0.6 at mid frequencies).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorReflection {
    /// Height of the floor plane, m.
    pub height_m: f64,
    /// Pressure reflection coefficient.
    pub coefficient: f64,
}

impl Spatializer {
    /// A listener at `listener` (m); two channels (left/right along x) when `stereo`. Delays
    /// longer than `max_delay_s` are held at it; blocks are at most `max_block` samples.
    ///
    /// # Errors
    /// [`SynthError::Parameter`] for a non-finite listener, a negative delay or an empty block.
    pub fn new(
        sample_rate_hz: f64,
        stereo: bool,
        listener: [f64; 3],
        max_delay_s: f64,
        max_block: usize,
    ) -> Result<Self, SynthError> {
        if !(listener.iter().all(|v| v.is_finite())
            && (0.0..=60.0).contains(&max_delay_s)
            && max_block > 0
            && sample_rate_hz > 0.0)
        {
            return Err(SynthError::Parameter(
                "spatializer: finite listener, delay in [0, 60] s, blocks > 0".into(),
            ));
        }
        let max_delay = (max_delay_s * sample_rate_hz).ceil() as usize;
        let cap = max_delay + 2 * max_block;
        Ok(Self {
            rings: vec![vec![0.0; cap]; if stereo { 2 } else { 1 }],
            read: 0,
            listener,
            sample_rate_hz,
            max_delay,
            max_block,
            reflection: None,
        })
    }

    /// Moves the listener to `position` (m) for the blocks placed from now on; false (and no
    /// move) for a non-finite position.
    pub fn set_listener(&mut self, position: [f64; 3]) -> bool {
        if position.iter().all(|v| v.is_finite()) {
            self.listener = position;
            true
        } else {
            false
        }
    }

    /// Writes first-order ambisonics (B-format, AmbiX: ACN W Y Z X, SN3D) instead of stereo or
    /// mono: four channels. Allocates (call before rendering).
    pub fn into_ambisonics(mut self) -> Self {
        let cap = self.rings[0].len();
        self.rings = vec![vec![0.0; cap]; 4];
        self
    }

    /// Adds (or removes) a floor reflection: each source is heard again from its image below
    /// the floor. False (unchanged) for a coefficient outside [0, 1] or a non-finite height.
    pub fn set_reflection(&mut self, reflection: Option<FloorReflection>) -> bool {
        if let Some(f) = reflection {
            if !(f.height_m.is_finite() && (0.0..=1.0).contains(&f.coefficient)) {
                return false;
            }
        }
        self.reflection = reflection;
        true
    }

    /// Where the listener is, m.
    pub fn listener(&self) -> [f64; 3] {
        self.listener
    }

    /// Output channels.
    pub fn channels(&self) -> usize {
        self.rings.len()
    }

    /// Adds `block` (mono, starting `offset` samples into the next block) from a source at
    /// `position` (m): delayed by r/343 s (up to the maximum delay), 1/r loud, panned (stereo)
    /// or encoded (ambisonics); with a floor reflection, again from its image below the floor.
    /// Never allocates.
    pub fn place(&mut self, block: &[f32], offset: usize, position: [f64; 3]) {
        assert!(
            offset + block.len() <= self.max_block,
            "block beyond max_block"
        );
        self.place_one(block, offset, position, 1.0);
        if let Some(f) = self.reflection {
            // The image source mirrored in the floor plane y = height, its pressure scaled by
            // the reflection coefficient (a locally reacting floor at any angle: a constant).
            let image = [position[0], 2.0 * f.height_m - position[1], position[2]];
            if position[1] >= f.height_m && self.listener[1] >= f.height_m {
                self.place_one(block, offset, image, f.coefficient);
            }
        }
    }

    fn place_one(&mut self, block: &[f32], offset: usize, position: [f64; 3], scale: f64) {
        let l = self.listener;
        let d = [position[0] - l[0], position[1] - l[1], position[2] - l[2]];
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let g = scale / r.max(0.1);
        let delay =
            ((r / SPEED_OF_SOUND_M_S * self.sample_rate_hz).round() as usize).min(self.max_delay);
        let u = if r > 1e-9 {
            [d[0] / r, d[1] / r, d[2] / r]
        } else {
            [0.0, 0.0, -1.0]
        };
        let gains: [f64; 4] = match self.rings.len() {
            2 => {
                let p = u[0].clamp(-1.0, 1.0);
                [
                    g * (0.5 * (1.0 - p)).sqrt(),
                    g * (0.5 * (1.0 + p)).sqrt(),
                    0.0,
                    0.0,
                ]
            }
            // First-order ambisonics, AmbiX (ACN order W Y Z X, SN3D): the listener faces −z
            // with +x on the right and +y up, so ambisonic x (front) = −z, y (left) = −x,
            // z (up) = +y.
            4 => [g, -g * u[0], g * u[1], -g * u[2]],
            _ => [g, 0.0, 0.0, 0.0],
        };
        let cap = self.rings[0].len();
        let start = (self.read + offset + delay) % cap;
        // Two contiguous runs (before and after the ring's end) instead of a modulo per sample.
        let first = block.len().min(cap - start);
        for (c, ring) in self.rings.iter_mut().enumerate() {
            let gc = gains[c] as f32;
            for (o, &x) in ring[start..start + first].iter_mut().zip(&block[..first]) {
                *o += x * gc;
            }
            for (o, &x) in ring[..block.len() - first].iter_mut().zip(&block[first..]) {
                *o += x * gc;
            }
        }
    }

    /// Adds the next `out[c].len()` samples (the same for every channel, at most `max_block`)
    /// into `out` and moves on.
    pub fn render(&mut self, out: &mut [&mut [f32]]) {
        let n = out.first().map_or(0, |o| o.len());
        for (ring, o) in self.rings.iter_mut().zip(out.iter_mut()) {
            let cap = ring.len();
            let first = n.min(cap - self.read);
            let (head, tail) = o[..n].split_at_mut(first);
            for (v, r) in head.iter_mut().zip(&mut ring[self.read..self.read + first]) {
                *v += *r;
                *r = 0.0;
            }
            for (v, r) in tail.iter_mut().zip(&mut ring[..n - first]) {
                *v += *r;
                *r = 0.0;
            }
        }
        self.read = (self.read + n) % self.rings[0].len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_source_is_delayed_attenuated_and_panned() {
        let fs = 48_000.0;
        // 3.43 m to the right of the listener: 480 samples late, 1/3.43 loud, all right.
        let mut s = Spatializer::new(fs, true, [0.0; 3], 1.0, 64).unwrap();
        let mut l = vec![0.0f32; 64 * 10];
        let mut r = vec![0.0f32; 64 * 10];
        for b in 0..10 {
            if b == 0 {
                let mut click = [0.0f32; 64];
                click[0] = 1.0;
                s.place(&click, 0, [3.43, 0.0, 0.0]);
            }
            let (lo, hi) = (b * 64, (b + 1) * 64);
            s.render(&mut [&mut l[lo..hi], &mut r[lo..hi]]);
        }
        let peak = r.iter().position(|&v| v != 0.0).unwrap();
        assert_eq!(peak, 480);
        assert!((r[480] - 1.0 / 3.43).abs() < 1e-6, "{}", r[480]);
        assert!(l.iter().all(|&v| v.abs() < 1e-9));
    }

    fn impulse_response(mut s: Spatializer, position: [f64; 3], blocks: usize) -> Vec<Vec<f32>> {
        let mut out = vec![vec![0.0f32; 64 * blocks]; s.channels()];
        for b in 0..blocks {
            if b == 0 {
                let mut click = [0.0f32; 64];
                click[0] = 1.0;
                s.place(&click, 0, position);
            }
            let (lo, hi) = (b * 64, (b + 1) * 64);
            let mut views: Vec<&mut [f32]> = out.iter_mut().map(|c| &mut c[lo..hi]).collect();
            s.render(&mut views);
        }
        out
    }

    #[test]
    fn a_floor_adds_the_image_source_later_and_quieter_by_its_path() {
        let fs = 48_000.0;
        // Source 0.5 m up, listener 1.5 m up, 4 m apart horizontally: direct path √(16 + 1),
        // reflected √(16 + 4).
        let mut s = Spatializer::new(fs, false, [0.0, 1.5, 0.0], 1.0, 64).unwrap();
        assert!(s.set_reflection(Some(FloorReflection {
            height_m: 0.0,
            coefficient: 0.8,
        })));
        assert!(!s.set_reflection(Some(FloorReflection {
            height_m: 0.0,
            coefficient: 1.5,
        })));
        let y = &impulse_response(s, [4.0, 0.5, 0.0], 20)[0];
        let (r1, r2) = (17f64.sqrt(), 20f64.sqrt());
        let k1 = (r1 / SPEED_OF_SOUND_M_S * fs).round() as usize;
        let k2 = (r2 / SPEED_OF_SOUND_M_S * fs).round() as usize;
        assert!((f64::from(y[k1]) - 1.0 / r1).abs() < 1e-6, "{}", y[k1]);
        assert!((f64::from(y[k2]) - 0.8 / r2).abs() < 1e-6, "{}", y[k2]);
        let others: f32 = y
            .iter()
            .enumerate()
            .filter(|&(k, _)| k != k1 && k != k2)
            .map(|(_, v)| v.abs())
            .sum();
        assert_eq!(others, 0.0);
    }

    #[test]
    fn ambisonics_encode_the_direction_in_ambix_order() {
        let fs = 48_000.0;
        // Listener at the origin facing −z: front, left (−x), up (+y), right (+x).
        for (pos, want) in [
            ([0.0, 0.0, -2.0], [1.0, 0.0, 0.0, 1.0]),
            ([-2.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]),
            ([0.0, 2.0, 0.0], [1.0, 0.0, 1.0, 0.0]),
            ([2.0, 0.0, 0.0], [1.0, -1.0, 0.0, 0.0]),
        ] {
            let s = Spatializer::new(fs, true, [0.0; 3], 1.0, 64)
                .unwrap()
                .into_ambisonics();
            assert_eq!(s.channels(), 4);
            let y = impulse_response(s, pos, 10);
            let k = (2.0 / SPEED_OF_SOUND_M_S * fs).round() as usize;
            for c in 0..4 {
                // W Y Z X, SN3D: the direction cosines times the 1/r gain.
                let got = f64::from(y[c][k]) * 2.0;
                assert!((got - want[c]).abs() < 1e-6, "{pos:?} channel {c}: {got}");
            }
        }
        // Off-axis: the first-order components are the unit vector (|(Y, Z, X)| = W).
        let y = impulse_response(
            Spatializer::new(fs, true, [0.0; 3], 1.0, 64)
                .unwrap()
                .into_ambisonics(),
            [1.0, 1.0, -1.0],
            10,
        );
        let k = (3f64.sqrt() / SPEED_OF_SOUND_M_S * fs).round() as usize;
        let v: Vec<f64> = (0..4).map(|c| f64::from(y[c][k])).collect();
        let norm = (v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt();
        assert!(
            (norm - v[0]).abs() < 1e-6 && v[3] > 0.0 && v[1] < 0.0 && v[2] > 0.0,
            "{v:?}"
        );
    }
}
