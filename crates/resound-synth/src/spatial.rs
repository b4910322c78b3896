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
pub use resound_core::limits::SPEED_OF_SOUND_M_S;

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
    /// Per tracked source (direct, image): the delay and gains of its last block.
    tracks: Vec<Track>,
}

/// A tracked source's glide: where its delay (samples) and gains are and where they go.
#[derive(Clone, Copy, Debug, Default)]
struct Track {
    delay: f64,
    gains: [f32; 4],
    target_delay: usize,
    target_gains: [f32; 4],
    /// Samples left to the target.
    left: usize,
    live: bool,
}

/// How long a tracked source glides to a new delay and gains: about one physics step.
pub const GLIDE_S: f64 = 1.0 / 240.0;

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
            tracks: Vec::new(),
        })
    }

    /// Tracks `n` sources for [`Spatializer::place_source`] (allocates; call before rendering).
    pub fn track_sources(&mut self, n: usize) {
        self.tracks = vec![Track::default(); 2 * n];
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
        self.place_tracked(None, block, offset, position);
    }

    /// [`Spatializer::place`] for source `source` of those tracked
    /// ([`Spatializer::track_sources`]; others are placed untracked): when its delay or gains
    /// changed since its last block (it moved, or the listener did) they glide from the old to
    /// the new over this block — the delay by writing each sample at its fractional position
    /// (linear), the gains linearly — so motion makes no gap, doubled sample or gain step (a
    /// click the physics did not make). A source that stays put is placed exactly as by
    /// `place`. Never allocates.
    pub fn place_source(
        &mut self,
        source: usize,
        block: &[f32],
        offset: usize,
        position: [f64; 3],
    ) {
        let tracked = (2 * source + 1 < self.tracks.len()).then_some(source);
        self.place_tracked(tracked, block, offset, position);
    }

    fn place_tracked(
        &mut self,
        source: Option<usize>,
        block: &[f32],
        offset: usize,
        position: [f64; 3],
    ) {
        assert!(
            offset + block.len() <= self.max_block,
            "block beyond max_block"
        );
        self.place_one(source.map(|s| 2 * s), block, offset, position, 1.0);
        if let Some(f) = self.reflection {
            // The image source mirrored in the floor plane y = height, its pressure scaled by
            // the reflection coefficient (a locally reacting floor at any angle: a constant).
            let image = [position[0], 2.0 * f.height_m - position[1], position[2]];
            if position[1] >= f.height_m && self.listener[1] >= f.height_m {
                self.place_one(
                    source.map(|s| 2 * s + 1),
                    block,
                    offset,
                    image,
                    f.coefficient,
                );
            }
        }
    }

    fn place_one(
        &mut self,
        track: Option<usize>,
        block: &[f32],
        offset: usize,
        position: [f64; 3],
        scale: f64,
    ) {
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
        let gains_f32 = gains.map(|g| g as f32);
        let cap = self.rings[0].len();
        if let Some(t) = track.and_then(|k| self.tracks.get_mut(k)) {
            let glide = (GLIDE_S * self.sample_rate_hz).round().max(1.0) as usize;
            if !t.live {
                *t = Track {
                    delay: delay as f64,
                    gains: gains_f32,
                    target_delay: delay,
                    target_gains: gains_f32,
                    left: 0,
                    live: true,
                };
            } else if delay != t.target_delay || gains_f32 != t.target_gains {
                t.target_delay = delay;
                t.target_gains = gains_f32;
                // A jump of more than half the glide (a teleport) is taken at once.
                t.left = if (delay as f64 - t.delay).abs() * 2.0 > glide as f64 {
                    t.delay = delay as f64;
                    t.gains = gains_f32;
                    0
                } else {
                    glide
                };
            }
            if t.left > 0 {
                // Each sample moves 1/left of the way; the rest of the block (if the glide ends
                // in it) is written at the target like an untracked source.
                let base = self.read + offset;
                let n = block.len();
                let mut i = 0;
                while i < n && t.left > 0 {
                    let k = t.left as f64;
                    t.delay += (t.target_delay as f64 - t.delay) / k;
                    for c in 0..4 {
                        t.gains[c] += (t.target_gains[c] - t.gains[c]) / t.left as f32;
                    }
                    t.left -= 1;
                    if t.left == 0 {
                        t.delay = t.target_delay as f64;
                        t.gains = t.target_gains;
                    }
                    let kf = t.delay.floor();
                    let frac = (t.delay - kf) as f32;
                    let at = (base + i + kf as usize) % cap;
                    let next = (at + 1) % cap;
                    for (c, ring) in self.rings.iter_mut().enumerate() {
                        let v = block[i] * t.gains[c];
                        ring[at] += v * (1.0 - frac);
                        if frac > 0.0 {
                            ring[next] += v * frac;
                        }
                    }
                    i += 1;
                }
                if i == n {
                    return;
                }
                // The remainder at the target: fall through with the block's tail.
                let (tail, off) = (&block[i..], offset + i);
                let start = (self.read + off + delay) % cap;
                let first = tail.len().min(cap - start);
                for (c, ring) in self.rings.iter_mut().enumerate() {
                    let gc = gains_f32[c];
                    for (o, &x) in ring[start..start + first].iter_mut().zip(&tail[..first]) {
                        *o += x * gc;
                    }
                    for (o, &x) in ring[..tail.len() - first].iter_mut().zip(&tail[first..]) {
                        *o += x * gc;
                    }
                }
                return;
            }
        }
        let start = (self.read + offset + delay) % cap;
        // Two contiguous runs (before and after the ring's end) instead of a modulo per sample.
        let first = block.len().min(cap - start);
        for (c, ring) in self.rings.iter_mut().enumerate() {
            let gc = gains_f32[c];
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

    /// Largest sample-to-sample step of a 1 kHz tone (amplitude 1 at the source) from a source
    /// moving along x past a stereo listener at `speed` m/s, blocks of 200 samples at 48 kHz,
    /// relative to the step the tone alone makes at the gain of the nearest point.
    fn moving_tone_step(speed: f64, tracked: bool) -> f64 {
        let fs = 48_000.0;
        let mut s = Spatializer::new(fs, true, [0.0, 0.0, 0.0], 1.0, 200).unwrap();
        s.track_sources(1);
        let (mut l, mut r) = (vec![0.0f32; 200], vec![0.0f32; 200]);
        let mut out = Vec::new();
        let w = 2.0 * std::f64::consts::PI * 1000.0 / fs;
        for b in 0..480 {
            let block: Vec<f32> = (0..200)
                .map(|i| ((b * 200 + i) as f64 * w).sin() as f32)
                .collect();
            let x = -2.0 + speed * b as f64 * 200.0 / fs;
            let p = [x, 0.0, -1.0];
            if tracked {
                s.place_source(0, &block, 0, p);
            } else {
                s.place(&block, 0, p);
            }
            l.fill(0.0);
            r.fill(0.0);
            s.render(&mut [&mut l, &mut r]);
            out.extend(
                l.iter()
                    .zip(&r)
                    .map(|(a, b)| (f64::from(*a), f64::from(*b))),
            );
        }
        // Skip the first 0.2 s (the delay line filling) and compare each step with what a
        // tone at that sample's gain makes: 2 sin(w/2) × the larger channel gain (≤ 1/r ≤ 1).
        let natural = 2.0 * (w / 2.0).sin();
        out.windows(2)
            .skip(9_600)
            .map(|p| (p[1].0 - p[0].0).abs().max((p[1].1 - p[0].1).abs()) / natural)
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_moving_source_glides_without_steps() {
        // Static: the tone's own step (≤ 1 at gain ≤ 1).
        let still = moving_tone_step(0.0, true);
        assert!(still <= 1.0 + 1e-3, "{still}");
        // At 5 m/s the delay changes by ~3 samples per block: placed untracked, each block
        // starts with a gap or an overlap, a step well above the tone's; tracked, it glides.
        let untracked = moving_tone_step(5.0, false);
        let tracked = moving_tone_step(5.0, true);
        assert!(untracked > 1.3, "untracked {untracked}");
        assert!(tracked <= 1.02, "tracked {tracked}");
    }

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
