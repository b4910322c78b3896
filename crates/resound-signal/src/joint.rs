//! Shared poles across takes: one object's modes fitted jointly to several recordings of it
//! (microphones, strikes, channels).
//!
//! Every take of one object holds the same poles (f, d); only the amplitude and phase of each
//! mode change with where it was struck and where it was heard. A single take fits a cluster
//! of close modes as well as its weighting of them allows: a microphone near one mode's nodal
//! line hears a beating pair as one mode with a wrong damping. Fitted jointly, the poles are
//! what every take agrees on (the polyreference idea of experimental modal analysis):
//!
//! 1. each take is analysed alone ([`crate::analyze()`]);
//! 2. the modes of all takes are grouped by frequency (modes of one take never share a group,
//!    so a pair one take resolves stays a pair) and each group seeds one pole, at the median
//!    f and d of its members;
//! 3. clusters of overlapping poles are fitted by Levenberg–Marquardt over the shared f, d and
//!    every take's own amplitude and phase, each take weighted by its noise (the maximum
//!    likelihood estimate under independent Gaussian noise), against the other clusters'
//!    residual in turn (block coordinate descent, as [`crate::refine`] does for one take);
//!    poles that converge onto each other are merged;
//! 4. each pole gets its joint Cramér–Rao bound (the inverse of the weighted normal matrix),
//!    and each take where it is heard refits it alone from the joint values: the scatter of
//!    those fits is the second measure of how sure the pole is, and takes that disagree beyond
//!    their own bound flag the pole.

use crate::crb::NoiseProfile;
use crate::refine::{self, cholesky_solve, normal_equations, Seed, P};
use resound_core::damped::ModeSigma;
use resound_core::DampedMode;
use thiserror::Error;

/// One take of the object: what [`crate::analyze()`] made of it.
#[derive(Clone, Copy, Debug)]
pub struct JointTake<'a> {
    /// The analysed samples (t = 0 at the onset), as [`crate::Analysis::segment`].
    pub segment: &'a [f64],
    /// The residual noise of the take (robust standard deviation).
    pub noise_rms: f64,
    /// The modes the take's own analysis found.
    pub modes: &'a [DampedMode],
}

/// Most takes [`joint_fit`] takes: each adds two unknowns per pole to every cluster's dense
/// normal matrix (64 takes of a 4-pole cluster: 520 unknowns).
pub const MAX_TAKES: usize = 64;

/// Settings of [`joint_fit`].
#[derive(Clone, Debug)]
pub struct JointParams {
    /// Passes over all clusters.
    pub sweeps: usize,
    /// Levenberg–Marquardt iterations per cluster fit.
    pub max_iterations: usize,
    /// Largest number of poles fitted jointly.
    pub max_cluster: usize,
    /// A pole is heard in a take when its energy there is this many times the take's noise
    /// variance (Σ s² / σ²); a pole heard in no take is dropped.
    pub min_energy_snr: f64,
    /// A pole is flagged when the takes' own fits deviate from it by more than this many of
    /// their own σ, as a root mean square over takes and over f and d.
    pub disagree_sigmas: f64,
}

impl Default for JointParams {
    fn default() -> Self {
        Self {
            sweeps: 2,
            max_iterations: 60,
            max_cluster: 4,
            min_energy_snr: 40.0,
            disagree_sigmas: 3.0,
        }
    }
}

/// A take's own fit of a shared pole (started from the joint values) and its σ in that take.
pub type OwnFit = (DampedMode, Option<ModeSigma>);

/// One pole shared by every take.
#[derive(Clone, Debug, PartialEq)]
pub struct JointMode {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Damping, 1/s.
    pub damping_per_s: f64,
    /// The joint Cramér–Rao bound at each take's noise.
    pub crb: Option<ModeSigma>,
    /// Standard deviation of the takes' own fits (two or more takes that hear the pole).
    pub scatter: Option<ModeSigma>,
    /// What to believe: per component the larger of the bound and the scatter's standard
    /// error (scatter / √takes).
    pub sigma: Option<ModeSigma>,
    /// Amplitude in each take (full scale = 1).
    pub amplitude: Vec<f64>,
    /// Phase at the onset in each take, rad.
    pub phase_rad: Vec<f64>,
    /// Whether each take hears the pole (energy above `min_energy_snr` times its noise).
    pub heard: Vec<bool>,
    /// Each hearing take's own fit started from the joint pole, with its own σ.
    pub own: Vec<Option<OwnFit>>,
    /// Root mean square over takes (and f, d) of the own fits' deviation from the joint
    /// pole in their own σ.
    pub disagreement_sigmas: f64,
    /// The takes disagree about this pole beyond their σ (`disagreement_sigmas` above
    /// [`JointParams::disagree_sigmas`]): the poles are not the same in every take (a pair
    /// fitted as one pole, two objects, a take that drifted) or the σ are optimistic.
    pub disagree: bool,
}

/// What [`joint_fit`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct JointAnalysis {
    /// The shared poles, by frequency.
    pub modes: Vec<JointMode>,
    /// Each take's residual noise after the joint fit (robust standard deviation).
    pub noise_rms: Vec<f64>,
    /// Poles seeded from the takes' own analyses.
    pub seeds: usize,
    /// Clusters fitted.
    pub clusters: usize,
    /// Levenberg–Marquardt iterations in all.
    pub iterations: usize,
}

impl JointAnalysis {
    /// The modes of take `take` (shared f, d; its own amplitude and phase), as a plain mode
    /// list for synthesis and estimation.
    pub fn take_modes(&self, take: usize) -> Vec<DampedMode> {
        self.modes
            .iter()
            .filter(|m| m.heard.get(take).copied().unwrap_or(false))
            .map(|m| DampedMode {
                freq_hz: m.freq_hz,
                damping_per_s: m.damping_per_s,
                amplitude: m.amplitude[take],
                phase_rad: m.phase_rad[take],
            })
            .collect()
    }
}

/// Why takes cannot be fitted jointly.
#[derive(Debug, Error, PartialEq)]
pub enum JointError {
    /// No takes given.
    #[error("no takes to fit")]
    NoTakes,
    /// More takes than one fit holds (its normal matrix grows with their square).
    #[error("{0} takes; at most {MAX_TAKES} are fitted jointly (pick the microphones or strikes to use)")]
    TooManyTakes(usize),
    /// A take without samples or with a non-finite or negative noise figure.
    #[error("take {0} has no samples or no finite noise figure")]
    BadTake(usize),
    /// No take holds a mode.
    #[error("no take holds a mode to fit")]
    NoModes,
    /// Bad parameter.
    #[error("invalid parameter: {0}")]
    Param(String),
}

/// Fits one set of poles shared by every take (all at `sample_rate_hz`), with each take's own
/// amplitudes and phases.
///
/// # Errors
/// No takes, an empty take, a non-finite noise figure, no modes in any take, bad parameters.
pub fn joint_fit(
    takes: &[JointTake],
    sample_rate_hz: f64,
    params: &JointParams,
) -> Result<JointAnalysis, JointError> {
    if takes.is_empty() {
        return Err(JointError::NoTakes);
    }
    if takes.len() > MAX_TAKES {
        return Err(JointError::TooManyTakes(takes.len()));
    }
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(JointError::Param(format!(
            "sample rate {sample_rate_hz} Hz is not positive"
        )));
    }
    if params.max_cluster == 0 || params.max_iterations == 0 {
        return Err(JointError::Param(
            "max_cluster and max_iterations must be at least 1".into(),
        ));
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(params.min_energy_snr) || !positive(params.disagree_sigmas) {
        return Err(JointError::Param(
            "min_energy_snr and disagree_sigmas must be positive".into(),
        ));
    }
    let peak = takes
        .iter()
        .flat_map(|t| t.segment.iter())
        .fold(0.0f64, |a, &v| a.max(v.abs()));
    for (i, t) in takes.iter().enumerate() {
        if t.segment.is_empty()
            || !(t.noise_rms.is_finite() && t.noise_rms >= 0.0)
            || t.segment.iter().any(|v| !v.is_finite())
        {
            return Err(JointError::BadTake(i));
        }
    }
    // A take without measurable noise (a synthetic one) still gets a finite weight.
    let sigma: Vec<f64> = takes
        .iter()
        .map(|t| t.noise_rms.max(1e-9 * peak).max(1e-300))
        .collect();
    let nt = takes.len();
    let fs = sample_rate_hz;
    let max_len = takes.iter().map(|t| t.segment.len()).max().unwrap_or(0);
    let duration_s = max_len as f64 / fs;

    let mut poles = seed_poles(takes, duration_s);
    if poles.is_empty() {
        return Err(JointError::NoModes);
    }
    let seeds = poles.len();
    let mut residual: Vec<Vec<f64>> = takes.iter().map(|t| t.segment.to_vec()).collect();
    for pole in &poles {
        for (p, r) in residual.iter_mut().enumerate() {
            pole.take_mode(p).add_scaled(fs, -1.0, r);
        }
    }
    let mut iterations = 0;
    let mut clusters_fitted = 0;
    for _ in 0..params.sweeps {
        let ranges = cluster_ranges(&poles, duration_s, params.max_cluster);
        clusters_fitted = ranges.len();
        let mut next: Vec<Pole> = Vec::with_capacity(poles.len());
        for range in ranges {
            let cluster = &poles[range];
            let lens = windows(cluster, takes, &sigma, fs);
            let targets: Vec<Vec<f64>> = (0..nt)
                .map(|p| {
                    let mut y = residual[p][..lens[p]].to_vec();
                    for pole in cluster {
                        pole.take_mode(p).add_scaled(fs, 1.0, &mut y);
                    }
                    y
                })
                .collect();
            let mut fitted = cluster.to_vec();
            iterations += joint_lm(&targets, &sigma, fs, &mut fitted, params.max_iterations);
            let window_s = lens.iter().copied().max().unwrap_or(0) as f64 / fs;
            if merge_close(&mut fitted, window_s) {
                iterations += joint_lm(&targets, &sigma, fs, &mut fitted, params.max_iterations);
            }
            if fitted.iter().all(|q| q.finite()) {
                for p in 0..nt {
                    for pole in cluster {
                        pole.take_mode(p).add_scaled(fs, 1.0, &mut residual[p]);
                    }
                    for pole in &fitted {
                        pole.take_mode(p).add_scaled(fs, -1.0, &mut residual[p]);
                    }
                }
                next.extend(fitted);
            } else {
                next.extend_from_slice(cluster);
            }
        }
        next.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        poles = next;
    }
    // Which takes hear each pole; poles no take hears (or outside the model) go.
    let heard: Vec<Vec<bool>> = poles
        .iter()
        .map(|q| {
            (0..nt)
                .map(|p| {
                    let m = q.take_mode(p);
                    energy(&m, takes[p].segment.len(), fs)
                        >= params.min_energy_snr * sigma[p] * sigma[p]
                })
                .collect()
        })
        .collect();
    let mut kept = Vec::new();
    for (q, h) in poles.into_iter().zip(heard) {
        let ok = crate::plausible(q.freq_hz, q.damping_per_s, fs)
            && q.damping_per_s < crate::analyze::TRANSIENT_DAMPING_PER_S;
        if h.iter().any(|&b| b) && ok {
            kept.push((q, h));
        } else {
            for (p, r) in residual.iter_mut().enumerate() {
                q.take_mode(p).add_scaled(fs, 1.0, r);
            }
        }
    }
    let poles: Vec<Pole> = kept.iter().map(|(q, _)| q.clone()).collect();
    // Each take's noise near each frequency (coloured noise, what the fit misses).
    let profiles: Vec<NoiseProfile> = residual
        .iter()
        .map(|r| NoiseProfile::of_residual(r, fs))
        .collect();
    let mut modes: Vec<JointMode> = Vec::with_capacity(poles.len());
    for range in cluster_ranges(&poles, duration_s, params.max_cluster) {
        let mut converged = poles[range.clone()].to_vec();
        let lens = windows(&converged, takes, &sigma, fs);
        // The cluster once more against the final residual (its neighbours moved after it was
        // fitted): the takes' own fits below start from, and are compared with, the optimum
        // of the very targets they fit, so a deviation is the takes', not the sweeps'.
        let targets: Vec<Vec<f64>> = (0..nt)
            .map(|p| {
                let mut y = residual[p][..lens[p]].to_vec();
                for pole in &converged {
                    pole.take_mode(p).add_scaled(fs, 1.0, &mut y);
                }
                y
            })
            .collect();
        let mut fitted = converged.clone();
        iterations += joint_lm(&targets, &sigma, fs, &mut fitted, params.max_iterations);
        if fitted.iter().all(|q| q.finite()) {
            for (p, r) in residual.iter_mut().enumerate() {
                for (old, new) in converged.iter().zip(&fitted) {
                    old.take_mode(p).add_scaled(fs, 1.0, r);
                    new.take_mode(p).add_scaled(fs, -1.0, r);
                }
            }
            converged = fitted;
        }
        let cluster = &converged[..];
        let centre = cluster.iter().map(|q| q.freq_hz).sum::<f64>() / cluster.len() as f64;
        let local: Vec<f64> = (0..nt)
            .map(|p| profiles[p].rms_at(centre).max(sigma[p]))
            .collect();
        let crb = joint_bounds(cluster, &lens, &local, fs);
        // Each take's own fit of the poles it hears, from the joint values.
        let mut own: Vec<Vec<Option<OwnFit>>> = vec![vec![None; nt]; cluster.len()];
        for p in 0..nt {
            let hearing: Vec<usize> = (0..cluster.len())
                .filter(|&j| kept[range.start + j].1[p])
                .collect();
            if hearing.is_empty() {
                continue;
            }
            let mut y = residual[p][..lens[p]].to_vec();
            for &j in &hearing {
                cluster[j].take_mode(p).add_scaled(fs, 1.0, &mut y);
            }
            let mut alone: Vec<DampedMode> =
                hearing.iter().map(|&j| cluster[j].take_mode(p)).collect();
            iterations += refine::levenberg_marquardt(&y, fs, &mut alone, params.max_iterations);
            if alone.len() != hearing.len() {
                continue;
            }
            let s = crate::crb::mode_sigmas(&alone, fs, y.len(), &profiles[p]);
            for (k, &j) in hearing.iter().enumerate() {
                if alone[k].freq_hz.is_finite() && alone[k].damping_per_s.is_finite() {
                    own[j][p] = Some((alone[k], s[k]));
                }
            }
        }
        for (j, q) in cluster.iter().enumerate() {
            let heard = kept[range.start + j].1.clone();
            let fits: Vec<&OwnFit> = own[j].iter().flatten().collect();
            let scatter = (fits.len() >= 2).then(|| {
                let sd = |v: Vec<f64>| {
                    let n = v.len() as f64;
                    let mean = v.iter().sum::<f64>() / n;
                    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
                };
                ModeSigma {
                    freq_hz: sd(fits.iter().map(|f| f.0.freq_hz).collect()),
                    damping_per_s: sd(fits.iter().map(|f| f.0.damping_per_s).collect()),
                }
            });
            let mut z2 = 0.0;
            let mut count = 0usize;
            for (m, s) in &fits {
                if let Some(s) = s {
                    if s.freq_hz > 0.0 && s.damping_per_s > 0.0 {
                        z2 += ((m.freq_hz - q.freq_hz) / s.freq_hz).powi(2)
                            + ((m.damping_per_s - q.damping_per_s) / s.damping_per_s).powi(2);
                        count += 2;
                    }
                }
            }
            let disagreement_sigmas = if count > 0 {
                (z2 / count as f64).sqrt()
            } else {
                0.0
            };
            let crb_j = crb.as_ref().map(|b| b[j]);
            let sigma_j = match (crb_j, scatter) {
                (Some(c), Some(s)) => {
                    let rn = (fits.len() as f64).sqrt();
                    Some(ModeSigma {
                        freq_hz: c.freq_hz.max(s.freq_hz / rn),
                        damping_per_s: c.damping_per_s.max(s.damping_per_s / rn),
                    })
                }
                (c, _) => c,
            };
            modes.push(JointMode {
                freq_hz: q.freq_hz,
                damping_per_s: q.damping_per_s,
                crb: crb_j,
                scatter,
                sigma: sigma_j,
                amplitude: q.amp.iter().map(|z| z.0.hypot(z.1)).collect(),
                phase_rad: q.amp.iter().map(|z| z.1.atan2(z.0)).collect(),
                heard,
                own: own[j].clone(),
                disagreement_sigmas,
                // One take has no other to disagree with.
                disagree: nt > 1 && disagreement_sigmas > params.disagree_sigmas,
            });
        }
    }
    modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    Ok(JointAnalysis {
        modes,
        noise_rms: residual.iter().map(|r| refine::robust_rms(r)).collect(),
        seeds,
        clusters: clusters_fitted,
        iterations,
    })
}

/// A pole being fitted: shared f and d, each take's `(u, v) = a (cos θ, sin θ)`.
#[derive(Clone, Debug)]
struct Pole {
    freq_hz: f64,
    damping_per_s: f64,
    amp: Vec<(f64, f64)>,
}

impl Pole {
    fn take_mode(&self, p: usize) -> DampedMode {
        let (u, v) = self.amp[p];
        DampedMode {
            freq_hz: self.freq_hz,
            damping_per_s: self.damping_per_s,
            amplitude: u.hypot(v),
            phase_rad: v.atan2(u),
        }
    }

    fn total_amplitude(&self) -> f64 {
        self.amp.iter().map(|z| z.0.hypot(z.1)).sum()
    }

    fn finite(&self) -> bool {
        self.freq_hz.is_finite()
            && self.damping_per_s.is_finite()
            && self.amp.iter().all(|z| z.0.is_finite() && z.1.is_finite())
    }
}

trait AddScaled {
    fn add_scaled(&self, fs: f64, scale: f64, out: &mut [f64]);
}

impl AddScaled for DampedMode {
    fn add_scaled(&self, fs: f64, scale: f64, out: &mut [f64]) {
        if self.amplitude > 0.0 {
            DampedMode {
                amplitude: scale * self.amplitude,
                ..*self
            }
            .add_to(fs, out);
        }
    }
}

/// Energy `Σ s²` of `m` over `n` samples (the closed form of a decaying sinusoid's mean
/// square, half the squared envelope).
fn energy(m: &DampedMode, n: usize, fs: f64) -> f64 {
    let t = n as f64 / fs;
    let d = m.damping_per_s.max(1e-9);
    0.25 * m.amplitude * m.amplitude * fs * (1.0 - (-2.0 * d * t).exp()) / d
}

/// Groups the takes' modes by frequency into poles: a mode joins the group before it when
/// its frequency is within both lines' half widths plus a quarter of the resolution, and its
/// take has no mode in that group yet.
fn seed_poles(takes: &[JointTake], duration_s: f64) -> Vec<Pole> {
    let mut all: Vec<(usize, DampedMode)> = takes
        .iter()
        .enumerate()
        .flat_map(|(p, t)| t.modes.iter().map(move |m| (p, *m)))
        .filter(|(_, m)| m.amplitude > 0.0 && m.freq_hz.is_finite() && m.damping_per_s.is_finite())
        .collect();
    all.sort_by(|a, b| a.1.freq_hz.total_cmp(&b.1.freq_hz));
    let mut groups: Vec<Vec<(usize, DampedMode)>> = Vec::new();
    for (p, m) in all {
        let joins = groups.last().is_some_and(|g| {
            let lead = g
                .iter()
                .max_by(|a, b| a.1.amplitude.total_cmp(&b.1.amplitude))
                .expect("groups are never empty")
                .1;
            let tol = 0.25 / duration_s
                + (lead.damping_per_s + m.damping_per_s) / (2.0 * std::f64::consts::PI);
            (m.freq_hz - lead.freq_hz).abs() < tol && g.iter().all(|(q, _)| *q != p)
        });
        if joins {
            groups.last_mut().expect("checked").push((p, m));
        } else {
            groups.push(vec![(p, m)]);
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    groups
        .into_iter()
        .map(|g| {
            let mut amp = vec![(0.0, 0.0); takes.len()];
            for (p, m) in &g {
                let (s, c) = m.phase_rad.sin_cos();
                amp[*p] = (m.amplitude * c, m.amplitude * s);
            }
            Pole {
                freq_hz: median(g.iter().map(|x| x.1.freq_hz).collect()),
                damping_per_s: median(g.iter().map(|x| x.1.damping_per_s).collect()),
                amp,
            }
        })
        .collect()
}

/// Clusters of overlapping poles (as [`crate::refine`] forms them for one take).
fn cluster_ranges(
    poles: &[Pole],
    duration_s: f64,
    max_cluster: usize,
) -> Vec<std::ops::Range<usize>> {
    let seeds: Vec<Seed> = poles
        .iter()
        .map(|q| Seed {
            mode: DampedMode::new(q.freq_hz, q.damping_per_s, q.total_amplitude()),
            window_len: 0,
        })
        .collect();
    refine::clusters(&seeds, duration_s, max_cluster)
}

/// Samples of each take over which the cluster stands above 0.3 σ of some take's noise: the
/// same time span in every take (a take that hardly hears the cluster still constrains it).
fn windows(cluster: &[Pole], takes: &[JointTake], sigma: &[f64], fs: f64) -> Vec<usize> {
    let t_end = (0..takes.len())
        .flat_map(|p| {
            cluster
                .iter()
                .map(move |q| q.take_mode(p).time_to_floor_s(0.3 * sigma[p]))
        })
        .fold(0.0, f64::max);
    takes
        .iter()
        .map(|t| {
            let n = t.segment.len();
            ((t_end * fs).ceil() as usize).clamp(n.min(256), n)
        })
        .collect()
}

/// Parameters of take `p` in [`crate::refine`]'s layout (per mode f, d, u, v).
fn local_params(cluster: &[Pole], p: usize) -> Vec<f64> {
    cluster
        .iter()
        .flat_map(|q| [q.freq_hz, q.damping_per_s, q.amp[p].0, q.amp[p].1])
        .collect()
}

/// Index in the joint parameter vector (poles' f, d first, then each take's u, v per pole)
/// of local parameter `l` of take `p` for a cluster of `k` poles.
fn global_index(l: usize, p: usize, k: usize) -> usize {
    let (j, c) = (l / P, l % P);
    if c < 2 {
        2 * j + c
    } else {
        2 * k + 2 * k * p + 2 * j + (c - 2)
    }
}

/// The weighted normal equations of the joint fit (upper triangle); returns the weighted cost.
fn joint_normal(
    ys: &[Vec<f64>],
    sigma: &[f64],
    fs: f64,
    cluster: &[Pole],
    jtj: &mut [f64],
    jtr: &mut [f64],
) -> f64 {
    let k = cluster.len();
    let np = 2 * k * (1 + ys.len());
    let nl = P * k;
    jtj.iter_mut().for_each(|v| *v = 0.0);
    jtr.iter_mut().for_each(|v| *v = 0.0);
    let mut lj = vec![0.0; nl * nl];
    let mut lr = vec![0.0; nl];
    let mut cost = 0.0;
    for (p, y) in ys.iter().enumerate() {
        let w2 = 1.0 / (sigma[p] * sigma[p]);
        let local = local_params(cluster, p);
        cost += w2 * normal_equations(y, &local, fs, &mut lj, &mut lr);
        for a in 0..nl {
            let ga = global_index(a, p, k);
            jtr[ga] += w2 * lr[a];
            for b in a..nl {
                let gb = global_index(b, p, k);
                let (lo, hi) = (ga.min(gb), ga.max(gb));
                jtj[lo * np + hi] += w2 * lj[a * nl + b];
            }
        }
    }
    cost
}

fn joint_cost(ys: &[Vec<f64>], sigma: &[f64], fs: f64, cluster: &[Pole]) -> f64 {
    ys.iter()
        .enumerate()
        .map(|(p, y)| refine::cost(y, &local_params(cluster, p), fs) / (sigma[p] * sigma[p]))
        .sum()
}

fn apply_step(cluster: &[Pole], delta: &[f64]) -> Vec<Pole> {
    let k = cluster.len();
    cluster
        .iter()
        .enumerate()
        .map(|(j, q)| Pole {
            freq_hz: q.freq_hz + delta[2 * j],
            damping_per_s: q.damping_per_s + delta[2 * j + 1],
            amp: q
                .amp
                .iter()
                .enumerate()
                .map(|(p, z)| {
                    let o = 2 * k + 2 * k * p + 2 * j;
                    (z.0 + delta[o], z.1 + delta[o + 1])
                })
                .collect(),
        })
        .collect()
}

/// Levenberg–Marquardt over the shared poles and every take's amplitudes; returns the
/// iterations used.
fn joint_lm(
    ys: &[Vec<f64>],
    sigma: &[f64],
    fs: f64,
    cluster: &mut Vec<Pole>,
    max_iterations: usize,
) -> usize {
    let k = cluster.len();
    let np = 2 * k * (1 + ys.len());
    let samples: usize = ys.iter().map(Vec::len).sum::<usize>().max(1);
    let mut jtj = vec![0.0; np * np];
    let mut jtr = vec![0.0; np];
    let mut mu = 1e-3;
    let mut iterations = 0;
    for _ in 0..max_iterations {
        iterations += 1;
        let c0 = joint_normal(ys, sigma, fs, cluster, &mut jtj, &mut jtr);
        if !(c0 > 0.0) {
            break;
        }
        let mut improved = false;
        while mu < 1e12 {
            let mut a = jtj.clone();
            for i in 0..np {
                for j in 0..i {
                    a[i * np + j] = a[j * np + i];
                }
                // A take that does not hear a pole leaves its amplitude's diagonal at ~0;
                // the small absolute term keeps the system definite.
                a[i * np + i] += mu * jtj[i * np + i] + 1e-12 * (1.0 + jtj[i * np + i]);
            }
            let Some(delta) = cholesky_solve(&mut a, &jtr, np) else {
                mu *= 10.0;
                continue;
            };
            let predicted: f64 = delta.iter().zip(&jtr).map(|(d, g)| d * g).sum();
            if predicted <= 1e-2 * c0 / samples as f64 && predicted >= 0.0 {
                return iterations;
            }
            let trial = apply_step(cluster, &delta);
            let admissible = trial
                .iter()
                .all(|q| crate::plausible(q.freq_hz, q.damping_per_s, fs) && q.finite());
            let c1 = if admissible {
                joint_cost(ys, sigma, fs, &trial)
            } else {
                f64::INFINITY
            };
            if c1 < c0 {
                *cluster = trial;
                mu = (mu / 3.0).max(1e-12);
                improved = true;
                let noise_var = c1 / samples as f64;
                if (c0 - c1) <= (1e-2 * noise_var).max(1e-15 * c0) {
                    return iterations;
                }
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    iterations
}

/// Merges poles closer than the window's resolution (or a quarter of their line widths) into
/// one carrying their summed complex amplitudes; returns whether any merged.
fn merge_close(cluster: &mut Vec<Pole>, window_s: f64) -> bool {
    cluster.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let mut merged = false;
    let mut i = 0;
    while i + 1 < cluster.len() {
        let (a, b) = (&cluster[i], &cluster[i + 1]);
        let close = 0.25 / window_s.max(1e-9)
            + (a.damping_per_s + b.damping_per_s) / (4.0 * std::f64::consts::PI);
        if b.freq_hz - a.freq_hz < close {
            let (wa, wb) = (a.total_amplitude(), b.total_amplitude());
            let w = (wa + wb).max(1e-300);
            let q = Pole {
                freq_hz: (a.freq_hz * wa + b.freq_hz * wb) / w,
                damping_per_s: (a.damping_per_s * wa + b.damping_per_s * wb) / w,
                amp: a
                    .amp
                    .iter()
                    .zip(&b.amp)
                    .map(|(x, y)| (x.0 + y.0, x.1 + y.1))
                    .collect(),
            };
            cluster[i] = q;
            cluster.remove(i + 1);
            merged = true;
        } else {
            i += 1;
        }
    }
    merged
}

/// The joint Cramér–Rao bound of each pole of `cluster`: the inverse of the weighted normal
/// matrix (the Fisher information under each take's noise) at the fit.
fn joint_bounds(
    cluster: &[Pole],
    lens: &[usize],
    sigma: &[f64],
    fs: f64,
) -> Option<Vec<ModeSigma>> {
    let k = cluster.len();
    let nt = lens.len();
    let np = 2 * k * (1 + nt);
    let ys: Vec<Vec<f64>> = (0..nt).map(|p| vec![0.0; lens[p]]).collect();
    let mut jtj = vec![0.0; np * np];
    let mut jtr = vec![0.0; np];
    joint_normal(&ys, sigma, fs, cluster, &mut jtj, &mut jtr);
    for i in 0..np {
        for j in 0..i {
            jtj[i * np + j] = jtj[j * np + i];
        }
        // Amplitudes of takes that do not hear a pole are not estimated: pin them.
        if jtj[i * np + i] <= 0.0 {
            jtj[i * np + i] = 1.0;
        }
    }
    let mut out = Vec::with_capacity(k);
    for j in 0..k {
        let mut var = [0.0; 2];
        for (c, v) in var.iter_mut().enumerate() {
            let mut e = vec![0.0; np];
            e[2 * j + c] = 1.0;
            let x = cholesky_solve(&mut jtj.clone(), &e, np)?;
            *v = x[2 * j + c];
        }
        if !(var[0] > 0.0 && var[1] > 0.0) {
            return None;
        }
        out.push(ModeSigma {
            freq_hz: var[0].sqrt(),
            damping_per_s: var[1].sqrt(),
        });
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use resound_core::damped::synthesize;

    /// Deterministic uniform numbers in [0, 1).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    fn gauss(state: &mut u64) -> f64 {
        let (u, v) = (lcg(state).max(1e-300), lcg(state));
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    #[test]
    fn takes_of_one_object_share_their_poles_and_bad_input_is_refused() {
        let fs = 48000.0;
        let truth = [(700.0, 4.0), (1680.0, 6.0), (1683.0, 9.0), (3100.0, 15.0)];
        let mut state = 7u64;
        let n = 24000;
        let mut segs = Vec::new();
        let mut found = Vec::new();
        for _ in 0..4 {
            let modes: Vec<DampedMode> = truth
                .iter()
                .map(|&(f, d)| DampedMode {
                    freq_hz: f,
                    damping_per_s: d,
                    amplitude: 0.1 + 0.3 * lcg(&mut state),
                    phase_rad: 6.0 * lcg(&mut state),
                })
                .collect();
            let mut x = synthesize(&modes, fs, n);
            x.iter_mut().for_each(|v| *v += 1e-4 * gauss(&mut state));
            // Seeds off by a little, as a take's own analysis might leave them.
            let seeds: Vec<DampedMode> = modes
                .iter()
                .map(|m| DampedMode {
                    freq_hz: m.freq_hz + 0.2,
                    damping_per_s: m.damping_per_s * 1.2,
                    ..*m
                })
                .collect();
            segs.push(x);
            found.push(seeds);
        }
        let takes: Vec<JointTake> = segs
            .iter()
            .zip(&found)
            .map(|(s, m)| JointTake {
                segment: s,
                noise_rms: 1e-4,
                modes: m,
            })
            .collect();
        let j = joint_fit(&takes, fs, &JointParams::default()).unwrap();
        assert_eq!(j.modes.len(), 4, "{:?}", j.modes);
        for (m, &(f, d)) in j.modes.iter().zip(&truth) {
            let s = m.sigma.unwrap();
            assert!((m.freq_hz - f).abs() < 5.0 * s.freq_hz, "{m:?}");
            assert!((m.damping_per_s - d).abs() < 5.0 * s.damping_per_s, "{m:?}");
            assert!(!m.disagree, "{m:?}");
            assert!(m.heard.iter().all(|&h| h));
        }
        assert!(j.take_modes(2).len() == 4);
        // One take alone: its own fit is the joint fit (nothing to disagree with, and the
        // deviation measured is the take's, not the sweeps' leftover convergence).
        let alone = joint_fit(&takes[..1], fs, &JointParams::default()).unwrap();
        assert!(
            alone.modes.iter().all(|m| m.disagreement_sigmas < 0.5),
            "{:?}",
            alone.modes
        );
        let many = vec![takes[0]; MAX_TAKES + 1];
        assert_eq!(
            joint_fit(&many, fs, &JointParams::default()),
            Err(JointError::TooManyTakes(MAX_TAKES + 1))
        );
        assert_eq!(
            joint_fit(&[], fs, &JointParams::default()),
            Err(JointError::NoTakes)
        );
        let bad = [JointTake {
            segment: &[f64::NAN; 4],
            noise_rms: 1e-3,
            modes: &[],
        }];
        assert_eq!(
            joint_fit(&bad, fs, &JointParams::default()),
            Err(JointError::BadTake(0))
        );
    }

    #[test]
    fn takes_of_two_objects_are_flagged() {
        // The same mode 0.3 % apart in two takes (two objects): one pole cannot serve both.
        let fs = 48000.0;
        let mut state = 3u64;
        let n = 24000;
        let mut segs = Vec::new();
        let mut found = Vec::new();
        for f in [1000.0, 1003.0] {
            let m = DampedMode::new(f, 5.0, 0.3);
            let mut x = synthesize(&[m], fs, n);
            x.iter_mut().for_each(|v| *v += 1e-4 * gauss(&mut state));
            segs.push(x);
            found.push(vec![m]);
        }
        // Without the second object the same call finds nothing to flag.
        let one = [JointTake {
            segment: &segs[0],
            noise_rms: 1e-4,
            modes: &found[0],
        }];
        let j1 = joint_fit(&one, fs, &JointParams::default()).unwrap();
        assert!(
            j1.modes.iter().all(|m| m.disagreement_sigmas < 0.5),
            "{:?}",
            j1.modes
        );
        let takes: Vec<JointTake> = segs
            .iter()
            .zip(&found)
            .map(|(s, m)| JointTake {
                segment: s,
                noise_rms: 1e-4,
                modes: m,
            })
            .collect();
        let j = joint_fit(&takes, fs, &JointParams::default()).unwrap();
        // Either the two are kept apart (each heard by one take) or the shared pole is flagged.
        let apart = j.modes.len() == 2
            && j.modes
                .iter()
                .all(|m| m.heard.iter().filter(|&&h| h).count() == 1);
        let flagged = j.modes.iter().any(|m| m.disagree);
        assert!(apart || flagged, "{:?}", j.modes);
    }
}
