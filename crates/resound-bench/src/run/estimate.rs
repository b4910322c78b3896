//! `bench estimate`: material estimation (Ren's Fig. 9 protocol on Spot).

use super::*;

/// Runs `bench estimate` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_estimate(a: EstimateBenchArgs) -> Result<()> {
    use crate::recovery::{recovery_case, recovery_case_between, table_cases};
    use resound::estimate::{ImageRoute, ModalSide};
    let (mesh, ceramic) = bench_mesh("spot")?;
    let side_at = |voxels: usize| -> Result<ModalSide> {
        let p = ModalParams {
            n_modes: Some(40),
            max_freq_hz: None,
            target_voxels: voxels,
            ..Default::default()
        };
        let model = ModalBuilder::surface(&mesh, &ceramic)
            .params(p)
            .solve()?
            .model;
        let sp = model.locate_hit([-0.0706, 0.1061, -0.0301], 0.02)?;
        Ok(ModalSide {
            eigenvalues0: model.eigenvalues.clone(),
            gains0: model.gains(&sp),
            gamma0: ceramic.stiffness_density_ratio(),
        })
    };
    let side = side_at(2500)?;
    let mut runs = vec![(None, ImageRoute::Auto), (Some(40.0), ImageRoute::Auto)];
    if !a.no_synthesized {
        runs.push((None, ImageRoute::Analytic));
        runs.push((None, ImageRoute::Synthesized));
    }
    let mut rows = Vec::new();
    for (name, truth) in table_cases() {
        for &(snr, route) in &runs {
            if !a.json {
                eprintln!("bench estimate: {name}, {route:?}, SNR {snr:?} ...");
            }
            let r = recovery_case(&side, name, truth, snr, route, 1).map_err(anyhow::Error::msg)?;
            if !a.json {
                println!(
                    "{:<13} {:<11} {:>6} err alpha {:.2e} beta {:.2e} gamma {:.2e} sigma {:.2e}  {:>3} starts {:>5} evals {:>6.2} s",
                    r.name,
                    r.route,
                    snr.map_or("clean".to_string(), |s| format!("{s} dB")),
                    r.rel_error[0],
                    r.rel_error[1],
                    r.rel_error[2],
                    r.rel_error[3],
                    r.starts,
                    r.evaluations,
                    r.elapsed_s
                );
            }
            rows.push(r);
        }
    }
    // The sound from a finer mesh of the same object, estimated on the coarse one.
    let fine_voxels = 12_000;
    let fine = side_at(fine_voxels)?;
    let mut bias_rows = Vec::new();
    for (name, truth) in table_cases() {
        let r = recovery_case_between(&fine, &side, name, truth, None, ImageRoute::Auto, 1)
            .map_err(anyhow::Error::msg)?;
        if !a.json {
            println!(
                "{:<13} sound from {fine_voxels} voxels, estimated on 2500: gamma bias {:+.2}%, err alpha {:.2e} beta {:.2e}  {:>6.2} s",
                r.name,
                100.0 * r.gamma_bias,
                r.rel_error[0],
                r.rel_error[1],
                r.elapsed_s
            );
        }
        bias_rows.push(r);
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&EstimateDoc {
                benchmark: "estimate",
                mesh: "spot (CC0), 0.15 scale, 40 modes, ~2500 voxels",
                cases: &rows,
                finer_source_voxels: fine_voxels,
                finer_source_cases: &bias_rows,
            })?
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct EstimateDoc<'a> {
    benchmark: &'static str,
    mesh: &'static str,
    cases: &'a [crate::recovery::RecoveryReport],
    finer_source_voxels: usize,
    finer_source_cases: &'a [crate::recovery::RecoveryReport],
}
