//! Correlation patterns (Picard §3.3): where each grain matches each signal, and how well.
//!
//! For a grain `g` of `L` samples and a signal `x`, the normalized cross-correlation at lag τ is
//! `c(τ) = Σ g(i) x(τ+i) / (‖g‖ · ‖x[τ, τ+L)‖)` — 1 where the signal is the grain up to a gain.
//! The numerator is computed by FFT overlap-save: each signal is cut once into blocks of `B`
//! samples overlapping by the longest grain, every grain is transformed once at `B`, and each
//! (grain, block) pair costs one product and one inverse FFT (f32, realfft). The window energy
//! comes from prefix sums.
//!
//! Peaks with `|c| ≥ min_corr` are picked greedily along time (a peak suppresses weaker ones
//! within half the grain's length), then the `k` largest over all grains are kept per signal,
//! plus each grain's own peak (where it was cut), so that every recording can be rebuilt.
//! Signals are correlated with the grains of their own kind (impulsive, sinusoidal, transient):
//! retargeting draws each kind from its own patterns, and it cuts the work by the number of
//! kinds. Each kept peak stores the gain that matches the grain's energy to the signal's energy
//! under the grain's window there (Picard §4.1), signed like the correlation.

use crate::{Grain, GrainError, Part, Peak};
use rayon::prelude::*;
use realfft::num_complex::Complex32;
use realfft::RealFftPlanner;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Pattern settings.
#[derive(Clone, Debug, PartialEq)]
pub struct PatternParams {
    /// Smallest |correlation| a peak may have.
    pub min_corr: f64,
    /// Peaks kept per signal, per mean grain length of the signal (`k = ⌈this · len / mean⌉`).
    pub peaks_per_slot: f64,
    /// Peaks kept per signal, overriding `peaks_per_slot`.
    pub peaks_per_part: Option<usize>,
    /// Overlap-save block, samples (a power of two).
    pub block_len: usize,
}

impl Default for PatternParams {
    fn default() -> Self {
        Self {
            min_corr: 0.5,
            peaks_per_slot: 3.0,
            peaks_per_part: None,
            block_len: 16_384,
        }
    }
}

impl PatternParams {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`GrainError::Param`] naming the absurd value.
    pub fn check(&self) -> Result<(), GrainError> {
        if !(self.min_corr > 0.0 && self.min_corr < 1.0) {
            return Err(GrainError::Param(format!(
                "minimum correlation must be in (0, 1), got {}",
                self.min_corr
            )));
        }
        if !(self.peaks_per_slot > 0.0 && self.peaks_per_slot <= 1000.0)
            || self.peaks_per_part == Some(0)
        {
            return Err(GrainError::Param(
                "peaks per signal must be positive".into(),
            ));
        }
        if !self.block_len.is_power_of_two() || self.block_len < 256 {
            return Err(GrainError::Param(format!(
                "block length must be a power of two ≥ 256, got {}",
                self.block_len
            )));
        }
        Ok(())
    }
}

/// A signal to correlate: a recording or one of its parts.
#[derive(Clone, Copy, Debug)]
pub struct Signal<'a> {
    /// Samples.
    pub samples: &'a [f32],
    /// Kind.
    pub part: Part,
    /// Recording it belongs to: grains of this recording and kind were cut from it.
    pub recording: u32,
}

struct Prepared {
    block: usize,
    hop: usize,
    spectra: Vec<Vec<Complex32>>,
    /// Prefix sums of x², padded with the total for `lmax` more entries (no clamping).
    energy: Vec<f64>,
    /// Signal length.
    n: usize,
    floor: f64,
}

/// Normalized cross-correlation peaks of one grain in block `k` of one signal, appended to `out`
/// (strongest within half a grain).
#[allow(clippy::too_many_arguments)]
fn block_peaks(
    sig: &Prepared,
    k: usize,
    len: usize,
    g_spec: &[Complex32],
    g_norm: f64,
    min_corr: f64,
    inv: &dyn realfft::ComplexToReal<f32>,
    buf: &mut (Vec<Complex32>, Vec<f32>, Vec<Complex32>),
    out: &mut Vec<(u32, f32)>,
) {
    let n = sig.n;
    let radius = (len / 2).max(1);
    let scale = 1.0 / sig.block as f64;
    {
        let x = &sig.spectra[k];
        for ((p, &a), &b) in buf.0.iter_mut().zip(x).zip(g_spec) {
            *p = a * b;
        }
        let last = buf.0.len() - 1;
        buf.0[0].im = 0.0;
        buf.0[last].im = 0.0;
        let _ = inv.process_with_scratch(&mut buf.0, &mut buf.1, &mut buf.2);
        let t0 = k * sig.hop;
        let m = sig.hop.min(n.saturating_sub(t0));
        // |c| ≥ min_corr ⇔ r² ≥ (min_corr ‖g‖ B)² · e: no square root or division per lag, and
        // lags are screened eight at a time (most do not pass).
        let thr = (min_corr * g_norm / scale).powi(2);
        let floor = sig.floor * len as f64;
        let r = &buf.1[..m];
        let lo = &sig.energy[t0..t0 + m];
        let hi = &sig.energy[t0 + len..t0 + len + m];
        let passes = |j: usize| {
            let rr = f64::from(r[j]);
            rr * rr >= thr * (hi[j] - lo[j]).max(floor)
        };
        let mut j0 = 0;
        while j0 < m {
            let j1 = (j0 + 8).min(m);
            let mut any = false;
            for j in j0..j1 {
                any |= passes(j);
            }
            if !any {
                j0 = j1;
                continue;
            }
            for j in j0..j1 {
                if !passes(j) {
                    continue;
                }
                let t = t0 + j;
                let e = (hi[j] - lo[j]).max(floor);
                let c = f64::from(r[j]) * scale / (g_norm * e.sqrt());
                push_peak(out, t, c, radius);
            }
            j0 = j1;
        }
    }
}

/// Greedy peak picking along time: a new peak within `radius` of the last kept one replaces it
/// when stronger.
fn push_peak(out: &mut Vec<(u32, f32)>, t: usize, c: f64, radius: usize) {
    match out.last_mut() {
        Some(last) if (t as u32 - last.0) as usize <= radius => {
            if c.abs() > f64::from(last.1.abs()) {
                *last = (t as u32, c as f32);
            }
        }
        _ => out.push((t as u32, c as f32)),
    }
}

/// The correlation pattern of every signal: peaks in ascending time, and the number of
/// (grain, signal) pairs correlated. `progress` gets the fraction of grains done.
pub fn patterns(
    signals: &[Signal<'_>],
    grains: &[Grain],
    p: &PatternParams,
    progress: &(dyn Fn(f64) + Sync),
) -> (Vec<Vec<Peak>>, usize) {
    let mut planner = RealFftPlanner::<f32>::new();
    let longest = |part: Part| {
        grains
            .iter()
            .filter(|g| g.part == part)
            .map(|g| g.samples.len())
            .max()
            .unwrap_or(0)
    };
    // Blocks of each signal, grouped by block length.
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    let mut prepared = Vec::with_capacity(signals.len());
    for (s, sig) in signals.iter().enumerate() {
        let lmax = longest(sig.part).max(1);
        let n = sig.samples.len();
        let block = (n + lmax)
            .next_power_of_two()
            .min(p.block_len.max((2 * lmax).next_power_of_two()));
        let hop = block - lmax + 1;
        let fft = planner.plan_fft_forward(block);
        let mut frame = fft.make_input_vec();
        let mut scratch = fft.make_scratch_vec();
        let mut spectra = Vec::new();
        let mut t = 0;
        while t < n {
            frame.fill(0.0);
            let m = (n - t).min(block);
            frame[..m].copy_from_slice(&sig.samples[t..t + m]);
            let mut spec = fft.make_output_vec();
            let _ = fft.process_with_scratch(&mut frame, &mut spec, &mut scratch);
            spectra.push(spec);
            t += hop;
        }
        let mut energy = vec![0.0f64; n + 1 + lmax + hop];
        for (i, &v) in sig.samples.iter().enumerate() {
            energy[i + 1] = energy[i] + f64::from(v).powi(2);
        }
        let total = energy[n];
        energy[n + 1..].fill(total);
        let floor = 1e-4 * total / n.max(1) as f64 + 1e-30;
        prepared.push(Prepared {
            block,
            hop,
            spectra,
            energy,
            n,
            floor,
        });
        groups.entry(block).or_default().push(s);
    }
    let total_pairs: usize = grains
        .iter()
        .map(|g| signals.iter().filter(|s| s.part == g.part).count())
        .sum();
    let done = AtomicUsize::new(0);
    let jobs = groups.len() * grains.len();
    let mut found: Vec<Vec<(u32, f32, u32)>> = vec![Vec::new(); signals.len()];
    for (&block, members) in &groups {
        let fwd = planner.plan_fft_forward(block);
        let inv = planner.plan_fft_inverse(block);
        // Grains in chunks of 8 (of one kind where possible): each signal block is read once
        // per chunk, while it is in cache.
        let mut order: Vec<usize> = (0..grains.len()).collect();
        order.sort_by_key(|&g| (crate::player_part_index(grains[g].part), g));
        let hits: Vec<Vec<(usize, u32, u32, f32)>> = order
            .par_chunks(8)
            .map_init(
                || {
                    (
                        fwd.make_input_vec(),
                        fwd.make_scratch_vec(),
                        (
                            inv.make_input_vec(),
                            inv.make_output_vec(),
                            inv.make_scratch_vec(),
                        ),
                    )
                },
                |(frame, fscratch, buf), chunk| {
                    let mut hits = Vec::new();
                    let mut specs: Vec<(usize, Vec<Complex32>, f64)> = Vec::new();
                    for &gi in chunk {
                        let g = &grains[gi];
                        let norm = g
                            .samples
                            .iter()
                            .map(|&v| f64::from(v).powi(2))
                            .sum::<f64>()
                            .sqrt();
                        if g.samples.len() > block || !(norm > 0.0) {
                            continue;
                        }
                        frame.fill(0.0);
                        frame[..g.samples.len()].copy_from_slice(&g.samples);
                        let mut spec = fwd.make_output_vec();
                        let _ = fwd.process_with_scratch(frame, &mut spec, fscratch);
                        for c in &mut spec {
                            *c = c.conj();
                        }
                        specs.push((gi, spec, norm));
                    }
                    let mut outs: Vec<Vec<(u32, f32)>> = vec![Vec::new(); specs.len()];
                    for &s in members {
                        let sig = &prepared[s];
                        if !specs
                            .iter()
                            .any(|(gi, _, _)| grains[*gi].part == signals[s].part)
                        {
                            continue;
                        }
                        outs.iter_mut().for_each(Vec::clear);
                        for k in 0..sig.spectra.len() {
                            for ((gi, spec, norm), out) in specs.iter().zip(outs.iter_mut()) {
                                if grains[*gi].part != signals[s].part {
                                    continue;
                                }
                                block_peaks(
                                    sig,
                                    k,
                                    grains[*gi].samples.len(),
                                    spec,
                                    *norm,
                                    p.min_corr,
                                    inv.as_ref(),
                                    buf,
                                    out,
                                );
                            }
                        }
                        for ((gi, _, _), out) in specs.iter().zip(&outs) {
                            hits.extend(out.iter().map(|&(t, c)| (s, *gi as u32, t, c)));
                        }
                    }
                    let d = done.fetch_add(chunk.len(), Ordering::Relaxed) + chunk.len();
                    progress(d as f64 / jobs.max(1) as f64);
                    hits
                },
            )
            .collect();
        for (s, g, t, c) in hits.into_iter().flatten() {
            found[s].push((g, c, t));
        }
    }
    progress(1.0);
    // Every grain matches the signal it was cut from where it was cut: that peak is always kept,
    // so every recording can be rebuilt from its pattern.
    let mut own: Vec<Vec<(u32, f32, u32)>> = vec![Vec::new(); signals.len()];
    for (gi, g) in grains.iter().enumerate() {
        let Some(s) = signals
            .iter()
            .position(|s| s.part == g.part && s.recording == g.recording)
        else {
            continue;
        };
        let x = &signals[s].samples;
        let t = g.start as usize;
        let (mut dot, mut gg) = (0.0f64, 0.0f64);
        for (i, &v) in g.samples.iter().enumerate() {
            let xv = x.get(t + i).map_or(0.0, |&a| f64::from(a));
            dot += f64::from(v) * xv;
            gg += f64::from(v).powi(2);
        }
        let e = &prepared[s].energy;
        let ex = e[(t + g.samples.len()).min(e.len() - 1)] - e[t.min(e.len() - 1)];
        let c = dot / (gg * ex).sqrt().max(1e-300);
        own[s].push((gi as u32, c as f32, g.start));
        let radius = (g.samples.len() / 2) as u32;
        found[s].retain(|&(fg, _, ft)| fg != gi as u32 || ft.abs_diff(g.start) > radius);
    }
    let out = found
        .into_iter()
        .zip(own)
        .enumerate()
        .map(|(s, (mut cand, own))| {
            let sig = &signals[s];
            let lens: Vec<usize> = grains
                .iter()
                .filter(|g| g.part == sig.part)
                .map(|g| g.samples.len())
                .collect();
            let mean = lens.iter().sum::<usize>() as f64 / lens.len().max(1) as f64;
            let k = p.peaks_per_part.unwrap_or_else(|| {
                (p.peaks_per_slot * sig.samples.len() as f64 / mean.max(1.0)).ceil() as usize
            });
            cand.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()).then(a.2.cmp(&b.2)));
            cand.truncate(k);
            cand.extend(own);
            let mut peaks: Vec<Peak> = cand
                .into_iter()
                .map(|(gi, c, t)| {
                    let g = &grains[gi as usize];
                    let (mut num, mut den) = (0.0f64, 0.0f64);
                    for (i, &v) in g.samples.iter().enumerate() {
                        let w = g.window(i);
                        let x = sig
                            .samples
                            .get(t as usize + i)
                            .map_or(0.0, |&x| f64::from(x));
                        num += (w * x).powi(2);
                        den += f64::from(v).powi(2);
                    }
                    Peak {
                        grain: gi,
                        time: t,
                        corr: c,
                        gain: ((num / den.max(1e-300)).sqrt() as f32).copysign(c),
                    }
                })
                .collect();
            peaks.sort_by_key(|p| (p.time, p.grain));
            peaks
        })
        .collect();
    (out, total_pairs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::{grains as cut, SegmentParams};
    use rand::{Rng, SeedableRng};

    #[test]
    fn a_grain_is_found_where_it_was_placed_with_its_gain() {
        let mut rng = rand::rngs::SmallRng::seed_from_u64(8);
        let burst: Vec<f32> = (0..1500)
            .map(|i| ((rng.random::<f64>() - 0.5) * (-(i as f64) / 300.0).exp()) as f32)
            .collect();
        let grain = Grain {
            samples: burst.clone(),
            part: Part::Impulsive,
            // Cut from another recording: no own peak here.
            recording: 1,
            start: 0,
            fade_in: 0,
            fade_out: 0,
            onset: true,
        };
        let mut x: Vec<f32> = (0..40_000)
            .map(|_| ((rng.random::<f64>() - 0.5) * 1e-3) as f32)
            .collect();
        let places = [(1234usize, 1.0f32), (17_000, -0.5), (33_333, 2.0)];
        for &(at, a) in &places {
            for (i, &v) in burst.iter().enumerate() {
                x[at + i] += a * v;
            }
        }
        let sig = [Signal {
            samples: &x,
            part: Part::Impulsive,
            recording: 0,
        }];
        let params = PatternParams {
            peaks_per_part: Some(3),
            block_len: 4096,
            ..PatternParams::default()
        };
        let (peaks, pairs) = patterns(&sig, &[grain], &params, &|_| {});
        assert_eq!(pairs, 1);
        assert_eq!(peaks[0].len(), 3);
        for (p, &(at, a)) in peaks[0].iter().zip(&places) {
            assert_eq!(p.time as usize, at);
            assert!(p.corr.abs() > 0.99 && p.corr.signum() == a.signum());
            assert!((p.gain - a).abs() < 0.02 * a.abs(), "{} vs {a}", p.gain);
        }
    }

    #[test]
    fn own_grains_correlate_fully_at_their_own_offsets() {
        let fs = 44_100.0;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(9);
        let x: Vec<f32> = (0..4)
            .flat_map(|k| crate::testing::event(k, 2500, fs, &mut rng))
            .collect();
        let c = cut(&x, fs, &SegmentParams::default());
        let grains: Vec<Grain> = c
            .kept
            .iter()
            .map(|g| Grain {
                samples: g.samples.clone(),
                part: Part::Impulsive,
                recording: 0,
                start: g.start as u32,
                fade_in: g.fade_in as u32,
                fade_out: g.fade_out as u32,
                onset: g.onset,
            })
            .collect();
        let sig = [Signal {
            samples: &x,
            part: Part::Impulsive,
            recording: 0,
        }];
        let (peaks, _) = patterns(&sig, &grains, &PatternParams::default(), &|_| {});
        for (i, g) in grains.iter().enumerate() {
            let own = peaks[0]
                .iter()
                .find(|p| p.grain as usize == i && p.time == g.start)
                .expect("own peak");
            assert!(own.corr > 0.99 && (own.gain - 1.0).abs() < 1e-3, "{own:?}");
        }
    }
}
