//! One material from several recordings: several strikes, several microphones, several objects.
//!
//! Every take (a recording with its own object side — eigenvalues and gains at its hit) keeps
//! its own amplitude scale σ_k (strike force, microphone distance and gain differ), while α, β
//! and γ are shared. The joint metric is the mean over takes of each take's hybrid metric
//! relative to the best that take reaches alone: scale-free (a loud take does not outweigh a
//! quiet one), and a take matched much worse than it can be costs more than another take
//! matched a little better gains.
//!
//! Each take is first estimated alone ([`crate::estimate()`]); the distinct (α, β, γ) found
//! become the joint starts, the σ_k of each start are fitted take by take (golden section on
//! ln σ), then Nelder–Mead refines (α, ln β, ln γ, ln σ_1 … ln σ_K) together. The takes' own
//! estimates are kept: their spread is the measured variation between takes.

use crate::estimate::ModalSide;
use crate::estimate::{
    estimate, from_vec, to_vec, Estimate, EstimateError, EstimateParams, Objective,
};
use crate::forward::RayleighParams;
use argmin::core::{CostFunction, Error as ArgminError, Executor};
use argmin::solver::neldermead::NelderMead;
use rayon::prelude::*;
use resound_core::DampedMode;

/// One recording of the material.
#[derive(Clone, Copy, Debug)]
pub struct Take<'a> {
    /// The recorded object at its hit point.
    pub side: &'a ModalSide,
    /// Onset-aligned recording.
    pub signal: &'a [f64],
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The recording's analysed modes.
    pub reference_modes: &'a [DampedMode],
}

/// Result of [`estimate_joint`].
#[derive(Clone, Debug)]
pub struct JointEstimate {
    /// Shared α, β, γ, with σ of the first take.
    pub params: RayleighParams,
    /// σ of every take (same order as the takes).
    pub sigmas: Vec<f64>,
    /// Geometric mean of the takes' hybrid metrics at the joint parameters.
    pub metric: f64,
    /// Each take's hybrid metric at the joint parameters.
    pub take_metrics: Vec<f64>,
    /// Each take estimated alone.
    pub individual: Vec<Estimate>,
    /// Takes left out of the joint metric: their own best metric is 0 (their loudness image
    /// holds nothing above its floor, so any parameters match them equally).
    pub left_out: Vec<usize>,
    /// Joint starting points refined.
    pub starts: usize,
    /// Metric evaluations in all (per take; the individual estimates' included).
    pub evaluations: usize,
}

/// How many joint starts [`estimate_joint`] refines at most.
pub const MAX_JOINT_STARTS: usize = 3;

/// Estimates one material from several takes. `on_take_done` is called after each take's own
/// estimate and after the joint refinement.
///
/// # Errors
/// As [`estimate()`] for any take; no takes.
pub fn estimate_joint(
    takes: &[Take<'_>],
    params: &EstimateParams,
    on_take_done: &(dyn Fn() + Sync),
) -> Result<JointEstimate, EstimateError> {
    if takes.is_empty() {
        return Err(EstimateError::NoReferenceModes);
    }
    let mut individual = Vec::with_capacity(takes.len());
    for t in takes {
        individual.push(estimate(
            t.side,
            t.signal,
            t.sample_rate_hz,
            t.reference_modes,
            params,
            &|| {},
        )?);
        on_take_done();
    }
    let objectives: Vec<Objective<'_>> = takes
        .iter()
        .map(|t| {
            Objective::new(
                t.side,
                t.signal,
                t.sample_rate_hz,
                t.reference_modes,
                params.floor_db,
                params.route,
            )
        })
        .collect::<Result<_, _>>()?;
    let left_out: Vec<usize> = (0..takes.len())
        .filter(|&k| !(individual[k].metric > 0.0 && individual[k].metric.is_finite()))
        .collect();
    if left_out.len() == takes.len() {
        return Err(EstimateError::Uninformative);
    }
    // A left-out take weighs nothing (its unit is infinite).
    let own: Vec<f64> = individual
        .iter()
        .map(|e| {
            if e.metric > 0.0 && e.metric.is_finite() {
                e.metric
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let joint = Joint {
        objectives: &objectives,
        own: &own,
    };
    // Starts: each take's (α, β, γ) with every take's σ fitted there; the best few.
    let mut starts: Vec<(f64, Vec<f64>)> = individual
        .par_iter()
        .map(|e| {
            let sigmas: Vec<f64> = objectives
                .iter()
                .zip(&individual)
                .map(|(o, own)| best_sigma(o, &e.params, own.params.sigma))
                .collect();
            let v = joint.vector(&e.params, &sigmas);
            (joint.cost_of(&v), v)
        })
        .collect();
    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
    starts.dedup_by(|a, b| {
        a.1.iter()
            .zip(&b.1)
            .take(3)
            .all(|(x, y)| (x - y).abs() < 1e-3 * (1.0 + y.abs()))
    });
    starts.truncate(MAX_JOINT_STARTS);
    let dims = 3 + takes.len();
    let iterations = params.max_iterations * dims as u64 / 4;
    let refined: Vec<(Vec<f64>, f64, usize)> = starts
        .par_iter()
        .map(|(c, v)| refine(&joint, v, *c, iterations))
        .collect();
    on_take_done();
    let (v, _, _) = refined
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .ok_or(EstimateError::NoStart)?;
    let (p, sigmas) = joint.params(v);
    let take_metrics: Vec<f64> = objectives
        .iter()
        .zip(&sigmas)
        .map(|(o, &sigma)| o.hybrid(&RayleighParams { sigma, ..p }))
        .collect();
    let counted: Vec<f64> = (0..takes.len())
        .filter(|k| !left_out.contains(k))
        .map(|k| take_metrics[k])
        .collect();
    let metric = (counted.iter().map(|m| m.ln()).sum::<f64>() / counted.len() as f64).exp();
    let evaluations = individual.iter().map(|e| e.evaluations).sum::<usize>()
        + refined.iter().map(|r| r.2).sum::<usize>() * takes.len();
    Ok(JointEstimate {
        params: RayleighParams {
            sigma: sigmas[0],
            ..p
        },
        sigmas,
        metric,
        take_metrics,
        individual,
        left_out,
        starts: starts.len(),
        evaluations,
    })
}

/// The joint metric over (α, ln β, ln γ, ln σ_1 … ln σ_K).
struct Joint<'a, 'b> {
    objectives: &'b [Objective<'a>],
    /// Each take's metric alone (the unit of its term).
    own: &'b [f64],
}

impl Joint<'_, '_> {
    fn vector(&self, p: &RayleighParams, sigmas: &[f64]) -> Vec<f64> {
        let mut v = to_vec(p);
        v.truncate(3);
        v.extend(sigmas.iter().map(|s| s.ln()));
        v
    }

    fn params(&self, v: &[f64]) -> (RayleighParams, Vec<f64>) {
        let p = from_vec(&[v[0], v[1], v[2], 0.0]);
        (p, v[3..].iter().map(|s| s.exp()).collect())
    }

    /// Mean hybrid metric relative to each take's own; `f64::INFINITY` when any take has no
    /// match.
    fn cost_of(&self, v: &[f64]) -> f64 {
        let (p, sigmas) = self.params(v);
        let mut sum = 0.0;
        for ((o, &sigma), own) in self.objectives.iter().zip(&sigmas).zip(self.own) {
            let m = o.hybrid(&RayleighParams { sigma, ..p });
            if own.is_infinite() {
                continue;
            }
            if !m.is_finite() {
                return f64::INFINITY;
            }
            sum += m / own;
        }
        sum / self.own.iter().filter(|o| o.is_finite()).count().max(1) as f64
    }
}

impl CostFunction for Joint<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, v: &Self::Param) -> Result<f64, ArgminError> {
        let c = self.cost_of(v);
        Ok(if c.is_finite() { c } else { 1e300 })
    }
}

/// σ minimising one take's metric at the shared parameters of `p`: golden section on ln σ
/// within a factor e² of `guess`.
fn best_sigma(objective: &Objective<'_>, p: &RayleighParams, guess: f64) -> f64 {
    let f = |ls: f64| {
        let m = objective.hybrid(&RayleighParams {
            sigma: ls.exp(),
            ..*p
        });
        if m.is_finite() {
            m
        } else {
            f64::INFINITY
        }
    };
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (guess.ln() - 2.0, guess.ln() + 2.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..14 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    let best = 0.5 * (a + b);
    if f(best) <= f(guess.ln()) {
        best.exp()
    } else {
        guess
    }
}

/// Nelder–Mead from `v0`; the best vector, its cost and the evaluations.
fn refine(joint: &Joint<'_, '_>, v0: &[f64], c0: f64, iterations: u64) -> (Vec<f64>, f64, usize) {
    let mut simplex = vec![v0.to_vec()];
    for i in 0..v0.len() {
        let mut v = v0.to_vec();
        v[i] += if i == 0 {
            0.2 * v0[0].abs().max(1.0)
        } else {
            0.1
        };
        simplex.push(v);
    }
    let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(1e-9) else {
        return (v0.to_vec(), c0, 1);
    };
    match Executor::new(
        Joint {
            objectives: joint.objectives,
            own: joint.own,
        },
        solver,
    )
    .configure(|s| s.max_iters(iterations))
    .run()
    {
        Ok(res) => {
            let evals = res.state.counts.values().sum::<u64>() as usize;
            match res.state.best_param.clone() {
                Some(v) => {
                    let c = joint.cost_of(&v);
                    if c <= c0 {
                        (v, c, evals.max(1))
                    } else {
                        (v0.to_vec(), c0, evals.max(1))
                    }
                }
                None => (v0.to_vec(), c0, evals.max(1)),
            }
        }
        Err(_) => (v0.to_vec(), c0, 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::forward::forward_modes;
    use resound_core::damped::synthesize;

    /// A small object: eigenvalues of a bar-like spectrum, gains that differ by hit.
    fn side(hit: usize) -> ModalSide {
        let f0 = [480.0, 1320.0, 2590.0, 4280.0, 6390.0, 8930.0];
        let eigenvalues0: Vec<f64> = f0
            .iter()
            .map(|f| (std::f64::consts::TAU * f).powi(2))
            .collect();
        let gains0: Vec<f64> = (0..f0.len())
            .map(|j| 1e-3 * (1.0 + 0.7 * (((j + 1) * (hit + 2)) as f64).sin()))
            .collect();
        ModalSide {
            eigenvalues0,
            gains0,
            gamma0: 2.5e7,
        }
    }

    #[test]
    fn takes_of_one_material_give_its_parameters_with_their_own_sigmas() {
        let truth = RayleighParams {
            alpha: 8.0,
            beta: 4e-8,
            gamma: 2.7e7,
            sigma: 1.0,
        };
        let fs = 44100.0;
        let sides: Vec<ModalSide> = (0..3).map(side).collect();
        let sigma_true = [200.0, 60.0, 450.0];
        let signals: Vec<Vec<f64>> = sides
            .iter()
            .zip(sigma_true)
            .map(|(s, sigma)| {
                let p = RayleighParams { sigma, ..truth };
                let modes = forward_modes(&s.eigenvalues0, &s.gains0, s.gamma0, &p, 0.5 * fs);
                synthesize(&modes, fs, 22050)
            })
            .collect();
        let refs: Vec<Vec<DampedMode>> = sides
            .iter()
            .zip(sigma_true)
            .map(|(s, sigma)| {
                let p = RayleighParams { sigma, ..truth };
                forward_modes(&s.eigenvalues0, &s.gains0, s.gamma0, &p, 0.5 * fs)
            })
            .collect();
        let takes: Vec<Take<'_>> = (0..3)
            .map(|k| Take {
                side: &sides[k],
                signal: &signals[k],
                sample_rate_hz: fs,
                reference_modes: &refs[k],
            })
            .collect();
        let r = estimate_joint(&takes, &EstimateParams::default(), &|| {}).unwrap();
        assert_eq!(r.individual.len(), 3);
        assert_eq!(r.sigmas.len(), 3);
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        assert!(rel(r.params.gamma, truth.gamma) < 1e-3, "{r:?}");
        assert!(rel(r.params.beta, truth.beta) < 2e-2, "{r:?}");
        for (s, t) in r.sigmas.iter().zip(sigma_true) {
            assert!(rel(*s, t) < 2e-2, "σ {s} vs {t}");
        }
        // The joint optimum is no worse on the joint metric than any take's own estimate.
        let own: Vec<f64> = r.individual.iter().map(|e| e.metric).collect();
        let joint = Joint {
            own: &own,
            objectives: &takes
                .iter()
                .map(|t| {
                    Objective::new(
                        t.side,
                        t.signal,
                        t.sample_rate_hz,
                        t.reference_modes,
                        50.0,
                        crate::ImageRoute::Auto,
                    )
                    .unwrap()
                })
                .collect::<Vec<_>>(),
        };
        let at_joint = joint.cost_of(&joint.vector(&r.params, &r.sigmas));
        for e in &r.individual {
            let sig: Vec<f64> = r.sigmas.clone();
            assert!(at_joint <= joint.cost_of(&joint.vector(&e.params, &sig)) + 1e-9);
        }
        assert!(estimate_joint(&[], &EstimateParams::default(), &|| {}).is_err());
    }
}
