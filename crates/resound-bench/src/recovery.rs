//! Recovery cases (Ren 2013 Fig. 9 protocol) shared by the tests and `resound bench estimate`:
//! synthesize an object's sound with known {α, β, γ, σ}, optionally add white noise, analyse it
//! like a recording, estimate, and compare.

use rand::rngs::SmallRng;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use resound_core::damped::synthesize;
use resound_estimate::estimate::{estimate, EstimateParams, ImageRoute, ModalSide};
use resound_estimate::forward::{forward_modes, RayleighParams};
use resound_signal::{analyze, AnalyzeParams};
use serde::Serialize;

/// One recovery case's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct RecoveryReport {
    /// Case name.
    pub name: String,
    /// "analytic" or "synthesized".
    pub route: String,
    /// SNR of the added noise (dB), or null for noise-free.
    pub snr_db: Option<f64>,
    /// Relative errors of α, β, γ, σ.
    pub rel_error: [f64; 4],
    /// Estimated α, β, γ, σ.
    pub estimate: [f64; 4],
    /// True α, β, γ, σ.
    pub truth: [f64; 4],
    /// Wall time of the estimation (analysis excluded), s.
    pub elapsed_s: f64,
    /// Starting points.
    pub starts: usize,
    /// Metric evaluations.
    pub evaluations: usize,
    /// Reference modes the analysis found.
    pub reference_modes: usize,
    /// γ estimated / γ true − 1 (signed): the bias when the sound comes from another mesh.
    pub gamma_bias: f64,
}

/// The three parameter sets: α, β of Ren's Table I wood, plastic and metal; γ = E/ρ of our
/// wood, plastic and steel presets.
pub fn table_cases() -> Vec<(&'static str, RayleighParams)> {
    vec![
        (
            "wood-like",
            RayleighParams {
                alpha: 2.1364,
                beta: 3.0828e-6,
                gamma: 11e9 / 750.0,
                sigma: 1.0,
            },
        ),
        (
            "plastic-like",
            RayleighParams {
                alpha: 52.627,
                beta: 8.7753e-7,
                gamma: 2.3e9 / 1050.0,
                sigma: 1.0,
            },
        ),
        (
            "metal-like",
            RayleighParams {
                alpha: 6.3035,
                beta: 2.1160e-8,
                gamma: 200e9 / 7850.0,
                sigma: 1.0,
            },
        ),
    ]
}

/// Runs one case: σ is set so the synthesized strike peaks at 0.3 of full scale.
pub fn recovery_case(
    side: &ModalSide,
    name: &str,
    truth: RayleighParams,
    snr_db: Option<f64>,
    route: ImageRoute,
    seed: u64,
) -> Result<RecoveryReport, String> {
    recovery_case_between(side, side, name, truth, snr_db, route, seed)
}

/// [`recovery_case`] with the sound made by `source` (e.g. a finer mesh of the object) and the
/// estimation done on `target`. A discretization that is too stiff by a factor `s` in λ is
/// compensated by γ, so `gamma_bias` ≈ `1/s − 1`.
pub fn recovery_case_between(
    source: &ModalSide,
    target: &ModalSide,
    name: &str,
    truth: RayleighParams,
    snr_db: Option<f64>,
    route: ImageRoute,
    seed: u64,
) -> Result<RecoveryReport, String> {
    let side = target;
    let fs = 44100.0;
    let n = 22050;
    let unit = forward_modes(
        &source.eigenvalues0,
        &source.gains0,
        source.gamma0,
        &truth,
        0.5 * fs,
    );
    let raw = synthesize(&unit, fs, n);
    let peak = raw.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(peak > 0.0) {
        return Err(format!("{name}: no audible modes"));
    }
    let truth = RayleighParams {
        sigma: truth.sigma * 0.3 / peak,
        ..truth
    };
    let mut x: Vec<f64> = raw.iter().map(|v| v * 0.3 / peak).collect();
    if let Some(snr) = snr_db {
        let power = x.iter().map(|v| v * v).sum::<f64>() / n as f64;
        let normal =
            Normal::new(0.0, (power / 10f64.powf(snr / 10.0)).sqrt()).map_err(|e| e.to_string())?;
        let mut rng = SmallRng::seed_from_u64(seed);
        x.iter_mut().for_each(|v| *v += normal.sample(&mut rng));
    }
    let analysis =
        analyze(&x, fs, &AnalyzeParams::default()).map_err(|e| format!("{name}: {e}"))?;
    let seg = &analysis.segment;
    let params = EstimateParams {
        route,
        ..EstimateParams::default()
    };
    let t0 = std::time::Instant::now();
    let est = estimate(side, seg, fs, &analysis.modes, &params, &|| {})
        .map_err(|e| format!("{name}: {e} (reference modes: {:?})", analysis.modes))?;
    let elapsed_s = t0.elapsed().as_secs_f64();
    let t = [truth.alpha, truth.beta, truth.gamma, truth.sigma];
    let e = [
        est.params.alpha,
        est.params.beta,
        est.params.gamma,
        est.params.sigma,
    ];
    let rel = |i: usize| (e[i] / t[i] - 1.0).abs();
    Ok(RecoveryReport {
        name: name.to_string(),
        route: match route {
            ImageRoute::Auto => "auto".into(),
            ImageRoute::Analytic => "analytic".into(),
            ImageRoute::Synthesized => "synthesized".into(),
        },
        snr_db,
        rel_error: [rel(0), rel(1), rel(2), rel(3)],
        estimate: e,
        truth: t,
        elapsed_s,
        starts: est.starts,
        evaluations: est.evaluations,
        reference_modes: analysis.modes.len(),
        gamma_bias: e[2] / t[2] - 1.0,
    })
}
