//! Stage 1 of recording analysis: Ren 2013 §4 feature extraction on multi-level spectrograms.
//!
//! 1. Complex spectrograms at `levels` window lengths, each doubling the frequency resolution of
//!    the one before ([`Spectrogram`]).
//! 2. Global peak search: local maxima along frequency of every level's per-bin maximum over
//!    frames, above that level's noise floor. All peaks of all levels go in one priority queue,
//!    ordered by the amplitude they imply.
//! 3. Greedy local shape fitting from the strongest peak: the mode's (f, d) are found by
//!    Nelder–Mead (argmin) on the residual of its closed-form "hill" ([`crate::stft::mode_basis`]) against a
//!    patch of ±2 bins × up to 16 frames; amplitude and phase are the linear least-squares
//!    solution for each (f, d) (variable projection). A fit whose relative residual exceeds
//!    `fit_tolerance` means this level cannot resolve the mode and the peak is discarded — the
//!    same mode is then taken from another level (dynamic level choice).
//! 4. Accepted modes are subtracted, in the complex domain and in closed form, from every level,
//!    so weaker modes next to strong ones are fitted on what the strong ones left.
//!
//! The result seeds [`crate::refine`], which brings it to the noise limit.

use crate::stft::{ModeColumns, Spectrogram};
use argmin::core::{CostFunction, Error as ArgminError, Executor};
use argmin::solver::neldermead::NelderMead;
use realfft::num_complex::Complex64;
use resound_core::DampedMode;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Settings of [`extract_modes`].
#[derive(Clone, Debug)]
pub struct ExtractParams {
    /// Shortest window (level 0) in samples.
    pub min_window: usize,
    /// Number of levels; level `l` has window `min_window · 2^l`.
    pub levels: usize,
    /// Stop after this many modes.
    pub max_modes: usize,
    /// Ignore modes whose level ([`crate::mode_level`]) is more than this many dB below the
    /// strongest mode's.
    pub min_db: f64,
    /// Peaks must stand this many dB above the level's noise floor.
    pub noise_margin_db: f64,
    /// Largest accepted relative residual of a local shape fit.
    pub fit_tolerance: f64,
}

impl Default for ExtractParams {
    fn default() -> Self {
        Self {
            min_window: 256,
            levels: 7,
            max_modes: 64,
            min_db: 60.0,
            noise_margin_db: 10.0,
            fit_tolerance: 0.25,
        }
    }
}

/// A mode found by [`extract_modes`] and the level it was fitted at.
#[derive(Clone, Copy, Debug)]
pub struct ExtractedMode {
    /// The damped sinusoid.
    pub mode: DampedMode,
    /// Window length of the level the shape fit used.
    pub window_len: usize,
    /// Relative residual of the shape fit.
    pub fit_residual: f64,
}

#[derive(PartialEq)]
struct Candidate {
    amplitude: f64,
    level: usize,
    bin: usize,
    /// Times this peak was put back after a failed fit.
    retries: u8,
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.amplitude.total_cmp(&other.amplitude)
    }
}

/// Per-level working state.
struct Level {
    spec: Spectrogram,
    /// Noise power per cell (|X|²), from the median of all cells.
    noise_power: f64,
}

/// Computes the spectrogram levels that fit in `x`.
pub fn spectrogram_levels(
    x: &[f64],
    sample_rate_hz: f64,
    params: &ExtractParams,
) -> Vec<Spectrogram> {
    use rayon::prelude::*;
    (0..params.levels)
        .into_par_iter()
        .filter_map(|l| Spectrogram::compute(x, sample_rate_hz, params.min_window << l))
        .collect()
}

/// Median of |X|² over all cells, divided by ln 2 (the median of an exponential variable):
/// the noise power per cell when most cells hold noise only.
fn noise_power(spec: &Spectrogram) -> f64 {
    let mut p: Vec<f64> = spec.data.iter().map(|c| c.norm_sqr()).collect();
    let mid = p.len() / 2;
    p.select_nth_unstable_by(mid, f64::total_cmp);
    p[mid] / std::f64::consts::LN_2
}

/// Stage-1 extraction of damped sinusoids from the onset-aligned signal `x`.
/// `known` are modes found before (already removed from `x`): peaks that look like their
/// leftovers are skipped. `reference_level` sets the level ([`crate::mode_level`]) `min_db` is
/// measured from (default: the strongest mode found here).
pub fn extract_modes(
    x: &[f64],
    sample_rate_hz: f64,
    params: &ExtractParams,
    known: &[DampedMode],
    reference_level: Option<f64>,
) -> Vec<ExtractedMode> {
    let mut levels: Vec<Level> = spectrogram_levels(x, sample_rate_hz, params)
        .into_iter()
        .map(|spec| {
            let noise_power = noise_power(&spec);
            Level { spec, noise_power }
        })
        .collect();
    if levels.is_empty() {
        return Vec::new();
    }
    let margin = 10f64.powf(params.noise_margin_db / 10.0);
    let mut heap = BinaryHeap::new();
    for (li, level) in levels.iter().enumerate() {
        let spec = &level.spec;
        let threshold = level.noise_power * ((spec.frames as f64).ln() + 1.0) * margin;
        let peak: Vec<f64> = (0..spec.bins)
            .map(|k| {
                (0..spec.frames)
                    .map(|m| spec.at(m, k).norm_sqr())
                    .fold(0.0, f64::max)
            })
            .collect();
        let mut found: Vec<Candidate> = (1..spec.bins - 1)
            .filter(|&k| peak[k] > peak[k - 1] && peak[k] >= peak[k + 1] && peak[k] > threshold)
            .map(|k| Candidate {
                amplitude: peak[k].sqrt() * spec.amplitude_scale(),
                level: li,
                bin: k,
                retries: 0,
            })
            .collect();
        found.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        found.truncate(2 * params.max_modes.max(16));
        heap.extend(found);
    }

    let mut out: Vec<ExtractedMode> = Vec::new();
    let mut strongest = reference_level.unwrap_or(0.0);
    let min_ratio = 10f64.powf(-params.min_db / 20.0);
    // Peaks whose fit failed; a neighbour's subtraction may make them fit later.
    let mut rejected: Vec<Candidate> = Vec::new();
    let mut failures_in_a_row = 0usize;
    while let Some(c) = heap.pop() {
        // A peak's amplitude is about the mean amplitude over its window, an upper bound of
        // its level within a few dB: stop with 6 dB to spare.
        if out.len() >= params.max_modes || c.amplitude < 0.5 * strongest * min_ratio {
            break;
        }
        let level = &levels[c.level];
        let spec = &level.spec;
        // Lazy update: the residual may have shrunk since this peak was queued.
        let now = (0..spec.frames)
            .map(|m| spec.at(m, c.bin).norm_sqr())
            .fold(0.0, f64::max);
        let still_peak = c.bin > 0
            && c.bin + 1 < spec.bins
            && (0..spec.frames).any(|m| {
                let p = spec.at(m, c.bin).norm_sqr();
                p >= spec.at(m, c.bin - 1).norm_sqr() && p >= spec.at(m, c.bin + 1).norm_sqr()
            });
        let amp_now = now.sqrt() * spec.amplitude_scale();
        let threshold = level.noise_power * ((spec.frames as f64).ln() + 1.0) * margin;
        if !still_peak || now <= threshold {
            continue;
        }
        if amp_now < 0.9 * c.amplitude {
            heap.push(Candidate {
                amplitude: amp_now,
                ..c
            });
            continue;
        }
        // Residue of a mode already taken: skip it.
        let bin_hz = spec.bin_width_hz();
        let f_peak = spec.bin_hz(c.bin);
        if out
            .iter()
            .map(|e| &e.mode)
            .chain(known)
            .any(|m| (m.freq_hz - f_peak).abs() < 2.0 * bin_hz && m.amplitude > 30.0 * amp_now)
        {
            continue;
        }
        // A good fit leaves little more than the patch's noise; two unresolved modes fitted
        // as one leave structure. A fitted amplitude far above the peak is a runaway fit.
        // Ren's dynamic level choice is checked both ways: the modes must also explain what the
        // longer (finer-frequency) levels see, or they are unresolved modes taken as one.
        let acceptable = |(modes, residual, noise_fraction): &(Vec<DampedMode>, f64, f64)| {
            let tolerance = params.fit_tolerance.min(0.02 + 4.0 * noise_fraction);
            *residual <= tolerance
                && modes.iter().all(|m| {
                    crate::plausible(m.freq_hz, m.damping_per_s, sample_rate_hz)
                        && m.amplitude <= 20.0 * amp_now
                })
                && levels[c.level + 1..].iter().all(|l| {
                    residual_at_level(&l.spec, l.noise_power, modes)
                        .is_none_or(|(r, nf)| r <= params.fit_tolerance.min(0.05 + 4.0 * nf))
                })
        };
        let mut accepted = fit_group(spec, level.noise_power, &[c.bin]).filter(acceptable);
        if accepted.is_none() && c.retries == 0 {
            // Two close modes: fit this peak together with its strongest neighbour.
            if let Some(nb) = neighbour_peak(spec, c.bin, threshold.max(1e-3 * now)) {
                accepted = fit_group(spec, level.noise_power, &[c.bin, nb]).filter(acceptable);
            }
        }
        let Some((group, residual, _)) = accepted else {
            if c.retries < 2 {
                rejected.push(Candidate {
                    amplitude: amp_now,
                    ..c
                });
            }
            // Noise-like input: peak after peak fails to look like a mode. Stop searching.
            failures_in_a_row += 1;
            if failures_in_a_row > 3 * params.max_modes.max(16) {
                break;
            }
            continue;
        };
        failures_in_a_row = 0;
        let floor = 1e-4 * (level.noise_power.sqrt() * spec.amplitude_scale()).max(1e-12);
        let window_len = spec.window_len;
        for mode in group {
            strongest = strongest.max(crate::mode_level(&mode, crate::LEVEL_WINDOW_S));
            for l in levels.iter_mut() {
                l.spec.subtract_mode(&mode, floor);
            }
            // Failed peaks near this mode get another chance on the cleaner residual.
            let mut i = 0;
            while i < rejected.len() {
                let r = &rejected[i];
                let s = &levels[r.level].spec;
                if (s.bin_hz(r.bin) - mode.freq_hz).abs() < 6.0 * s.bin_width_hz() {
                    let r = rejected.swap_remove(i);
                    heap.push(Candidate {
                        retries: r.retries + 1,
                        ..r
                    });
                } else {
                    i += 1;
                }
            }
            out.push(ExtractedMode {
                mode,
                window_len,
                fit_residual: residual,
            });
        }
    }
    out.retain(|e| crate::mode_level(&e.mode, crate::LEVEL_WINDOW_S) >= strongest * min_ratio);
    out.sort_by(|a, b| a.mode.freq_hz.total_cmp(&b.mode.freq_hz));
    out
}

/// The local patch of one peak (or of two neighbouring peaks fitted together).
struct Patch<'a> {
    spec: &'a Spectrogram,
    bins: std::ops::RangeInclusive<usize>,
    frames: usize,
}

impl Patch<'_> {
    /// Best complex amplitudes `a e^{jθ}` for the modes `(f, d)` (linear least squares, real
    /// unknowns Re/Im per mode) and the relative residual. A patch fits one mode or two
    /// neighbours ([`fit_group`]); more are refused (`INFINITY`).
    fn solve(&self, fd: &[(f64, f64)]) -> (Vec<Complex64>, f64) {
        match fd {
            [a] => self.solve_fixed::<1, 2>([*a]),
            [a, b] => self.solve_fixed::<2, 4>([*a, *b]),
            _ => (vec![Complex64::new(0.0, 0.0); fd.len()], f64::INFINITY),
        }
    }

    /// [`Self::solve`] for `K` modes, `N = 2K` real unknowns: the Gram matrix and the
    /// right-hand side accumulate in fixed arrays the compiler keeps in registers (this is
    /// the inner loop of every Nelder–Mead step of the extraction).
    fn solve_fixed<const K: usize, const N: usize>(
        &self,
        fd: [(f64, f64); K],
    ) -> (Vec<Complex64>, f64) {
        // Two real unknowns a mode, at most two modes (`flat` below holds 4 × 4).
        const { assert!(N == 2 * K && N <= 4) };
        let mut g = [[0.0; N]; N];
        let mut b = [0.0; N];
        let mut xx = 0.0;
        let columns = fd.map(|(f, d)| ModeColumns::new(self.spec, f, d));
        for k in self.bins.clone() {
            let mut state = columns.each_ref().map(|c| c.column(k));
            for m in 0..self.frames {
                let mut cols = [Complex64::new(0.0, 0.0); N];
                for (j, st) in state.iter_mut().enumerate() {
                    cols[2 * j] = st[0] + st[1];
                    cols[2 * j + 1] = Complex64::new(0.0, 1.0) * (st[0] - st[1]);
                    st[0] *= st[2];
                    st[1] *= st[3];
                }
                let x = self.spec.at(m, k);
                xx += x.norm_sqr();
                for a in 0..N {
                    let ca = cols[a];
                    b[a] += ca.re * x.re + ca.im * x.im;
                    for c in a..N {
                        g[a][c] += ca.re * cols[c].re + ca.im * cols[c].im;
                    }
                }
            }
        }
        let mut flat = [0.0; 16];
        for a in 0..N {
            for c in 0..N {
                flat[a * N + c] = if c < a { g[c][a] } else { g[a][c] };
            }
            flat[a * N + a] *= 1.0 + 1e-12;
        }
        let Some(coef) = crate::refine::cholesky_solve(&mut flat[..N * N], &b, N) else {
            return (vec![Complex64::new(0.0, 0.0); K], f64::INFINITY);
        };
        if !(xx > 0.0) {
            return (vec![Complex64::new(0.0, 0.0); K], f64::INFINITY);
        }
        // Residual of a linear LS fit: |x|² − bᵀ·coef.
        let explained: f64 = coef.iter().zip(&b).map(|(c, b)| c * b).sum();
        let res = (xx - explained).max(0.0) / xx;
        (
            coef.chunks(2).map(|c| Complex64::new(c[0], c[1])).collect(),
            res,
        )
    }
}

struct PatchCost<'a>(&'a Patch<'a>);

impl CostFunction for PatchCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> Result<f64, ArgminError> {
        let fd: Vec<(f64, f64)> = p.chunks(2).map(|q| (q[0], q[1].exp())).collect();
        let (_, r) = self.0.solve(&fd);
        Ok(if r.is_finite() { r } else { 1e300 })
    }
}

/// How well `modes` explain the patches around their frequencies at another level: the
/// relative residual and the share of the patch energy noise would explain. `None` when the
/// first mode does not stand 10 dB above the noise at that level.
fn residual_at_level(
    spec: &Spectrogram,
    noise_power: f64,
    modes: &[DampedMode],
) -> Option<(f64, f64)> {
    let bins: Vec<usize> = modes
        .iter()
        .map(|m| (m.freq_hz / spec.bin_width_hz()).round() as usize)
        .collect();
    let (lo, hi) = (*bins.iter().min()?, *bins.iter().max()?);
    if lo < 3 || hi + 3 >= spec.bins {
        return None;
    }
    let mut frames = 0;
    while frames < spec.frames.min(16) && spec.at(frames, bins[0]).norm_sqr() > 10.0 * noise_power {
        frames += 1;
    }
    if frames == 0 {
        return None;
    }
    let amps: Vec<Complex64> = modes
        .iter()
        .map(|m| Complex64::from_polar(m.amplitude, m.phase_rad))
        .collect();
    let columns: Vec<ModeColumns> = modes
        .iter()
        .map(|m| ModeColumns::new(spec, m.freq_hz, m.damping_per_s))
        .collect();
    let (mut rr, mut xx) = (0.0, 0.0);
    let mut cells = 0;
    for k in lo - 2..=hi + 2 {
        if !bins.iter().any(|&b| b.abs_diff(k) <= 2) {
            continue;
        }
        cells += frames;
        let mut cols: Vec<[Complex64; 4]> = columns.iter().map(|c| c.column(k)).collect();
        for m in 0..frames {
            let x = spec.at(m, k);
            let mut model = Complex64::new(0.0, 0.0);
            for (c, a) in cols.iter_mut().zip(&amps) {
                model += a * c[0] + a.conj() * c[1];
                c[0] *= c[2];
                c[1] *= c[3];
            }
            rr += (x - model).norm_sqr();
            xx += x.norm_sqr();
        }
    }
    if !(xx > 0.0) {
        return None;
    }
    Some((rr / xx, noise_power * cells as f64 / xx))
}

/// Local shape fit of the peaks at `bins` (one, or two neighbours fitted jointly) of `spec`:
/// returns the modes, the relative residual and the share of the patch's energy that noise
/// alone would explain.
fn fit_group(
    spec: &Spectrogram,
    noise_power: f64,
    bins: &[usize],
) -> Option<(Vec<DampedMode>, f64, f64)> {
    let fs = spec.sample_rate_hz;
    let main = bins[0];
    // Frames: from the onset while the main bin stands 10 dB above the noise, at most 16.
    let mut frames = 1;
    while frames < spec.frames.min(16) && spec.at(frames, main).norm_sqr() > 10.0 * noise_power {
        frames += 1;
    }
    let lo = bins.iter().min()?.saturating_sub(2).max(1);
    let hi = (bins.iter().max()? + 2).min(spec.bins - 2);
    let patch = Patch {
        spec,
        bins: lo..=hi,
        frames,
    };
    let energy: f64 = (0..frames)
        .flat_map(|m| (lo..=hi).map(move |k| spec.at(m, k).norm_sqr()))
        .sum();
    let noise_fraction = noise_power * (frames * (hi - lo + 1)) as f64 / energy.max(1e-300);
    let bw = spec.bin_width_hz();
    let mut start: Vec<f64> = Vec::with_capacity(2 * bins.len());
    for &bin in bins {
        if bin < 1 || bin + 1 >= spec.bins {
            return None;
        }
        // Initial frequency: parabolic interpolation of log power at the strongest frame.
        let mpk = (0..frames)
            .max_by(|&a, &b| {
                spec.at(a, bin)
                    .norm_sqr()
                    .total_cmp(&spec.at(b, bin).norm_sqr())
            })
            .unwrap_or(0);
        let lp = |k: usize| spec.at(mpk, k).norm_sqr().max(1e-300).ln();
        let (ym, y0, yp) = (lp(bin - 1), lp(bin), lp(bin + 1));
        let denom = ym - 2.0 * y0 + yp;
        let delta = if denom < 0.0 {
            (0.5 * (ym - yp) / denom).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        let f0 = (bin as f64 + delta) * bw;
        // Initial damping: slope of log magnitude over the patch frames.
        let d0 = if frames >= 2 {
            let a0 = spec.at(0, bin).norm().max(1e-300).ln();
            let a1 = spec.at(frames - 1, bin).norm().max(1e-300).ln();
            let dt = spec.frame_start_s(frames - 1);
            ((a0 - a1) / dt).clamp(0.05, 20_000.0)
        } else {
            2.0 * fs / spec.window_len as f64
        };
        start.extend([f0, d0.ln()]);
    }
    // Simplex: the start and one step along each parameter.
    let mut simplex = vec![start.clone()];
    for i in 0..start.len() {
        let mut v = start.clone();
        v[i] += if i % 2 == 0 { 0.3 * bw } else { 0.7 };
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-10).ok()?;
    let res = Executor::new(PatchCost(&patch), solver)
        .configure(|s| s.max_iters(150 * bins.len() as u64))
        .run()
        .ok()?;
    let best = res.state.best_param.clone()?;
    let fd: Vec<(f64, f64)> = best.chunks(2).map(|q| (q[0], q[1].exp())).collect();
    let (amps, r) = patch.solve(&fd);
    if !r.is_finite() || amps.iter().any(|a| !(a.norm() > 0.0)) {
        return None;
    }
    let modes = fd
        .iter()
        .zip(&amps)
        .map(|(&(f, d), a)| DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: a.norm(),
            phase_rad: a.arg(),
        })
        .collect();
    Some((modes, r, noise_fraction))
}

/// The strongest other peak of `spec` within 8 bins of `bin` that stands above `threshold`
/// (per-bin maximum over frames), if any.
fn neighbour_peak(spec: &Spectrogram, bin: usize, threshold: f64) -> Option<usize> {
    let power = |k: usize| {
        (0..spec.frames.min(16))
            .map(|m| spec.at(m, k).norm_sqr())
            .fold(0.0, f64::max)
    };
    let lo = bin.saturating_sub(8).max(1);
    let hi = (bin + 8).min(spec.bins - 2);
    (lo..=hi)
        .filter(|&k| k.abs_diff(bin) >= 2)
        .filter(|&k| {
            let p = power(k);
            p > threshold && p > power(k - 1) && p >= power(k + 1)
        })
        .max_by(|&a, &b| power(a).total_cmp(&power(b)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::damped::synthesize;

    #[test]
    fn finds_three_modes_noise_free() {
        let fs = 44100.0;
        let truth = [
            DampedMode {
                freq_hz: 523.0,
                damping_per_s: 4.0,
                amplitude: 0.5,
                phase_rad: 0.2,
            },
            DampedMode {
                freq_hz: 1771.0,
                damping_per_s: 40.0,
                amplitude: 0.2,
                phase_rad: -1.0,
            },
            DampedMode {
                freq_hz: 6100.0,
                damping_per_s: 300.0,
                amplitude: 0.3,
                phase_rad: 2.0,
            },
        ];
        let x = synthesize(&truth, fs, 44100);
        let found = extract_modes(&x, fs, &ExtractParams::default(), &[], None);
        for t in truth {
            let best = found
                .iter()
                .min_by(|a, b| {
                    (a.mode.freq_hz - t.freq_hz)
                        .abs()
                        .total_cmp(&(b.mode.freq_hz - t.freq_hz).abs())
                })
                .unwrap();
            assert!(
                (best.mode.freq_hz / t.freq_hz - 1.0).abs() < 1e-3,
                "{t:?} vs {best:?}"
            );
            assert!(
                (best.mode.damping_per_s / t.damping_per_s - 1.0).abs() < 0.05,
                "{t:?} vs {best:?}"
            );
            assert!(
                (best.mode.amplitude / t.amplitude - 1.0).abs() < 0.05,
                "{t:?} vs {best:?}"
            );
        }
    }
}
