//! Multi-level complex spectrograms (Ren 2013 §4, eq. 9) and the closed-form spectrogram of a
//! damped sinusoid.
//!
//! Every level uses a periodic Hann window of `W = min_window · 2^level` samples, a hop of `W/4`
//! and an FFT of `2W` (two-times zero padding, so bins are `fs / 2W` apart). Frame `m` starts at
//! sample `m · hop` of the onset-aligned signal, so no frame reaches before the onset.
//!
//! Because the Hann window is a sum of three complex exponentials, the windowed DFT of a damped
//! complex exponential is a sum of three geometric series: [`mode_basis`] evaluates a mode's
//! contribution to any spectrogram cell in O(1), with no synthesis and no FFT. Local shape fitting
//! and subtraction (see [`crate::extract`]) are built on it.

use realfft::num_complex::Complex64;
use realfft::{RealFftPlanner, RealToComplex};
use std::f64::consts::TAU;
use std::sync::Arc;

thread_local! {
    /// One planner per thread: it keeps every plan it made, so a length is planned once per
    /// thread however often spectrograms of it are computed (the estimator computes one per
    /// objective evaluation).
    static PLANNER: std::cell::RefCell<RealFftPlanner<f64>> =
        std::cell::RefCell::new(RealFftPlanner::new());
}

/// The forward real FFT of `len` points, planned once per thread and length (every STFT of
/// the analysis crates takes its plan here).
pub fn forward_plan(len: usize) -> Arc<dyn RealToComplex<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft_forward(len))
}

/// One level of the multi-level spectrogram: complex STFT values, frame-major.
#[derive(Clone, Debug)]
pub struct Spectrogram {
    /// Window length W in samples.
    pub window_len: usize,
    /// Hop between frames in samples.
    pub hop: usize,
    /// FFT length (2W).
    pub fft_len: usize,
    /// Number of frames.
    pub frames: usize,
    /// Number of bins (fft_len/2 + 1).
    pub bins: usize,
    /// Sample rate in Hz.
    pub sample_rate_hz: f64,
    /// `data[m * bins + k]`.
    pub data: Vec<Complex64>,
}

impl Spectrogram {
    /// Computes the level with window `window_len` over `x` (sample 0 = onset). Returns `None`
    /// when `x` is shorter than one window.
    pub fn compute(x: &[f64], sample_rate_hz: f64, window_len: usize) -> Option<Self> {
        if x.len() < window_len || window_len < 8 {
            return None;
        }
        let hop = window_len / 4;
        let fft_len = 2 * window_len;
        let frames = (x.len() - window_len) / hop + 1;
        let bins = fft_len / 2 + 1;
        let win = hann(window_len);
        let fft = forward_plan(fft_len);
        let mut input = fft.make_input_vec();
        let mut output = fft.make_output_vec();
        let mut scratch = fft.make_scratch_vec();
        let mut data = Vec::with_capacity(frames * bins);
        for m in 0..frames {
            let s = m * hop;
            for (i, v) in input.iter_mut().enumerate() {
                *v = if i < window_len {
                    x[s + i] * win[i]
                } else {
                    0.0
                };
            }
            // The input length always matches the plan, so this cannot fail.
            if fft
                .process_with_scratch(&mut input, &mut output, &mut scratch)
                .is_err()
            {
                output
                    .iter_mut()
                    .for_each(|c| *c = Complex64::new(0.0, 0.0));
            }
            data.extend_from_slice(&output);
        }
        Some(Self {
            window_len,
            hop,
            fft_len,
            frames,
            bins,
            sample_rate_hz,
            data,
        })
    }

    /// Cell (frame, bin).
    #[inline]
    pub fn at(&self, m: usize, k: usize) -> Complex64 {
        self.data[m * self.bins + k]
    }

    /// Frequency of bin `k` in Hz.
    #[inline]
    pub fn bin_hz(&self, k: usize) -> f64 {
        k as f64 * self.sample_rate_hz / self.fft_len as f64
    }

    /// Bin spacing in Hz.
    #[inline]
    pub fn bin_width_hz(&self) -> f64 {
        self.sample_rate_hz / self.fft_len as f64
    }

    /// Start time of frame `m` in seconds after the onset.
    #[inline]
    pub fn frame_start_s(&self, m: usize) -> f64 {
        (m * self.hop) as f64 / self.sample_rate_hz
    }

    /// The factor that turns |X| of a steady sinusoid into its amplitude: `2 / Σw = 4 / W`.
    #[inline]
    pub fn amplitude_scale(&self) -> f64 {
        4.0 / self.window_len as f64
    }

    /// Subtracts the closed-form contribution of `mode` from the cells it reaches: bins within
    /// its main lobe plus its damping width, frames until its envelope falls below `floor`.
    pub fn subtract_mode(&mut self, mode: &resound_core::DampedMode, floor: f64) {
        // Hann leakage falls as 1/Δ³: 24 bins (12 window bins) leave < −60 dB.
        let width_bins = 24.0 + 8.0 * mode.damping_per_s / TAU / self.bin_width_hz();
        let width = width_bins.min(600.0).ceil() as isize;
        let centre = (mode.freq_hz / self.bin_width_hz()).round() as isize;
        let t_end = mode.time_to_floor_s(floor.max(1e-300));
        let (p_amp, p_conj) = amplitude_coefficients(mode);
        let last = self
            .frames
            .min((t_end * self.sample_rate_hz / self.hop as f64).ceil() as usize + 1);
        let columns = ModeColumns::new(self, mode.freq_hz, mode.damping_per_s);
        for k in (centre - width).max(0)..=(centre + width).min(self.bins as isize - 1) {
            let k = k as usize;
            let [mut p, mut q, ps, qs] = columns.column(k);
            for m in 0..last {
                self.data[m * self.bins + k] -= p_amp * p + p_conj * q;
                p *= ps;
                q *= qs;
            }
        }
    }
}

/// Periodic Hann window of length `n`: the one window of every STFT in the workspace
/// (analysis, comparison, statistics' transients, grain segmentation).
pub fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 0.5 - 0.5 * (TAU * i as f64 / n as f64).cos())
        .collect()
}

/// [`mode_basis`] at frame 0 of bin `k` and the factors that advance it by one frame:
/// `(P_m, Q_m) = (P_0 · p_step^m, Q_0 · q_step^m)`, since a frame shift multiplies each
/// term by `z^hop`. Four exponentials per bin instead of per cell.
pub fn mode_basis_column(
    spec: &Spectrogram,
    freq_hz: f64,
    damping_per_s: f64,
    k: usize,
) -> [Complex64; 4] {
    let (p0, q0) = mode_basis(spec, freq_hz, damping_per_s, 0, k);
    let fs = spec.sample_rate_hz;
    let h = spec.hop as f64;
    let sigma = -damping_per_s / fs;
    let omega = TAU * freq_hz / fs;
    let p_step = Complex64::new(sigma * h, omega * h).exp();
    let q_step = Complex64::new(sigma * h, -omega * h).exp();
    [p0, q0, p_step, q_step]
}

/// [`mode_basis_column`] for many bins of one mode, with two `sin_cos` per bin instead of
/// about forty transcendental calls.
///
/// With the layout's zero padding (`fft_len = 2W`), `ω_k W = πk`, so the numerator
/// `e^{ℓW} − 1` of the three geometric sums of the Hann window is the same for all three and
/// changes with `k` only by a quarter turn of its half angle; the denominators `e^{ℓ} − 1`,
/// `e^{ℓ ± jβ} − 1` (β = 2π/W) come from one half-angle `sin_cos` by angle addition. Every
/// `e^x − 1` is formed as `expm1(σ)·cos θ − 2 sin²(θ/2) + j e^σ sin θ`, which keeps full
/// relative precision when both the damping and the offset from the bin are tiny.
#[derive(Clone, Debug)]
pub struct ModeColumns {
    /// Set when the layout is not zero-padded to 2W: columns then come from [`mode_basis`].
    direct: Option<(Layout, f64, f64)>,
    window: f64,
    sigma: f64,
    omega: f64,
    bin_step: f64,
    em1_sigma: f64,
    e_sigma: f64,
    em1_sigma_w: f64,
    e_sigma_w: f64,
    half_w: (f64, f64),
    half_beta: (f64, f64),
    p_step: Complex64,
    q_step: Complex64,
}

impl ModeColumns {
    /// Prepares the columns of the mode `(freq_hz, damping_per_s)` in `spec`'s layout (any
    /// layout; the fast path needs `fft_len = 2W`, which [`Spectrogram::compute`] uses).
    pub fn new(spec: &Spectrogram, freq_hz: f64, damping_per_s: f64) -> Self {
        let direct = (spec.fft_len != 2 * spec.window_len)
            .then(|| (Layout::of(spec), freq_hz, damping_per_s));
        let fs = spec.sample_rate_hz;
        let w = spec.window_len as f64;
        let sigma = -damping_per_s / fs;
        let omega = TAU * freq_hz / fs;
        let h = spec.hop as f64;
        Self {
            direct,
            window: w,
            sigma,
            omega,
            bin_step: TAU / spec.fft_len as f64,
            em1_sigma: sigma.exp_m1(),
            e_sigma: sigma.exp(),
            em1_sigma_w: (sigma * w).exp_m1(),
            e_sigma_w: (sigma * w).exp(),
            half_w: (0.5 * omega * w).sin_cos(),
            half_beta: (0.5 * TAU / w).sin_cos(),
            p_step: Complex64::new(sigma * h, omega * h).exp(),
            q_step: Complex64::new(sigma * h, -omega * h).exp(),
        }
    }

    /// `e^{σ(+W)} e^{jθ} − 1` from `(sin θ/2, cos θ/2)`.
    #[inline]
    fn em1(em1: f64, e: f64, (s, c): (f64, f64)) -> Complex64 {
        let cos = 1.0 - 2.0 * s * s;
        Complex64::new(em1 * cos - 2.0 * s * s, e * 2.0 * s * c)
    }

    /// `Σ_τ hann[τ] e^{ℓτ}` for `ℓ = σ + jθ`, with `(sin θ/2, cos θ/2)` and the numerator's
    /// half angle `half_n` given.
    #[inline]
    fn hann_sum_half(&self, theta: f64, (s, c): (f64, f64), half_n: (f64, f64)) -> Complex64 {
        let n = Self::em1(self.em1_sigma_w, self.e_sigma_w, half_n);
        let (sb, cb) = self.half_beta;
        let up = (s * cb + c * sb, c * cb - s * sb);
        let down = (s * cb - c * sb, c * cb + s * sb);
        let g = |half: (f64, f64), angle: f64| {
            let d = Self::em1(self.em1_sigma, self.e_sigma, half);
            if d.norm_sqr() > 1e-14 {
                n / d
            } else {
                // ℓ' ≈ 0 (mod 2πj): second-order series of the geometric sum.
                let l = Complex64::new(self.sigma, angle - TAU * (angle / TAU).round());
                Complex64::new(self.window, 0.0) + l * (self.window * (self.window - 1.0) / 2.0)
            }
        };
        let beta = TAU / self.window;
        g((s, c), theta) * 0.5 - (g(up, theta + beta) + g(down, theta - beta)) * 0.25
    }

    /// `[P_0, Q_0, p_step, q_step]` of bin `k`, as [`mode_basis_column`] returns them.
    #[inline]
    pub fn column(&self, k: usize) -> [Complex64; 4] {
        let wk = self.bin_step * k as f64;
        let pos = (0.5 * (self.omega - wk)).sin_cos();
        let neg = (0.5 * (-self.omega - wk)).sin_cos();
        self.column_with(k, pos, neg)
    }

    /// [`Self::column`] with the half angles `(sin, cos)` of `±ω − ω_k` given.
    #[inline]
    fn column_with(&self, k: usize, half_pos: (f64, f64), half_neg: (f64, f64)) -> [Complex64; 4] {
        if let Some((layout, f, d)) = &self.direct {
            let (p, q) = layout.mode_basis(*f, *d, 0, k);
            return [p, q, self.p_step, self.q_step];
        }
        let wk = self.bin_step * k as f64;
        // Half angle of the numerator, (±ωW − πk)/2: the mode's half angle turned by k
        // quarter turns.
        let (sw, cw) = self.half_w;
        let quarter = |s: f64, c: f64| match k % 4 {
            0 => (s, c),
            1 => (-c, s),
            2 => (-s, -c),
            _ => (c, -s),
        };
        let pos = self.hann_sum_half(self.omega - wk, half_pos, quarter(sw, cw));
        let neg = self.hann_sum_half(-self.omega - wk, half_neg, quarter(-sw, cw));
        let half_j = Complex64::new(0.0, 0.5);
        [-(half_j * pos), half_j * neg, self.p_step, self.q_step]
    }

    /// [`Self::column`] of every bin `lo..=hi` in order, handed to `f` with its bin. From one
    /// bin to the next both half angles turn by the same step, so they advance by a rotation
    /// (four products) instead of two `sin_cos`; an exact `sin_cos` every
    /// [`Self::REANCHOR`] bins keeps the rounding of the rotations near 1e-14.
    pub fn for_each_column(&self, lo: usize, hi: usize, mut f: impl FnMut(usize, [Complex64; 4])) {
        let (sd, cd) = (-0.5 * self.bin_step).sin_cos();
        let turn = |(s, c): (f64, f64)| (s * cd + c * sd, c * cd - s * sd);
        let (mut pos, mut neg) = ((0.0, 1.0), (0.0, 1.0));
        for k in lo..=hi {
            if (k - lo).is_multiple_of(Self::REANCHOR) {
                let wk = self.bin_step * k as f64;
                pos = (0.5 * (self.omega - wk)).sin_cos();
                neg = (0.5 * (-self.omega - wk)).sin_cos();
            } else {
                pos = turn(pos);
                neg = turn(neg);
            }
            f(k, self.column_with(k, pos, neg));
        }
    }

    /// [`Self::for_each_column`] without the negative-frequency term: `[P_0, p_step]` of every
    /// bin `lo..=hi`, for bins far from the mode's mirror image at `−f` (and its alias at
    /// `fs − f`), where `Q` is below the window's leakage already left out.
    pub fn for_each_positive_column(
        &self,
        lo: usize,
        hi: usize,
        mut f: impl FnMut(usize, [Complex64; 2]),
    ) {
        if self.direct.is_some() {
            return self.for_each_column(lo, hi, |k, [p, _, ps, _]| f(k, [p, ps]));
        }
        let (sd, cd) = (-0.5 * self.bin_step).sin_cos();
        let turn = |(s, c): (f64, f64)| (s * cd + c * sd, c * cd - s * sd);
        let mut pos = (0.0, 1.0);
        let (sw, cw) = self.half_w;
        let half_j = Complex64::new(0.0, 0.5);
        for k in lo..=hi {
            if (k - lo).is_multiple_of(Self::REANCHOR) {
                pos = (0.5 * (self.omega - self.bin_step * k as f64)).sin_cos();
            } else {
                pos = turn(pos);
            }
            let wk = self.bin_step * k as f64;
            let half_n = match k % 4 {
                0 => (sw, cw),
                1 => (-cw, sw),
                2 => (-sw, -cw),
                _ => (cw, -sw),
            };
            let p = self.hann_sum_half(self.omega - wk, pos, half_n);
            f(k, [-(half_j * p), self.p_step]);
        }
    }

    /// Bins between exact half angles in [`Self::for_each_column`].
    pub const REANCHOR: usize = 32;
}

/// `A` and `conj(A)` of a mode, where its spectrogram is `A·P + conj(A)·Q` with `(P, Q)` from
/// [`mode_basis`] and `A = a e^{jθ}`.
pub fn amplitude_coefficients(mode: &resound_core::DampedMode) -> (Complex64, Complex64) {
    let a = Complex64::from_polar(mode.amplitude, mode.phase_rad);
    (a, a.conj())
}

/// `e^z − 1` for complex `z`, accurate for small |z|.
#[inline]
fn expm1c(z: Complex64) -> Complex64 {
    let (s, c) = z.im.sin_cos();
    let half = (0.5 * z.im).sin();
    Complex64::new(z.re.exp_m1() * c - 2.0 * half * half, z.re.exp() * s)
}

/// `Σ_{τ=0}^{W−1} e^{ℓ τ}` for complex log-ratio `ℓ`.
#[inline]
fn geometric(l: Complex64, w: usize) -> Complex64 {
    if l.norm() < 1e-9 {
        // Second-order series; the relative error is below 1e-12 here.
        let wf = w as f64;
        return Complex64::new(wf, 0.0) + l * (wf * (wf - 1.0) / 2.0);
    }
    expm1c(l * w as f64) / expm1c(l)
}

/// `Σ_τ hann[τ] e^{ℓ τ}`: the Hann window as three complex exponentials.
#[inline]
fn hann_sum(l: Complex64, w: usize) -> Complex64 {
    let beta = Complex64::new(0.0, TAU / w as f64);
    geometric(l, w) * 0.5 - (geometric(l + beta, w) + geometric(l - beta, w)) * 0.25
}

/// The spectrogram cell (frame `m`, bin `k`) of `a e^{−dt} sin(2πft + θ)` is
/// `A·P + conj(A)·Q` with `A = a e^{jθ}`; this returns `(P, Q)`.
///
/// With `z = e^{(−d + j2πf)/fs}`: `sin` contributes `(A z^n − conj(A) conj(z)^n) / 2j`, and each
/// term's windowed DFT at frame start `s` is `z^s Σ_τ w[τ] (z e^{−jω_k})^τ`.
pub fn mode_basis(
    spec: &Spectrogram,
    freq_hz: f64,
    damping_per_s: f64,
    m: usize,
    k: usize,
) -> (Complex64, Complex64) {
    Layout::of(spec).mode_basis(freq_hz, damping_per_s, m, k)
}

/// The sizes of a spectrogram that its closed form needs.
#[derive(Clone, Copy, Debug)]
struct Layout {
    sample_rate_hz: f64,
    hop: usize,
    fft_len: usize,
    window_len: usize,
}

impl Layout {
    fn of(spec: &Spectrogram) -> Self {
        Self {
            sample_rate_hz: spec.sample_rate_hz,
            hop: spec.hop,
            fft_len: spec.fft_len,
            window_len: spec.window_len,
        }
    }

    fn mode_basis(
        &self,
        freq_hz: f64,
        damping_per_s: f64,
        m: usize,
        k: usize,
    ) -> (Complex64, Complex64) {
        let fs = self.sample_rate_hz;
        let s = (m * self.hop) as f64;
        let wk = TAU * k as f64 / self.fft_len as f64;
        let sigma = -damping_per_s / fs;
        let omega = TAU * freq_hz / fs;
        let half_j = Complex64::new(0.0, 0.5); // 1 / (2j) = −j/2
        let pos_start = Complex64::new(sigma * s, omega * s).exp();
        let neg_start = Complex64::new(sigma * s, -omega * s).exp();
        let pos = hann_sum(Complex64::new(sigma, omega - wk), self.window_len);
        let neg = hann_sum(Complex64::new(sigma, -omega - wk), self.window_len);
        // 1/(2j) = −j/2.
        (-(half_j * pos_start * pos), half_j * neg_start * neg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::{damped::synthesize, DampedMode};

    #[test]
    fn fast_columns_match_the_direct_closed_form() {
        let x = vec![0.0; 48000];
        let spec = Spectrogram::compute(&x, 48000.0, 1024).unwrap();
        let bin = spec.bin_width_hz();
        let beta_hz = 2.0 * bin;
        for f in [
            1000.0,
            37.0 * bin,
            37.0 * bin + beta_hz,
            37.0 * bin - 1e-9,
            23_990.0,
            24_000.0 - bin,
            15.2,
        ] {
            for d in [1e-3, 1.5, 50.0, 2900.0] {
                let fast = ModeColumns::new(&spec, f, d);
                let cols: Vec<[Complex64; 4]> = (0..spec.bins)
                    .map(|k| mode_basis_column(&spec, f, d, k))
                    .collect();
                let peak = cols
                    .iter()
                    .map(|c| c[0].norm().max(c[1].norm()))
                    .fold(0.0, f64::max);
                // Bin by bin, and every bin in one sweep (half angles by rotation).
                let mut swept = Vec::new();
                fast.for_each_column(0, spec.bins - 1, |k, c| swept.push((k, c)));
                assert_eq!(swept.len(), spec.bins);
                // The positive term alone, from any first bin.
                let mut positive = Vec::new();
                fast.for_each_positive_column(5, spec.bins - 1, |k, c| positive.push((k, c)));
                assert_eq!(positive.len(), spec.bins - 5);
                for (k, [p, ps]) in positive {
                    assert!((p - cols[k][0]).norm() <= 1e-9 * peak, "f {f} d {d} k {k}");
                    assert_eq!(ps, cols[k][2]);
                }
                for (k, want) in cols.iter().enumerate() {
                    assert_eq!(swept[k].0, k);
                    for got in [fast.column(k), swept[k].1] {
                        for i in 0..4 {
                            let scale = if i < 2 { peak } else { 1.0 };
                            assert!(
                                (got[i] - want[i]).norm() <= 1e-9 * scale,
                                "f {f} d {d} k {k} term {i}: {} vs {}",
                                got[i],
                                want[i]
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn closed_form_matches_fft() {
        let fs = 44100.0;
        let modes = [
            DampedMode {
                freq_hz: 440.3,
                damping_per_s: 7.0,
                amplitude: 0.5,
                phase_rad: 1.1,
            },
            DampedMode {
                freq_hz: 21_900.0,
                damping_per_s: 300.0,
                amplitude: 0.2,
                phase_rad: -2.0,
            },
            DampedMode {
                freq_hz: 25.0,
                damping_per_s: 0.2,
                amplitude: 0.3,
                phase_rad: 0.3,
            },
        ];
        for mode in modes {
            let x = synthesize(&[mode], fs, 8192);
            let spec = Spectrogram::compute(&x, fs, 1024).unwrap();
            let (a, ac) = amplitude_coefficients(&mode);
            let mut max_err: f64 = 0.0;
            let mut max_val: f64 = 0.0;
            for m in [0, 3, 17] {
                for k in 0..spec.bins {
                    let (p, q) = mode_basis(&spec, mode.freq_hz, mode.damping_per_s, m, k);
                    let model = a * p + ac * q;
                    max_err = max_err.max((model - spec.at(m, k)).norm());
                    max_val = max_val.max(spec.at(m, k).norm());
                }
            }
            assert!(max_err < 1e-9 * max_val, "{mode:?}: {max_err} vs {max_val}");
            let mut sub = spec.clone();
            sub.subtract_mode(&mode, 1e-12);
            let rest = sub.data.iter().map(|c| c.norm()).fold(0.0, f64::max);
            assert!(
                rest < 1e-3 * max_val,
                "subtraction leaves {rest} of {max_val}"
            );
        }
    }
}
