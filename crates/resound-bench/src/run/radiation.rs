//! `bench radiation`: the acoustic transfer of Spot.

use super::*;

/// Runs `bench radiation` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_radiation(a: RadiationBenchArgs) -> Result<()> {
    use resound::core::radiation::FieldScratch;
    let (mesh, material) = bench_mesh("spot")?;
    let t0 = std::time::Instant::now();
    let solved = resound::modal::ModalBuilder::surface(&mesh, &material)
        .modes(a.modes)
        .solve()?;
    let solve_s = t0.elapsed().as_secs_f64();
    let rss_solve = peak_rss_mib();
    let mut model = solved.model;
    let t1 = std::time::Instant::now();
    let info = resound::radiation::add_transfer(
        &mut model,
        &resound::modal::TransferParams {
            max_sources: a.sources,
            ..Default::default()
        },
    )?;
    let fit_s = t1.elapsed().as_secs_f64();
    let rss_fit = peak_rss_mib();
    let t = model.transfer.as_ref().context("no transfer")?;
    let freqs = model.freqs_hz();
    // Run time: every mode's factor at 200 listener positions on a circle 1 m away.
    let mut scratch = FieldScratch::new(t.max_order());
    let positions: Vec<[f64; 3]> = (0..200)
        .map(|i| {
            let a = i as f64 * 0.0314;
            [a.cos(), 0.3, a.sin()]
        })
        .collect();
    let mut eval = f64::INFINITY;
    let mut one_by_one = f64::INFINITY;
    let mut batch = resound::core::radiation::BatchScratch::for_transfer(t);
    let mut out = vec![0.0; freqs.len()];
    let mut worst_rel = 0.0f64;
    for _ in 0..3 {
        let t2 = std::time::Instant::now();
        let mut sink = 0.0;
        for x in &positions {
            t.factors_into(&freqs, *x, &mut batch, &mut out);
            sink += out.iter().sum::<f64>();
        }
        std::hint::black_box(sink);
        eval = eval.min(t2.elapsed().as_secs_f64());
        let t3 = std::time::Instant::now();
        for x in &positions[..20] {
            for (j, &f) in freqs.iter().enumerate() {
                let one = t.factor(j, f, *x, &mut scratch).unwrap_or(0.0);
                sink += one;
            }
        }
        std::hint::black_box(sink);
        one_by_one = one_by_one.min(t3.elapsed().as_secs_f64() * positions.len() as f64 / 20.0);
    }
    // The batch and the one-mode path agree.
    for x in &positions[..5] {
        t.factors_into(&freqs, *x, &mut batch, &mut out);
        for (j, &f) in freqs.iter().enumerate() {
            let one = t.factor(j, f, *x, &mut scratch).unwrap_or(0.0);
            worst_rel = worst_rel.max((one - out[j]).abs() / one.abs().max(1e-300));
        }
    }
    if worst_rel > 1e-9 {
        bail!("batched radiation factors differ from the one-mode path by {worst_rel:e}");
    }
    let one_by_one_us = one_by_one / (positions.len() * freqs.len()) as f64 * 1e6;
    let per_mode_us = eval / (positions.len() * freqs.len()) as f64 * 1e6;
    // Baseline in the same run: the bank's cost of one mode for one 256-sample block.
    let rate = (0..3)
        .map(|_| crate::throughput::bank_mode_samples_per_s(64, 1.0, false))
        .fold(0.0, f64::max);
    let block_us = 256.0 / rate * 1e6;
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        modes: usize,
        surface_vertices: usize,
        solve_s: f64,
        transfer_fit_s: f64,
        transfer_bytes: usize,
        sources: usize,
        grid_points: usize,
        worst_misfit: f64,
        poorly_fitted: usize,
        peak_rss_after_solve_mib: Option<f64>,
        peak_rss_after_fit_mib: Option<f64>,
        factor_per_mode_us: f64,
        factor_one_mode_at_a_time_us: f64,
        bank_block256_per_mode_us: f64,
        factor_over_block: f64,
    }
    let v = Doc {
        benchmark: "radiation",
        modes: model.n_modes(),
        surface_vertices: model.n_vertices(),
        solve_s,
        transfer_fit_s: fit_s,
        transfer_bytes: info.bytes,
        sources: info.sources,
        grid_points: info.grid_points,
        worst_misfit: info.worst_residual,
        poorly_fitted: info.poorly_fitted,
        peak_rss_after_solve_mib: rss_solve,
        peak_rss_after_fit_mib: rss_fit,
        factor_per_mode_us: per_mode_us,
        factor_one_mode_at_a_time_us: one_by_one_us,
        bank_block256_per_mode_us: block_us,
        factor_over_block: per_mode_us / block_us,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "Spot, {} modes, {} vertices: solve {:.2} s; transfer fit {:.2} s ({} sources, {} grid frequencies, {:.1} MB of coefficients, worst misfit {:.2}, {} modes above 0.9); peak RSS {:.0} MiB after the solve, {:.0} MiB after the fit",
            v.modes, v.surface_vertices, solve_s, fit_s, v.sources, v.grid_points,
            v.transfer_bytes as f64 / 1e6, v.worst_misfit, v.poorly_fitted,
            rss_solve.unwrap_or(f64::NAN), rss_fit.unwrap_or(f64::NAN)
        );
        println!(
            "run time: {per_mode_us:.3} µs per mode per listener position (all modes at once; {one_by_one_us:.2} µs one mode at a time) = {:.2}× the bank's cost of rendering that mode for one 256-sample block ({block_us:.3} µs)",
            v.factor_over_block
        );
    }
    Ok(())
}
