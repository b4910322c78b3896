//! Placing sources at a listener: 1/r distance attenuation (1 at 1 m, capped at 10 cm), the
//! propagation delay r / 343 m/s, and an equal-power pan from the source's direction along x
//! (stereo) — the mixer of scenes, offline and live alike.
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

    /// Output channels.
    pub fn channels(&self) -> usize {
        self.rings.len()
    }

    /// Adds a source's `block`, which starts `offset` samples after the next sample `render`
    /// reads, from `position` (m).
    ///
    /// # Panics
    /// When `offset + block.len()` exceeds the `max_block` given to `new`.
    pub fn place(&mut self, block: &[f32], offset: usize, position: [f64; 3]) {
        assert!(
            offset + block.len() <= self.max_block,
            "block beyond max_block"
        );
        let l = self.listener;
        let d = [position[0] - l[0], position[1] - l[1], position[2] - l[2]];
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let g = 1.0 / r.max(0.1);
        let delay =
            ((r / SPEED_OF_SOUND_M_S * self.sample_rate_hz).round() as usize).min(self.max_delay);
        let gains: [f64; 2] = if self.rings.len() == 2 {
            let p = (d[0] / r.max(1e-9)).clamp(-1.0, 1.0);
            [g * (0.5 * (1.0 - p)).sqrt(), g * (0.5 * (1.0 + p)).sqrt()]
        } else {
            [g, 0.0]
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
}
