//! The resonator bank: every mode an exactly discretized damped oscillator driven by a force.
//!
//! A mode with unit-impulse response `h(t) = g e^(−dt) sin(ωt)` (g: output amplitude per N·s at
//! the contact) is discretized impulse-invariantly as the complex one-pole
//! `z[n] = p z[n−1] + b x[n]`, `y[n] = Im z[n]`, with `p = e^((−d + jω)T)` and `b = T g`: then
//! `y[n] = Σ_m x[m] T g e^(−d(n−m)T) sin(ω(n−m)T)`, the exact sampled convolution of the force
//! `x` (N) with `h`. Coefficients are computed in f64, state and arithmetic are f32.
//!
//! **Precision.** In f32, `p` of a low mode at a high rate sits within 1e-5 of 1, where the f32
//! grid (6e-8) makes `|p|` off by up to 3e-8 per sample: 1.4 % of amplitude after 5 s at
//! 96 kHz. So every [`CORRECTION_PERIOD`] samples (on a fixed grid of the bank's clock, so the
//! output does not depend on how a caller splits its blocks) the state is multiplied by
//! `(p_exact / p_f32)^period`, computed in f64. What remains is the rounding of the state, a
//! random walk of about 6e-8 per sample (≈ 4e-5 after 480 000 samples); the test holds the bank
//! to 2e-4 of the peak against an f64 sum of damped sinusoids over 5 s at 96 kHz.
//!
//! **SIMD.** Modes are stored in chunks of [`LANES`] (struct of arrays); the per-sample update of
//! a chunk is plain arithmetic over fixed-size arrays, which LLVM vectorizes, compiled with
//! AVX2+FMA when the CPU has them (pulp's runtime dispatch). Each chunk adds into a per-lane
//! accumulator, summed across lanes once per block. The operations and their order do not
//! depend on the instruction set, so all paths give identical output.
//!
//! **Contact inputs.** A force drives the modes through the gains of the point it acts at. Forces
//! at different points that overlap in time (a box on two corners, an impact while it slides) each
//! need their own gains, so the bank has [`INPUTS`] inputs, each with its own gain per mode
//! ([`ModalBank::set_input_gains`], [`ModalBank::process_inputs`]): `z[n] = p z[n−1] + Σ_i b_i
//! x_i[n]`. One input at a time runs the same arithmetic as [`ModalBank::process`].
//!
//! **Culling.** Modes are sorted by decay rate at preparation, so a chunk holds modes that fade
//! together. A chunk whose every lane has fallen below the audibility threshold while no force
//! arrives is zeroed and skipped until the next force.

use crate::SynthError;

/// Modes per chunk (two AVX2 vectors).
pub const LANES: usize = 16;
/// Samples between drift corrections.
pub const CORRECTION_PERIOD: usize = 1024;
/// Inputs (contact points with their own gains) a bank can be driven through at once.
pub const INPUTS: usize = 4;
/// Samples per accumulator block.
const BLOCK: usize = 256;

/// One mode as the bank sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BankMode {
    /// Damped frequency, Hz.
    pub freq_hz: f64,
    /// Amplitude decay rate, 1/s.
    pub damping_per_s: f64,
    /// Output amplitude per unit impulse (1 N·s) at the contact; the sign is the phase.
    pub gain: f64,
}

#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Chunk {
    zr: [f32; LANES],
    zi: [f32; LANES],
    pr: [f32; LANES],
    pi: [f32; LANES],
    b: [f32; LANES],
    cr: [f32; LANES],
    ci: [f32; LANES],
    active: bool,
}

/// A bank of resonators (one sounding object).
#[derive(Clone, Debug)]
pub struct ModalBank {
    sample_rate_hz: f64,
    chunks: Vec<Chunk>,
    /// Mode index (as given to [`ModalBank::configure`]) of each lane, `usize::MAX` for padding.
    order: Vec<usize>,
    modes: usize,
    clock: usize,
    acc: Vec<[f32; LANES]>,
    cull_level: f32,
    scalar_only: bool,
    /// Frequency (Hz) and own decay rate (1/s) of each lane, in lane order.
    lanes: Vec<(f64, f64)>,
    /// Added loss factor η (contact damping): each mode decays `π f η` 1/s faster.
    extra_loss: f64,
    /// The gains of inputs 1.. ([`ModalBank::set_input_gains`]), per chunk (input 0's are in
    /// the chunk, next to the state the single-input path reads).
    extra_b: Vec<[[f32; LANES]; INPUTS - 1]>,
}

/// The f32 pole `p = e^((−d + jω)T)` and the f32 drift correction `(p / p32)^period` of a mode.
fn pole(freq_hz: f64, damping_per_s: f64, t: f64) -> (f32, f32, f32, f32) {
    let r = (-damping_per_s * t).exp();
    let (s, co) = (std::f64::consts::TAU * freq_hz * t).sin_cos();
    let (pr, pi) = (r * co, r * s);
    let (pr32, pi32) = (pr as f32, pi as f32);
    // (p / p32)^period in f64: the drift the f32 pole accumulates, undone.
    let (qr, qi) = (f64::from(pr32), f64::from(pi32));
    let q2 = qr * qr + qi * qi;
    let (rr, ri) = ((pr * qr + pi * qi) / q2, (pi * qr - pr * qi) / q2);
    let mag = (rr * rr + ri * ri).sqrt().powi(CORRECTION_PERIOD as i32);
    let ang = ri.atan2(rr) * CORRECTION_PERIOD as f64;
    (
        pr32,
        pi32,
        (mag * ang.cos()) as f32,
        (mag * ang.sin()) as f32,
    )
}

impl ModalBank {
    /// Allocates a bank for up to `capacity` modes at `sample_rate_hz`. Modes below
    /// `cull_level` (output amplitude) with no force arriving are skipped.
    pub fn with_capacity(
        sample_rate_hz: f64,
        capacity: usize,
        cull_level: f32,
    ) -> Result<Self, SynthError> {
        if !(1000.0..=768_000.0).contains(&sample_rate_hz) {
            return Err(SynthError::SampleRate(sample_rate_hz));
        }
        if !(cull_level >= 0.0 && cull_level.is_finite()) {
            return Err(SynthError::Parameter(format!(
                "cull level must be finite and ≥ 0, got {cull_level}"
            )));
        }
        let chunks = capacity.div_ceil(LANES);
        Ok(Self {
            sample_rate_hz,
            chunks: Vec::with_capacity(chunks),
            order: Vec::with_capacity(chunks * LANES),
            modes: 0,
            clock: 0,
            acc: vec![[0.0; LANES]; BLOCK],
            cull_level,
            scalar_only: false,
            lanes: Vec::with_capacity(chunks * LANES),
            extra_loss: 0.0,
            extra_b: Vec::with_capacity(chunks),
        })
    }

    /// A bank holding `modes`.
    pub fn new(
        sample_rate_hz: f64,
        modes: &[BankMode],
        cull_level: f32,
    ) -> Result<Self, SynthError> {
        let mut b = Self::with_capacity(sample_rate_hz, modes.len(), cull_level)?;
        b.configure(modes)?;
        Ok(b)
    }

    /// Forces the portable code path (for the benchmark's baseline).
    pub fn set_scalar_only(&mut self, on: bool) {
        self.scalar_only = on;
    }

    /// Sample rate, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// Replaces the modes and silences the bank; allocation-free within the capacity.
    /// Modes at or above Nyquist, with non-finite values or negative damping are skipped.
    pub fn configure(&mut self, modes: &[BankMode]) -> Result<(), SynthError> {
        let usable = |m: &BankMode| {
            m.freq_hz > 0.0
                && m.freq_hz < 0.5 * self.sample_rate_hz
                && m.damping_per_s >= 0.0
                && m.damping_per_s.is_finite()
                && m.gain.is_finite()
        };
        let n = modes.iter().filter(|m| usable(m)).count();
        if n.div_ceil(LANES) > self.chunks.capacity() {
            return Err(SynthError::Capacity {
                wanted: n,
                capacity: self.chunks.capacity() * LANES,
            });
        }
        // Sort by decay rate (fast decays first) so chunks fade together; the order buffer is
        // preallocated, and an insertion sort keeps this allocation-free.
        self.order.clear();
        self.order
            .extend((0..modes.len()).filter(|&i| usable(&modes[i])));
        for i in 1..self.order.len() {
            let mut j = i;
            while j > 0
                && modes[self.order[j - 1]].damping_per_s < modes[self.order[j]].damping_per_s
            {
                self.order.swap(j - 1, j);
                j -= 1;
            }
        }
        self.chunks.clear();
        self.lanes.clear();
        self.extra_b.clear();
        let t = 1.0 / self.sample_rate_hz;
        let eta = self.extra_loss;
        for c in 0..n.div_ceil(LANES) {
            let mut chunk = Chunk::default();
            for l in 0..LANES {
                let Some(&i) = self.order.get(c * LANES + l) else {
                    chunk.cr[l] = 1.0;
                    self.lanes.push((0.0, 0.0));
                    continue;
                };
                let m = &modes[i];
                self.lanes.push((m.freq_hz, m.damping_per_s));
                let d = m.damping_per_s + std::f64::consts::PI * m.freq_hz * eta;
                (chunk.pr[l], chunk.pi[l], chunk.cr[l], chunk.ci[l]) = pole(m.freq_hz, d, t);
                chunk.b[l] = (t * m.gain) as f32;
            }
            self.chunks.push(chunk);
            self.extra_b.push([[0.0; LANES]; INPUTS - 1]);
        }
        self.modes = n;
        self.clock = 0;
        Ok(())
    }

    /// Sets each mode's gain (output amplitude per N·s, indexed as the modes given to
    /// [`ModalBank::configure`]), e.g. for a new contact point: input 0's gains.
    /// Allocation-free.
    pub fn set_gains(&mut self, gains: &[f64]) {
        self.set_input_gains(0, gains);
    }

    /// Sets input `input`'s gain per mode (as [`Self::set_gains`]); inputs past [`INPUTS`] are
    /// ignored. Each input starts with gains 0 except input 0, which has the configured ones.
    /// Allocation-free.
    pub fn set_input_gains(&mut self, input: usize, gains: &[f64]) {
        let t = 1.0 / self.sample_rate_hz;
        for (c, (chunk, extra)) in self.chunks.iter_mut().zip(&mut self.extra_b).enumerate() {
            let b = match input {
                0 => &mut chunk.b,
                i if i < INPUTS => &mut extra[i - 1],
                _ => return,
            };
            for (l, bl) in b.iter_mut().enumerate() {
                if let Some(&i) = self.order.get(c * LANES + l) {
                    *bl = (t * gains.get(i).copied().unwrap_or(0.0)) as f32;
                }
            }
        }
    }

    /// Adds contact damping: every mode decays `π f η` 1/s faster than its own rate (a loss
    /// factor η, from 0: none). The state is kept, so the sound goes on without a step, only
    /// fading faster. Allocation-free; a few transcendental functions per mode, so callers
    /// change it when the contact changes, not every sample.
    pub fn set_extra_loss(&mut self, eta: f64) {
        let eta = if eta.is_finite() {
            eta.clamp(0.0, 1.0)
        } else {
            0.0
        };
        if eta == self.extra_loss {
            return;
        }
        self.extra_loss = eta;
        let t = 1.0 / self.sample_rate_hz;
        for (c, chunk) in self.chunks.iter_mut().enumerate() {
            for l in 0..LANES {
                if self.order.get(c * LANES + l).is_none() {
                    continue;
                }
                let (f, d0) = self.lanes[c * LANES + l];
                let d = d0 + std::f64::consts::PI * f * eta;
                (chunk.pr[l], chunk.pi[l], chunk.cr[l], chunk.ci[l]) = pole(f, d, t);
            }
        }
    }

    /// The added loss factor (see [`Self::set_extra_loss`]).
    pub fn extra_loss(&self) -> f64 {
        self.extra_loss
    }

    /// Modes in the bank.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// Modes in chunks that are currently running (not culled).
    pub fn active_modes(&self) -> usize {
        self.chunks.iter().filter(|c| c.active).count() * LANES
    }

    /// Whether every chunk is culled (the object is silent).
    pub fn is_silent(&self) -> bool {
        self.chunks.iter().all(|c| !c.active)
    }

    /// Current output amplitude bound: Σ |z| over the modes (for voice priorities).
    pub fn level(&self) -> f32 {
        self.chunks
            .iter()
            .filter(|c| c.active)
            .map(|c| {
                (0..LANES)
                    .map(|l| (c.zr[l] * c.zr[l] + c.zi[l] * c.zi[l]).sqrt())
                    .sum::<f32>()
            })
            .sum()
    }

    /// Changes the level (output amplitude) below which modes with no force arriving are
    /// culled: raised under overload, modes are dropped by audibility. Never allocates.
    pub fn set_cull_level(&mut self, cull_level: f32) {
        if cull_level >= 0.0 && cull_level.is_finite() {
            self.cull_level = cull_level;
        }
    }

    /// The level below which modes are culled.
    pub fn cull_level(&self) -> f32 {
        self.cull_level
    }

    /// Silences every mode.
    pub fn reset(&mut self) {
        for c in &mut self.chunks {
            c.zr = [0.0; LANES];
            c.zi = [0.0; LANES];
            c.active = false;
        }
    }

    /// Adds the bank's free ringing (no force) into `out`: the same as [`Self::process`] with
    /// a force of zeros. Never allocates, locks or blocks.
    pub fn ring(&mut self, out: &mut [f32]) {
        for o in out.chunks_mut(BLOCK) {
            self.process(&ZEROS[..o.len()], o);
        }
    }

    /// Adds the bank's response to `force` (N per sample, same length as `out`) into `out`,
    /// through input 0. Never allocates, locks or blocks.
    pub fn process(&mut self, force: &[f32], out: &mut [f32]) {
        let n = force.len().min(out.len());
        let scalar = self.scalar_only;
        self.segments(&mut out[..n], |chunks, _, acc, start| {
            let x = &force[start..start + acc.len()];
            let silent_input = is_silent(x);
            if scalar {
                run_chunks_one(chunks, x, acc, silent_input);
            } else {
                pulp::Arch::new().dispatch(|| run_chunks_one(chunks, x, acc, silent_input));
            }
        });
    }

    /// Adds the bank's response to the forces on its inputs (`forces[i]`: input `i`'s force, N
    /// per sample, at least as long as `out`, or empty for none) into `out`. Never allocates,
    /// locks or blocks.
    pub fn process_inputs(&mut self, forces: &[&[f32]; INPUTS], out: &mut [f32]) {
        let scalar = self.scalar_only;
        self.segments(out, |chunks, extra, acc, start| {
            let len = acc.len();
            // The inputs that carry force in this segment.
            let mut active = [(0usize, &[] as &[f32]); INPUTS];
            let mut k = 0;
            for (i, f) in forces.iter().enumerate() {
                if let Some(x) = f.get(start..start + len).filter(|x| !is_silent(x)) {
                    active[k] = (i, x);
                    k += 1;
                }
            }
            let active = &active[..k];
            if scalar {
                run_chunks(chunks, extra, active, acc);
            } else {
                pulp::Arch::new().dispatch(|| run_chunks(chunks, extra, active, acc));
            }
        });
    }

    /// Renders `out` in segments that end at block ends and at the correction grid:
    /// `segment(chunks, extra gains, accumulator, start)` runs the chunks over the segment
    /// from `start` (its length is the accumulator's); then the lanes are summed into `out`
    /// and the drift is corrected on the grid.
    #[inline(always)]
    fn segments(
        &mut self,
        out: &mut [f32],
        mut segment: impl FnMut(&mut [Chunk], &[[[f32; LANES]; INPUTS - 1]], &mut [[f32; LANES]], usize),
    ) {
        let n = out.len();
        let mut start = 0;
        while start < n {
            let to_grid = CORRECTION_PERIOD - self.clock % CORRECTION_PERIOD;
            let len = (n - start).min(BLOCK).min(to_grid);
            let acc = &mut self.acc[..len];
            for a in acc.iter_mut() {
                *a = [0.0; LANES];
            }
            segment(&mut self.chunks, &self.extra_b, acc, start);
            for (o, a) in out[start..start + len].iter_mut().zip(acc.iter()) {
                *o += a.iter().sum::<f32>();
            }
            self.clock += len;
            if self.clock.is_multiple_of(CORRECTION_PERIOD) {
                self.correct_and_cull();
            }
            start += len;
        }
    }

    fn correct_and_cull(&mut self) {
        let floor = self.cull_level * self.cull_level;
        for c in self.chunks.iter_mut().filter(|c| c.active) {
            let mut loudest = 0.0f32;
            for l in 0..LANES {
                let (zr, zi) = (c.zr[l], c.zi[l]);
                c.zr[l] = zr * c.cr[l] - zi * c.ci[l];
                c.zi[l] = zr * c.ci[l] + zi * c.cr[l];
                loudest = loudest.max(c.zr[l] * c.zr[l] + c.zi[l] * c.zi[l]);
            }
            if loudest < floor {
                c.zr = [0.0; LANES];
                c.zi = [0.0; LANES];
                c.active = false;
            }
        }
    }
}

/// The single-input path ([`ModalBank::process`]): input 0's gains, kept apart from the
/// several-input one so the common case runs exactly this loop.
#[inline(always)]
fn run_chunks_one(chunks: &mut [Chunk], x: &[f32], acc: &mut [[f32; LANES]], silent_input: bool) {
    for c in chunks.iter_mut() {
        if !c.active {
            if silent_input {
                continue;
            }
            c.active = true;
        }
        let b = c.b;
        run_chunk(c, b, x, acc);
    }
}

/// Runs every chunk over one segment; `active`: the inputs with force (index, samples).
#[inline(always)]
fn run_chunks(
    chunks: &mut [Chunk],
    extra: &[[[f32; LANES]; INPUTS - 1]],
    active: &[(usize, &[f32])],
    acc: &mut [[f32; LANES]],
) {
    let gains = |c: &Chunk, e: &[[f32; LANES]; INPUTS - 1], i: usize| {
        if i == 0 {
            c.b
        } else {
            e[i - 1]
        }
    };
    match active {
        // Free ringing: the chunks still sounding, with a zero force.
        [] => {
            let zeros = &ZEROS[..acc.len()];
            for c in chunks.iter_mut().filter(|c| c.active) {
                let b = c.b;
                run_chunk(c, b, zeros, acc);
            }
        }
        [(i, x)] => {
            for (c, e) in chunks.iter_mut().zip(extra) {
                c.active = true;
                let b = gains(c, e, *i);
                run_chunk(c, b, x, acc);
            }
        }
        _ => {
            for (c, e) in chunks.iter_mut().zip(extra) {
                c.active = true;
                let mut b = [[0.0; LANES]; INPUTS];
                for (bk, (i, _)) in b.iter_mut().zip(active) {
                    *bk = gains(c, e, *i);
                }
                run_chunk_inputs(c, &b[..active.len()], active, acc);
            }
        }
    }
}

/// Every sample ±0 (an OR of the bits less the sign, without early exits, so it vectorizes).
#[inline(always)]
fn is_silent(x: &[f32]) -> bool {
    x.iter().fold(0u32, |a, &v| a | (v.to_bits() << 1)) == 0
}

/// A segment of zero force.
static ZEROS: [f32; BLOCK] = [0.0; BLOCK];

/// One chunk over a segment driven through one input with gains `b`.
#[inline(always)]
fn run_chunk(c: &mut Chunk, b: [f32; LANES], x: &[f32], acc: &mut [[f32; LANES]]) {
    let (mut zr, mut zi) = (c.zr, c.zi);
    let (pr, pi) = (c.pr, c.pi);
    for (&xn, a) in x.iter().zip(acc.iter_mut()) {
        for l in 0..LANES {
            let r = pr[l] * zr[l] - pi[l] * zi[l] + b[l] * xn;
            let i = pr[l] * zi[l] + pi[l] * zr[l];
            zr[l] = r;
            zi[l] = i;
            a[l] += i;
        }
    }
    c.zr = zr;
    c.zi = zi;
}

/// One chunk over a segment driven through several inputs at once (`b[k]`: the gains of
/// `active[k]`).
#[inline(always)]
fn run_chunk_inputs(
    c: &mut Chunk,
    b: &[[f32; LANES]],
    active: &[(usize, &[f32])],
    acc: &mut [[f32; LANES]],
) {
    let (mut zr, mut zi) = (c.zr, c.zi);
    let (pr, pi) = (c.pr, c.pi);
    for (n, a) in acc.iter_mut().enumerate() {
        let mut u = [0.0f32; LANES];
        for (bk, (_, x)) in b.iter().zip(active) {
            let xn = x[n];
            for l in 0..LANES {
                u[l] += bk[l] * xn;
            }
        }
        for l in 0..LANES {
            let r = pr[l] * zr[l] - pi[l] * zi[l] + u[l];
            let i = pr[l] * zi[l] + pi[l] * zr[l];
            zr[l] = r;
            zi[l] = i;
            a[l] += i;
        }
    }
    c.zr = zr;
    c.zi = zi;
}

/// The reference: the response of `modes` to `force` as an f64 sum over modes and samples of
/// the exact sampled convolution (O(modes × samples × pulse)). For tests and benchmarks.
pub fn reference_response(
    modes: &[BankMode],
    sample_rate_hz: f64,
    force: &[f64],
    len: usize,
) -> Vec<f64> {
    let t = 1.0 / sample_rate_hz;
    let mut out = vec![0.0; len];
    for (m_idx, &f) in force.iter().enumerate() {
        if f == 0.0 {
            continue;
        }
        for m in modes {
            if !(m.freq_hz < 0.5 * sample_rate_hz) {
                continue;
            }
            let w = std::f64::consts::TAU * m.freq_hz;
            for (k, o) in out.iter_mut().enumerate().skip(m_idx) {
                let tau = (k - m_idx) as f64 * t;
                *o += f * t * m.gain * (-m.damping_per_s * tau).exp() * (w * tau).sin();
            }
        }
    }
    out
}
