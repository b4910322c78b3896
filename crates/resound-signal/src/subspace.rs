//! Sub-band ESPRIT: poles (f, d) of damped sinusoids by subspace rotation in narrow bands.
//!
//! The spectrogram stage ([`crate::extract`]) needs a spectral peak that persists over frames,
//! so it misses what the ear hears as a knock (d of several hundred 1/s, gone within one frame)
//! and it fits a beating doublet (two modes 0.05–0.5 % apart, equal d) as one mode or not at
//! all. ESPRIT has neither limit: it models the samples themselves as a sum of complex
//! exponentials, resolves poles closer than 1/T where the signal stands above the noise, and
//! finds a decay of any speed.
//!
//! The signal is split into bands with one FFT: for each band the bins of `[fc − 1.5B, fc + 1.5B]`
//! are weighted by a flat-top mask (flat over `±B`, raised-cosine edges), shifted to 0 Hz and
//! transformed back at the band's own rate (`≈ 3B`): an exact, decimated, analytic band signal
//! whose poles are the signal's poles (a linear filter keeps them). Band sets of several widths
//! cover the range: wide bands with short windows for fast decays, narrow bands with long
//! windows for close pairs and low frequencies. In each band:
//!
//! 1. the sample covariance `R = H Hᴴ / M` of the `L × M` Hankel matrix `H` of the band signal;
//! 2. its eigenvalues above the noise (the Marchenko–Pastur edge of white noise of the band's
//!    known variance, with a 3 dB margin) give the model order;
//! 3. the rotation `Φ = U₁⁺ U₂` between the shifted halves of the signal subspace gives the
//!    poles `z = e^{(−d + iω)/f_band}` as its eigenvalues (least-squares ESPRIT);
//! 4. a pole is kept by the band whose flat part holds it.
//!
//! The same pole found by several band sets is kept once: from the set whose window best fits
//! its decay.

use faer::{c64, Mat, Side};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;
use rustfft::FftPlanner;

/// A pole found by [`find_poles`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pole {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Damping, 1/s.
    pub damping_per_s: f64,
    /// Length of the window the pole was estimated on, s.
    pub window_s: f64,
    /// Signal eigenvalue over the noise eigenvalue of its band (a local SNR, linear).
    pub strength: f64,
}

/// One set of equal bands.
#[derive(Clone, Copy, Debug)]
pub struct BandSet {
    /// Half-width of each band's flat part, Hz (bands are `2B` apart).
    pub half_width_hz: f64,
    /// Lowest and highest band centre, Hz (bands outside are skipped).
    pub range_hz: (f64, f64),
}

/// Settings of [`find_poles`].
#[derive(Clone, Debug)]
pub struct SubspaceParams {
    /// The band sets, widest first.
    pub sets: Vec<BandSet>,
    /// Samples per band window (at the band's rate).
    pub window_samples: usize,
    /// Largest model order per band.
    pub max_order: usize,
    /// Signal eigenvalues must exceed the white-noise edge by this factor.
    pub margin: f64,
}

impl Default for SubspaceParams {
    fn default() -> Self {
        Self {
            sets: vec![
                BandSet {
                    half_width_hz: 3000.0,
                    range_hz: (0.0, f64::INFINITY),
                },
                BandSet {
                    half_width_hz: 750.0,
                    range_hz: (0.0, f64::INFINITY),
                },
                BandSet {
                    half_width_hz: 180.0,
                    range_hz: (0.0, 12000.0),
                },
                BandSet {
                    half_width_hz: 45.0,
                    range_hz: (0.0, 1500.0),
                },
            ],
            window_samples: 240,
            max_order: 16,
            margin: 3.0,
        }
    }
}

/// Finds the poles of `x` (sample 0 = onset; white noise of standard deviation `noise_rms`).
/// Poles are sorted by frequency; only those with `f ≥ min_freq_hz`, `f < Nyquist` and
/// `d` in `[d_min, d_max]` are returned.
pub fn find_poles(
    x: &[f64],
    sample_rate_hz: f64,
    noise_rms: f64,
    params: &SubspaceParams,
    d_range: (f64, f64),
    min_freq_hz: f64,
) -> Vec<Pole> {
    let n = x.len();
    if n < 64 {
        return Vec::new();
    }
    let nfft = 2 * n;
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let mut buf = vec![0.0; nfft];
    buf[..n].copy_from_slice(x);
    let mut spec = fwd.make_output_vec();
    if fwd.process(&mut buf, &mut spec).is_err() {
        return Vec::new();
    }
    let df = sample_rate_hz / nfft as f64;
    let nyquist = 0.5 * sample_rate_hz;
    let duration_s = n as f64 / sample_rate_hz;
    let mut bands: Vec<(f64, f64)> = Vec::new();
    for set in &params.sets {
        let b = set.half_width_hz;
        let mut fc = b;
        while fc - b < nyquist {
            if fc + b >= set.range_hz.0 && fc - b <= set.range_hz.1 {
                bands.push((fc, b));
            }
            fc += 2.0 * b;
        }
    }
    use rayon::prelude::*;
    let all: Vec<Pole> = bands
        .par_iter()
        .map_init(FftPlanner::<f64>::new, |cplx, &(fc, b)| {
            let mut out = Vec::new();
            let Some(band) = band_signal(&spec, df, fc, b, nfft, cplx) else {
                return out;
            };
            // Skip the mask's response at both ends of the signal.
            let skip = (2.0 / b * band.rate_hz).ceil() as usize;
            let last = ((duration_s - 2.0 / b) * band.rate_hz).floor() as usize;
            if last <= skip + 32 {
                return out;
            }
            let end = last.min(skip + params.window_samples);
            let y = &band.samples[skip..end];
            let var = noise_rms * noise_rms * band.noise_gain;
            // Nothing but noise in the band: its mean power is at the noise level.
            let power = y.iter().map(|v| v.norm_sqr()).sum::<f64>() / y.len() as f64;
            if power < 0.3 * var {
                return out;
            }
            let window_s = y.len() as f64 / band.rate_hz;
            for (z, strength) in esprit(y, var, params.max_order, params.margin) {
                let f = band.centre_hz + z.arg() * band.rate_hz / std::f64::consts::TAU;
                let d = -z.norm().ln() * band.rate_hz;
                // The top 1 % below Nyquist holds the mask's edge, not modes.
                if (f - fc).abs() > b || f < min_freq_hz || f >= 0.99 * nyquist {
                    continue;
                }
                if !(d >= d_range.0 && d <= d_range.1) {
                    continue;
                }
                out.push(Pole {
                    freq_hz: f,
                    damping_per_s: d,
                    window_s,
                    strength,
                });
            }
            out
        })
        .flatten()
        .collect();
    dedupe(all)
}

/// Keeps each pole once: poles from different band sets closer than their resolution are the
/// same pole; the one whose window best matches its decay (d·T nearest 2) stays.
fn dedupe(mut all: Vec<Pole>) -> Vec<Pole> {
    let fit = |p: &Pole| (p.damping_per_s * p.window_s / 2.0).ln().abs();
    all.sort_by(|a, b| fit(a).total_cmp(&fit(b)));
    let mut kept: Vec<Pole> = Vec::new();
    for p in all {
        let same = kept.iter().any(|q| {
            let tol = 0.5 / q.window_s.max(p.window_s)
                + 0.25 * (p.damping_per_s + q.damping_per_s) / std::f64::consts::PI;
            let window_differs = (q.window_s / p.window_s - 1.0).abs() > 0.01;
            window_differs && (p.freq_hz - q.freq_hz).abs() < tol
        });
        if !same {
            kept.push(p);
        }
    }
    kept.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    kept
}

struct BandSignal {
    samples: Vec<Complex64>,
    rate_hz: f64,
    centre_hz: f64,
    /// Largest noise eigenvalue of the band signal's covariance per unit variance of white input noise.
    noise_gain: f64,
}

/// The analytic band signal of `[fc − 1.5B, fc + 1.5B]`, shifted by the centre bin, sampled at
/// its own rate.
fn band_signal(
    spec: &[Complex64],
    df: f64,
    fc: f64,
    b: f64,
    nfft: usize,
    planner: &mut FftPlanner<f64>,
) -> Option<BandSignal> {
    let k_c = (fc / df).round() as i64;
    let half = (1.5 * b / df).ceil() as i64;
    let flat = b / df;
    let p = (2 * half as usize + 1).next_power_of_two().max(16);
    let mut buf = vec![Complex64::new(0.0, 0.0); p];
    let mut gain = 0.0;
    for off in -half..=half {
        let k = k_c + off;
        if k <= 0 || k as usize >= spec.len() - 1 {
            continue;
        }
        let a = (off as f64).abs();
        let w = if a <= flat {
            1.0
        } else {
            let u = (a - flat) / (half as f64 - flat).max(1e-9);
            if u >= 1.0 {
                0.0
            } else {
                0.5 * (1.0 + (std::f64::consts::PI * u).cos())
            }
        };
        if w == 0.0 {
            continue;
        }
        // Positive frequencies only, doubled: the analytic signal.
        let idx = off.rem_euclid(p as i64) as usize;
        buf[idx] = spec[k as usize] * (2.0 * w);
        gain += 4.0 * w * w;
    }
    if gain == 0.0 {
        return None;
    }
    planner.plan_fft_inverse(p).process(&mut buf);
    // x[t] = (1/nfft) Σ X_k e^{i2πk t/nfft}; the band rate is p·df.
    let scale = 1.0 / nfft as f64;
    for v in buf.iter_mut() {
        *v *= scale;
    }
    Some(BandSignal {
        samples: buf,
        rate_hz: p as f64 * df,
        centre_hz: k_c as f64 * df,
        // The band noise is coloured (flat over the mask, zero outside it), so the covariance's
        // noise eigenvalues approach its peak spectral density, not its variance: white input
        // of variance σ² gives |2w|² σ² per bin, i.e. 4σ² p / nfft at the band rate.
        noise_gain: 4.0 * p as f64 / nfft as f64,
    })
}

/// Least-squares ESPRIT on the complex samples `y` with noise variance `noise_var`: returns
/// the poles and their eigenvalue-to-noise ratios.
fn esprit(y: &[Complex64], noise_var: f64, max_order: usize, margin: f64) -> Vec<(Complex64, f64)> {
    let k = y.len();
    let l = (k / 3).max(4);
    if k < l + 8 {
        return Vec::new();
    }
    let m = k - l + 1;
    let h = Mat::<c64>::from_fn(l, m, |i, j| {
        let v = y[i + j];
        c64::new(v.re, v.im)
    });
    let r = &h * h.adjoint() * faer::Scale(c64::new(1.0 / m as f64, 0.0));
    let Ok(eig) = r.self_adjoint_eigen(Side::Lower) else {
        return Vec::new();
    };
    let s = eig.S().column_vector();
    let u = eig.U();
    // Eigenvalues ascend.
    let lam: Vec<f64> = (0..l).rev().map(|i| s[i].re).collect();
    let top = lam[0];
    if !(top > 0.0) {
        return Vec::new();
    }
    let edge = noise_var * (1.0 + (l as f64 / m as f64).sqrt()).powi(2);
    let floor = (margin * edge).max(1e-13 * top);
    let order = lam
        .iter()
        .take(max_order.min(l / 2))
        .take_while(|&&v| v > floor)
        .count();
    if order == 0 {
        return Vec::new();
    }
    let us = Mat::<c64>::from_fn(l, order, |i, j| u[(i, l - 1 - j)]);
    let u1 = us.subrows(0, l - 1);
    let u2 = us.subrows(1, l - 1);
    // Φ = (U₁ᴴU₁)⁻¹ U₁ᴴ U₂.
    let g = u1.adjoint() * u1;
    let rhs = u1.adjoint() * u2;
    let Ok(llt) = g.llt(Side::Lower) else {
        return Vec::new();
    };
    let phi = faer::linalg::solvers::Solve::solve(&llt, &rhs);
    let Ok(z) = phi.eigenvalues() else {
        return Vec::new();
    };
    let noise = (noise_var * (1.0 + (l as f64 / m as f64).sqrt()).powi(2)).max(1e-300);
    z.into_iter()
        .enumerate()
        .map(|(i, z)| (Complex64::new(z.re, z.im), lam[i.min(order - 1)] / noise))
        .collect()
}

/// Textbook full-band ESPRIT (Roy & Kailath 1989) of a real segment: the `rows × rows`
/// covariance of its Hankel rows over the whole segment, the model order by MDL
/// ([`mdl_order`], at most `max_order` complex exponentials), least-squares ESPRIT on the signal
/// subspace. Returns the poles of positive frequency, unsorted and unfiltered (`strength`: a
/// signal eigenvalue, ranked as the poles come, over the mean noise eigenvalue — a rough SNR).
pub fn fullband_esprit(y: &[f64], fs: f64, rows: usize, max_order: usize) -> Vec<Pole> {
    let m = rows.max(4);
    if y.len() < 3 * m {
        return Vec::new();
    }
    let k = y.len() - m + 1;
    // R[i][j] = Σ_{n<k} y[n+i] y[n+j]: the first row by correlation, the rest by the
    // shift R[i+1][j+1] = R[i][j] − y[i]y[j] + y[k+i]y[k+j].
    let mut r = Mat::<f64>::zeros(m, m);
    for j in 0..m {
        r[(0, j)] = (0..k).map(|n| y[n] * y[n + j]).sum::<f64>();
    }
    for i in 0..m - 1 {
        for j in i..m - 1 {
            r[(i + 1, j + 1)] = r[(i, j)] - y[i] * y[j] + y[k + i] * y[k + j];
        }
    }
    for i in 0..m {
        for j in 0..i {
            r[(i, j)] = r[(j, i)];
        }
    }
    let Ok(eig) = r.self_adjoint_eigen(Side::Lower) else {
        return Vec::new();
    };
    let s = eig.S().column_vector();
    // Eigenvalues descending, clamped positive.
    let lam: Vec<f64> = (0..m).rev().map(|i| s[i].max(1e-300)).collect();
    let order = mdl_order(&lam, k, max_order);
    if order == 0 {
        return Vec::new();
    }
    let u = eig.U();
    let us = Mat::<f64>::from_fn(m, order, |i, j| u[(i, m - 1 - j)]);
    let u1 = us.subrows(0, m - 1);
    let u2 = us.subrows(1, m - 1);
    let g = u1.transpose() * u1;
    let rhs = u1.transpose() * u2;
    let Ok(llt) = g.llt(Side::Lower) else {
        return Vec::new();
    };
    let phi = faer::linalg::solvers::Solve::solve(&llt, &rhs);
    let Ok(z) = phi.eigenvalues() else {
        return Vec::new();
    };
    let noise = lam[order..].iter().sum::<f64>() / (m - order) as f64;
    z.into_iter()
        .enumerate()
        .filter(|(_, z)| z.im > 0.0 && z.norm() > 0.0)
        .map(|(i, z)| Pole {
            freq_hz: z.im.atan2(z.re) * fs / std::f64::consts::TAU,
            damping_per_s: -z.norm().ln() * fs,
            window_s: y.len() as f64 / fs,
            strength: lam[i.min(order - 1)] / noise.max(1e-300),
        })
        .collect()
}

/// Wax & Kailath's MDL order from eigenvalues `lam` (descending, positive) of a covariance of
/// `snapshots` rows: the `q ≤ max_order` minimising
/// `−snapshots (M−q) ln(geometric / arithmetic mean of the M−q smallest) + ½ q (2M − q) ln snapshots`.
pub fn mdl_order(lam: &[f64], snapshots: usize, max_order: usize) -> usize {
    let m = lam.len();
    let n = snapshots as f64;
    let mut best = (f64::INFINITY, 0);
    for q in 0..m.min(max_order + 1) {
        let rest = &lam[q..];
        let p = rest.len() as f64;
        let arith = rest.iter().sum::<f64>() / p;
        let geo = (rest.iter().map(|v| v.ln()).sum::<f64>() / p).exp();
        let mdl =
            -n * p * (geo / arith).ln() + 0.5 * q as f64 * (2.0 * m as f64 - q as f64) * n.ln();
        if mdl < best.0 {
            best = (mdl, q);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::{damped::synthesize, DampedMode};

    fn mode(f: f64, d: f64, a: f64) -> DampedMode {
        DampedMode {
            freq_hz: f,
            damping_per_s: d,
            amplitude: a,
            phase_rad: 0.4,
        }
    }

    fn nearest(p: &[Pole], f: f64) -> Pole {
        *p.iter()
            .min_by(|a, b| (a.freq_hz - f).abs().total_cmp(&(b.freq_hz - f).abs()))
            .expect("a pole")
    }

    #[test]
    fn resolves_a_beating_doublet_and_a_knock() {
        let fs = 48000.0;
        // A doublet 0.1 % apart with equal d, and a mode gone in 5 ms.
        let truth = [
            mode(900.0, 2.0, 0.3),
            mode(900.9, 2.0, 0.2),
            mode(3100.0, 900.0, 0.5),
        ];
        let x = synthesize(&truth, fs, 48000);
        let poles = find_poles(
            &x,
            fs,
            1e-7,
            &SubspaceParams::default(),
            (0.01, 5000.0),
            15.0,
        );
        for t in &truth {
            let p = nearest(&poles, t.freq_hz);
            assert!(
                (p.freq_hz - t.freq_hz).abs() < 0.05 + 1e-3 * t.damping_per_s,
                "{t:?} → {p:?} in {poles:?}"
            );
            assert!(
                (p.damping_per_s / t.damping_per_s - 1.0).abs() < 0.05,
                "{t:?} → {p:?}"
            );
        }
    }

    #[test]
    fn finds_nothing_in_white_noise() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(5);
        let nrm = Normal::new(0.0, 0.01).expect("valid");
        let x: Vec<f64> = (0..48000).map(|_| nrm.sample(&mut rng)).collect();
        let poles = find_poles(
            &x,
            48000.0,
            0.01,
            &SubspaceParams::default(),
            (0.01, 5000.0),
            15.0,
        );
        assert!(poles.is_empty(), "{} poles: {poles:?}", poles.len());
    }
}
