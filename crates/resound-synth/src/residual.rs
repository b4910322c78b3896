//! Ren 2013 §6: the residual — what a recording holds beyond what the estimated modes represent —
//! its computation, its transfer to other objects and hit points, and its reconstruction.
//!
//! **Computation (§6.1).** Each reference mode (feature) of the recording is weighted by how well
//! the estimated modes represent it (its point-to-set match ratio R_i, eq. 24): the represented
//! sound is `Σ R_i · feature_i` (amplitudes weighted, synthesized exactly). The residual power is
//! `max(P_rec − P_rep − 2 N, 0)` per STFT cell, where `N` is the recording's steady noise per bin
//! (its 10th percentile over frames; a room's hiss is not part of the object and must not follow
//! every synthesized hit). It is stored as audio — magnitudes with the recording's phases, inverse
//! STFT — trimmed where it has decayed by 60 dB: Algorithm 1's input is residual audio.
//!
//! **Transfer (§6.2, Algorithm 1).** Source and target modes are paired: by index when the target
//! is the source object (or a scaled copy: natural correspondence), otherwise the `N` dominant
//! modes of each side (perceptual weight, as in the estimator) paired from low to high. Each
//! pair owns a band on either side, between the midpoints to its neighbours. A target pixel
//! `(t, f)` in pair k's band takes the source pixel at `f_s = f_k^s + (f − f_k^t)·(band ratio)`
//! (a shift of the mode frequency, the band stretched piecewise-linearly so that bands stitch
//! without gaps) and `t_s = t · d_k^t / d_k^s` (time stretched by the damping ratio), times the
//! pixel scale. For a damped sinusoid the shifted, stretched source mode's power spectrogram
//! differs from the target mode's at every pixel by the same factor `(a_k^t / a_k^s)²` (the
//! envelopes `e^{−2dt}` coincide after the stretch; the window's spectral shape moves with the
//! shift), so FindPixelScale is that constant — no per-pixel division of tiny numbers.
//!
//! **Reconstruction.** Griffin–Lim from the transferred magnitudes, started from the
//! transferred source phases; the fast variant (Perraudin, Balazs & Søndergaard 2013: momentum
//! 0.99) by default, 10 iterations as in the paper. Sine (√Hann) windows of about 21 ms, hop W/2.

use realfft::num_complex::Complex32;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use resound_core::damped::synthesize;
use resound_core::{DampedMode, Residual};
use resound_estimate::features::{represented_ratios, FeaturePoint};
use std::sync::Arc;

/// STFT window for `sample_rate_hz`: about 21 ms, a power of two (1024 at 44.1/48 kHz).
pub fn window_len_for(sample_rate_hz: f64) -> usize {
    ((0.0213 * sample_rate_hz) as usize)
        .next_power_of_two()
        .max(64)
}

/// An STFT with the periodic sine window (√Hann) and its exact inverse (weighted overlap-add),
/// f32, with plans and scratch kept between calls. With a hop of W/2 (the default for the
/// residual) the window's squares sum to exactly 1, so analysis and synthesis form a tight frame
/// at half the frames of the usual W/4 hop — Griffin–Lim costs half as much.
pub struct Stft {
    window_len: usize,
    hop: usize,
    window: Vec<f32>,
    fwd: Arc<dyn RealToComplex<f32>>,
    inv: Arc<dyn ComplexToReal<f32>>,
    frame: Vec<f32>,
    spectrum: Vec<Complex32>,
    scratch_fwd: Vec<Complex32>,
    scratch_inv: Vec<Complex32>,
}

impl std::fmt::Debug for Stft {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Stft(W = {}, hop = {})", self.window_len, self.hop)
    }
}

impl Stft {
    /// Plans an STFT of window `window_len` (even) and hop W/2.
    pub fn new(window_len: usize) -> Self {
        Self::with_hop(window_len, window_len / 2)
    }

    /// Plans an STFT of window `window_len` with `hop` (W/2 or W/4 keep the frame tight).
    pub fn with_hop(window_len: usize, hop: usize) -> Self {
        let mut planner = RealFftPlanner::<f32>::new();
        let fwd = planner.plan_fft_forward(window_len);
        let inv = planner.plan_fft_inverse(window_len);
        let window = (0..window_len)
            .map(|i| (std::f64::consts::PI * i as f64 / window_len as f64).sin() as f32)
            .collect();
        Self {
            window_len,
            hop: hop.max(1),
            window,
            frame: vec![0.0; window_len],
            spectrum: fwd.make_output_vec(),
            scratch_fwd: fwd.make_scratch_vec(),
            scratch_inv: inv.make_scratch_vec(),
            fwd,
            inv,
        }
    }

    /// Bins per frame.
    pub fn bins(&self) -> usize {
        self.window_len / 2 + 1
    }

    /// Window length.
    pub fn window_len(&self) -> usize {
        self.window_len
    }

    /// Hop.
    pub fn hop(&self) -> usize {
        self.hop
    }

    /// Frames covering `samples` samples (every sample lies under W/hop frames).
    pub fn frames_for(&self, samples: usize) -> usize {
        (samples + self.window_len - self.hop).div_ceil(self.hop)
    }

    /// Frame m covers samples `[start, start + W)`, `start = m·hop − (W − hop)`; returns the
    /// part inside `[0, samples)` as (offset in frame, first sample, length).
    fn span(&self, m: usize, samples: usize) -> (usize, usize, usize) {
        let start = (m * self.hop) as isize - (self.window_len - self.hop) as isize;
        let first = start.max(0) as usize;
        let offset = (first as isize - start) as usize;
        let end = ((start + self.window_len as isize).max(0) as usize).min(samples);
        (offset, first, end.saturating_sub(first))
    }

    /// The STFT of `x` into `out` (frames × bins, frame-major).
    pub fn forward(&mut self, x: &[f32], out: &mut Vec<Complex32>) {
        let frames = self.frames_for(x.len());
        let bins = self.bins();
        out.clear();
        out.resize(frames * bins, Complex32::new(0.0, 0.0));
        for m in 0..frames {
            let (offset, first, len) = self.span(m, x.len());
            self.frame.fill(0.0);
            for ((f, &v), &w) in self.frame[offset..offset + len]
                .iter_mut()
                .zip(&x[first..first + len])
                .zip(&self.window[offset..offset + len])
            {
                *f = v * w;
            }
            // Lengths are right by construction; a failure would leave the frame at zero.
            let _ = self.fwd.process_with_scratch(
                &mut self.frame,
                &mut self.spectrum,
                &mut self.scratch_fwd,
            );
            out[m * bins..(m + 1) * bins].copy_from_slice(&self.spectrum);
        }
    }

    /// The signal of `samples` samples whose STFT is closest to `spec` (least squares: windowed
    /// overlap-add divided by Σ w² = W / (2 hop)).
    pub fn inverse(&mut self, spec: &[Complex32], samples: usize, out: &mut Vec<f32>) {
        let bins = self.bins();
        let frames = spec.len() / bins;
        out.clear();
        out.resize(samples, 0.0);
        let scale = 2.0 * self.hop as f32 / (self.window_len as f32 * self.window_len as f32);
        for m in 0..frames {
            let (offset, first, len) = self.span(m, samples);
            if len == 0 {
                continue;
            }
            self.spectrum
                .copy_from_slice(&spec[m * bins..(m + 1) * bins]);
            // A real signal's DC and Nyquist bins are real.
            self.spectrum[0].im = 0.0;
            self.spectrum[bins - 1].im = 0.0;
            let _ = self.inv.process_with_scratch(
                &mut self.spectrum,
                &mut self.frame,
                &mut self.scratch_inv,
            );
            for ((o, &v), &w) in out[first..first + len]
                .iter_mut()
                .zip(&self.frame[offset..offset + len])
                .zip(&self.window[offset..offset + len])
            {
                *o += v * w * scale;
            }
        }
    }
}

/// Griffin–Lim settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GriffinLim {
    /// Iterations.
    pub iterations: usize,
    /// Momentum α of the fast variant (0: plain Griffin–Lim; 0.99: Perraudin et al.).
    pub momentum: f32,
}

impl Default for GriffinLim {
    fn default() -> Self {
        Self {
            iterations: 10,
            momentum: 0.99,
        }
    }
}

/// Spectral error `‖ |STFT(x)| − S ‖ / ‖S‖` of a signal against target magnitudes.
pub fn spectral_error(stft: &mut Stft, x: &[f32], magnitude: &[f32]) -> f64 {
    let mut spec = Vec::new();
    stft.forward(x, &mut spec);
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (c, &s) in spec.iter().zip(magnitude) {
        num += f64::from(c.norm() - s).powi(2);
        den += f64::from(s).powi(2);
    }
    (num / den.max(1e-300)).sqrt()
}

/// Reconstructs `samples` samples from STFT magnitudes (frames × bins) starting from
/// `initial` (complex cells whose phases are used; `None`: zero phase). When `errors` is given,
/// the spectral error of each iterate is pushed to it (one extra STFT per iteration).
pub fn griffin_lim(
    stft: &mut Stft,
    magnitude: &[f32],
    initial: Option<&[Complex32]>,
    samples: usize,
    params: &GriffinLim,
    errors: Option<&mut Vec<f64>>,
) -> Vec<f32> {
    let mut ws = GlWorkspace::default();
    match initial {
        Some(init) => ws.c.extend_from_slice(init),
        None => {
            ws.c.extend(magnitude.iter().map(|&s| Complex32::new(s, 0.0)))
        }
    }
    griffin_lim_in(stft, magnitude, samples, params, errors, &mut ws);
    std::mem::take(&mut ws.x)
}

/// Buffers of [`griffin_lim_in`], reused between calls.
#[derive(Debug, Default)]
pub struct GlWorkspace {
    /// Current estimate (complex cells); holds the initial cells on entry.
    pub c: Vec<Complex32>,
    previous: Vec<Complex32>,
    t: Vec<Complex32>,
    y: Vec<Complex32>,
    /// The reconstructed signal on return.
    pub x: Vec<f32>,
}

/// [`griffin_lim`] in reused buffers: starts from `ws.c` (its phases), leaves the signal in
/// `ws.x`.
pub fn griffin_lim_in(
    stft: &mut Stft,
    magnitude: &[f32],
    samples: usize,
    params: &GriffinLim,
    mut errors: Option<&mut Vec<f64>>,
    ws: &mut GlWorkspace,
) {
    let project = |cells: &mut [Complex32]| {
        for (c, &s) in cells.iter_mut().zip(magnitude) {
            let n2 = c.re * c.re + c.im * c.im;
            *c = if n2 > 1e-30 {
                *c * (s / n2.sqrt())
            } else {
                Complex32::new(s, 0.0)
            };
        }
    };
    ws.c.resize(magnitude.len(), Complex32::new(0.0, 0.0));
    project(&mut ws.c);
    ws.previous.clear();
    ws.previous.extend_from_slice(&ws.c);
    ws.t.clear();
    ws.t.extend_from_slice(&ws.c);
    for _ in 0..params.iterations {
        stft.inverse(&ws.t, samples, &mut ws.x);
        stft.forward(&ws.x, &mut ws.y);
        project(&mut ws.y);
        std::mem::swap(&mut ws.c, &mut ws.y);
        for ((ti, &ci), pi) in ws.t.iter_mut().zip(&ws.c).zip(ws.previous.iter_mut()) {
            *ti = ci + (ci - *pi) * params.momentum;
            *pi = ci;
        }
        if let Some(e) = errors.as_deref_mut() {
            let mut xc = Vec::new();
            stft.inverse(&ws.c, samples, &mut xc);
            e.push(spectral_error(stft, &xc, magnitude));
        }
    }
    stft.inverse(&ws.c, samples, &mut ws.x);
}

/// Computes the residual of `recording` (onset-aligned, full scale = 1) against its analysed
/// `reference` modes and the `estimated` modes of the material on the recorded object at the
/// recorded hit (see the module docs).
pub fn compute_residual(
    recording: &[f64],
    sample_rate_hz: f64,
    reference: &[DampedMode],
    estimated: &[DampedMode],
) -> Residual {
    let mut stft = Stft::new(window_len_for(sample_rate_hz));
    let n = recording.len();
    let x: Vec<f32> = recording.iter().map(|&v| v as f32).collect();
    let ratios = represented_ratios(reference, estimated);
    let represented: Vec<DampedMode> = reference
        .iter()
        .zip(&ratios)
        .map(|(m, r)| DampedMode {
            amplitude: m.amplitude * r,
            ..*m
        })
        .collect();
    let rep: Vec<f32> = synthesize(&represented, sample_rate_hz, n)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let (mut sx, mut sr) = (Vec::new(), Vec::new());
    stft.forward(&x, &mut sx);
    stft.forward(&rep, &mut sr);
    let bins = stft.bins();
    let frames = sx.len() / bins;
    // Steady noise per bin: the 10th percentile over frames.
    let noise: Vec<f32> = (0..bins)
        .map(|k| {
            let mut p: Vec<f32> = (0..frames).map(|m| sx[m * bins + k].norm_sqr()).collect();
            if p.len() < 10 {
                return 0.0;
            }
            let i = p.len() / 10;
            *p.select_nth_unstable_by(i, f32::total_cmp).1
        })
        .collect();
    let cells: Vec<Complex32> = sx
        .iter()
        .zip(&sr)
        .enumerate()
        .map(|(i, (c, r))| {
            let p = (c.norm_sqr() - r.norm_sqr() - 2.0 * noise[i % bins]).max(0.0);
            let n = c.norm();
            if n > 0.0 {
                *c * (p.sqrt() / n)
            } else {
                Complex32::new(0.0, 0.0)
            }
        })
        .collect();
    // Trim frames after the residual has decayed by 60 dB.
    let energy: Vec<f32> = (0..frames)
        .map(|m| {
            cells[m * bins..(m + 1) * bins]
                .iter()
                .map(|c| c.norm_sqr())
                .sum()
        })
        .collect();
    let peak = energy.iter().copied().fold(0.0f32, f32::max);
    let last = energy
        .iter()
        .rposition(|&e| e > 1e-6 * peak)
        .map_or(0, |m| m + 1);
    let samples = (last * stft.hop()).min(n);
    let mut out = Vec::new();
    stft.inverse(&cells, n, &mut out);
    out.truncate(samples);
    // A short fade-out where it was cut.
    let fade = (stft.hop()).min(out.len());
    let len = out.len();
    for (i, v) in out[len - fade..].iter_mut().enumerate() {
        *v *= 1.0 - (i as f32 + 1.0) / fade as f32;
    }
    Residual {
        sample_rate_hz,
        samples: out,
        source_modes: estimated.to_vec(),
    }
}

/// How source and target modes are paired.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pairing {
    /// By index: the target is the source object or a scaled copy.
    Natural,
    /// The N dominant modes of each side, paired from low to high frequency.
    Dominant(usize),
}

/// A residual prepared for transfer: its STFT, computed once per material (Ren: "cache what does
/// not change between events").
#[derive(Debug)]
pub struct ResidualSource {
    sample_rate_hz: f64,
    stft: Stft,
    frames: usize,
    power: Vec<f32>,
    phase: Vec<Complex32>,
    modes: Vec<DampedMode>,
    samples: usize,
    magnitude: Vec<f32>,
    ws: GlWorkspace,
}

/// One source–target mode pair with its bands.
#[derive(Clone, Copy, Debug)]
struct Pair {
    fs: f64,
    ft: f64,
    lo_s: f64,
    hi_s: f64,
    lo_t: f64,
    hi_t: f64,
    stretch: f64,
    scale: f32,
}

impl ResidualSource {
    /// Prepares `residual` for transfer.
    pub fn new(residual: &Residual) -> Self {
        let mut stft = Stft::new(window_len_for(residual.sample_rate_hz));
        let mut spec = Vec::new();
        stft.forward(&residual.samples, &mut spec);
        let frames = spec.len() / stft.bins();
        let power = spec.iter().map(|c| c.norm_sqr()).collect();
        let phase = spec
            .iter()
            .map(|c| {
                let n = c.norm();
                if n > 0.0 {
                    *c / n
                } else {
                    Complex32::new(1.0, 0.0)
                }
            })
            .collect();
        let mut modes = residual.source_modes.clone();
        modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        Self {
            sample_rate_hz: residual.sample_rate_hz,
            stft,
            frames,
            power,
            phase,
            modes,
            samples: residual.samples.len(),
            magnitude: Vec::new(),
            ws: GlWorkspace::default(),
        }
    }

    /// Sample rate of the residual (and of what [`ResidualSource::transfer`] returns).
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    fn pairs(&self, target: &[DampedMode], pairing: Pairing) -> Vec<Pair> {
        let mut t: Vec<DampedMode> = target.to_vec();
        t.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        let (s, t): (Vec<DampedMode>, Vec<DampedMode>) = match pairing {
            Pairing::Natural => {
                let k = self.modes.len().min(t.len());
                (self.modes[..k].to_vec(), t[..k].to_vec())
            }
            Pairing::Dominant(n) => {
                let top = |v: &[DampedMode]| {
                    let mut v = v.to_vec();
                    v.sort_by(|a, b| {
                        FeaturePoint::of(b)
                            .weight
                            .total_cmp(&FeaturePoint::of(a).weight)
                    });
                    v.truncate(n.max(1));
                    v.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
                    v
                };
                let (a, b) = (top(&self.modes), top(&t));
                let k = a.len().min(b.len());
                (a[..k].to_vec(), b[..k].to_vec())
            }
        };
        let nyquist = 0.5 * self.sample_rate_hz;
        let k = s.len();
        (0..k)
            .map(|i| {
                let mid = |v: &[DampedMode], j: usize| 0.5 * (v[j].freq_hz + v[j + 1].freq_hz);
                let (lo_s, hi_s) = (
                    if i == 0 { 0.0 } else { mid(&s, i - 1) },
                    if i + 1 == k { nyquist } else { mid(&s, i) },
                );
                let (lo_t, hi_t) = (
                    if i == 0 { 0.0 } else { mid(&t, i - 1) },
                    if i + 1 == k { nyquist } else { mid(&t, i) },
                );
                let ratio = if s[i].amplitude > 0.0 {
                    (t[i].amplitude / s[i].amplitude).powi(2)
                } else {
                    0.0
                };
                Pair {
                    fs: s[i].freq_hz,
                    ft: t[i].freq_hz,
                    lo_s,
                    hi_s,
                    lo_t,
                    hi_t,
                    stretch: t[i].damping_per_s / s[i].damping_per_s.max(1e-9),
                    scale: ratio as f32,
                }
            })
            .collect()
    }

    /// The transferred magnitudes into `magnitude` and initial cells (magnitude × source phase)
    /// into `cells` (frames × bins); returns the length in samples (0: nothing to transfer).
    fn transfer_into(
        &self,
        target: &[DampedMode],
        pairing: Pairing,
        magnitude: &mut Vec<f32>,
        cells: &mut Vec<Complex32>,
    ) -> usize {
        let pairs = self.pairs(target, pairing);
        let bins = self.stft.bins();
        magnitude.clear();
        cells.clear();
        if pairs.is_empty() || self.frames == 0 {
            return 0;
        }
        // Longest stretch decides the length (at most 4× the source).
        let longest = pairs
            .iter()
            .map(|p| 1.0 / p.stretch.max(1e-9))
            .fold(0.0f64, f64::max)
            .clamp(0.25, 4.0);
        let frames = ((self.frames as f64 * longest).ceil() as usize).max(1);
        magnitude.resize(frames * bins, 0.0);
        cells.resize(frames * bins, Complex32::new(0.0, 0.0));
        let bin_hz = self.sample_rate_hz / self.stft.window_len() as f64;
        let mut p_idx = 0;
        for k in 0..bins {
            let f = k as f64 * bin_hz;
            while p_idx + 1 < pairs.len() && f >= pairs[p_idx].hi_t {
                p_idx += 1;
            }
            let p = &pairs[p_idx];
            // Piecewise-linear band map with the mode frequency fixed to its partner.
            let f_s = if f <= p.ft {
                let w = (p.ft - p.lo_t).max(1e-9);
                p.lo_s + (f - p.lo_t).max(0.0) / w * (p.fs - p.lo_s)
            } else {
                let w = (p.hi_t - p.ft).max(1e-9);
                p.fs + (f - p.ft).min(w) / w * (p.hi_s - p.fs)
            };
            let ks = f_s / bin_hz;
            let k0 = (ks.floor() as usize).min(bins - 1);
            let k1 = (k0 + 1).min(bins - 1);
            let wk = (ks - k0 as f64) as f32;
            let nearest_k = if wk < 0.5 { k0 } else { k1 };
            for m in 0..frames {
                let ms = m as f64 * p.stretch;
                let m0 = ms.floor() as usize;
                if m0 >= self.frames {
                    break;
                }
                let m1 = (m0 + 1).min(self.frames - 1);
                let wm = (ms - m0 as f64) as f32;
                let at = |mm: usize, kk: usize| self.power[mm * bins + kk];
                let v = (1.0 - wm) * ((1.0 - wk) * at(m0, k0) + wk * at(m0, k1))
                    + wm * ((1.0 - wk) * at(m1, k0) + wk * at(m1, k1));
                let mag = (v * p.scale).sqrt();
                let nearest_m = if wm < 0.5 { m0 } else { m1 };
                magnitude[m * bins + k] = mag;
                cells[m * bins + k] = self.phase[nearest_m * bins + nearest_k] * mag;
            }
        }
        ((self.samples as f64 * longest) as usize).max(1)
    }

    /// The transferred power spectrogram (frames × bins) and its length in samples.
    pub fn transfer_spectrogram(
        &self,
        target: &[DampedMode],
        pairing: Pairing,
    ) -> (Vec<f32>, usize) {
        let (mut magnitude, mut cells) = (Vec::new(), Vec::new());
        let samples = self.transfer_into(target, pairing, &mut magnitude, &mut cells);
        (magnitude.iter().map(|m| m * m).collect(), samples)
    }

    /// The residual audio for `target` modes (unit impulse; scale by the impact's impulse).
    /// Buffers are reused between calls.
    pub fn transfer(
        &mut self,
        target: &[DampedMode],
        pairing: Pairing,
        gl: &GriffinLim,
    ) -> Vec<f32> {
        let mut magnitude = std::mem::take(&mut self.magnitude);
        let mut ws = std::mem::take(&mut self.ws);
        let samples = self.transfer_into(target, pairing, &mut magnitude, &mut ws.c);
        let out = if samples <= 1 {
            Vec::new()
        } else {
            griffin_lim_in(&mut self.stft, &magnitude, samples, gl, None, &mut ws);
            ws.x.clone()
        };
        self.magnitude = magnitude;
        self.ws = ws;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stft_round_trip_is_exact() {
        for hop in [128, 64] {
            let mut stft = Stft::with_hop(256, hop);
            let x: Vec<f32> = (0..3000)
                .map(|i| ((i * 7919) % 1000) as f32 / 500.0 - 1.0)
                .collect();
            let (mut spec, mut y) = (Vec::new(), Vec::new());
            stft.forward(&x, &mut spec);
            stft.inverse(&spec, x.len(), &mut y);
            let err = x
                .iter()
                .zip(&y)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(err < 1e-5, "hop {hop}: {err}");
        }
    }
}
