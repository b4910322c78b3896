//! An STFT with the periodic sine window (√Hann) and its exact inverse, and Griffin–Lim
//! phase reconstruction (plain and fast, Perraudin, Balazs & Søndergaard 2013) on it.
//!
//! f32 throughout (audio); one plan per window length, kept with its scratch between calls
//! (RustFFT's plan-once pattern). Used by the residual (Ren §6: computation in
//! `resound-estimate`, transfer in `resound-synth`) and by the grains' SMS split and quality
//! figure. (The statistical model's transient bands keep their own 46 ms frames.)
//!
//! # Normalization
//! The forward transform is unnormalized; [`Stft::inverse`] is the weighted overlap-add that
//! undoes it exactly (for every hop that divides the window into a tight frame: W/2, W/4).

use realfft::num_complex::Complex32;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
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
