//! `bench stats`: the statistical model (impacts and a scrape).

use super::*;

/// The PyImpact metal_3 table (BSD-2-Clause; see tests/fixtures/pyimpact/README.md).
const METAL_3: &str = include_str!("../../../resound-cli/tests/fixtures/pyimpact/metal_3_mm.json");

/// Runs `bench stats` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_stats(a: StatsBenchArgs) -> Result<()> {
    use resound::synth::excitation::{ContactModel, Elastic, Impact};
    use resound::synth::render::{bank_modes, render_strike, REFERENCE_IMPULSE_N_S};
    use resound::synth::scrape::{scrape, scrape_force, ScrapeParams, Surface};
    let stats = resound::stats::ModeStatistics::from_pyimpact_json("metal_3", METAL_3)?;
    let fs = 44_100.0;
    let steel = Elastic {
        youngs_modulus: 200e9,
        poisson_ratio: 0.3,
    };
    let best = |f: &dyn Fn() -> Result<f64>| -> Result<f64> {
        let mut b = f64::INFINITY;
        for _ in 0..3 {
            b = b.min(f()?);
        }
        Ok(b)
    };
    let impacts = best(&|| {
        let t0 = std::time::Instant::now();
        let ir = stats.sample(1)?;
        let mut sink = 0.0f32;
        for k in 0..100u64 {
            let modes = resound::stats::perturb(&ir, k + 2);
            let mut bm = bank_modes(&modes);
            bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
            let imp = Impact {
                impactor_mass_kg: 0.01,
                impactor_radius_m: 0.005,
                impactor: steel,
                object: steel,
                object_mass_kg: None,
                speed_m_s: 0.5 + 0.01 * k as f64,
            };
            let f = imp.force_pulse(ContactModel::Hertz, fs, 0.0)?;
            let x = render_strike(&bm, &f, fs, 44_100)?;
            sink += x[100];
        }
        std::hint::black_box(sink);
        Ok(t0.elapsed().as_secs_f64())
    })?;
    // The same 100 impacts through the library call the Python package makes
    // (`resound.render_impact` → `render_strike(Struck::Stats)`): the baseline of the Python
    // call overhead (`crates/resound-py/bench/impacts.py`).
    let library = best(&|| {
        let t0 = std::time::Instant::now();
        let mut sink = 0.0f32;
        for k in 0..100u64 {
            let p = resound::strike::StrikeParams {
                speed_m_s: 0.5 + 0.01 * k as f64,
                impactor_mass_kg: Some(0.01),
                residual: false,
                duration_s: 1.0,
                sample_rate_hz: 44_100,
                ..Default::default()
            };
            let x = resound::strike::render_strike(
                resound::strike::Struck::Stats {
                    stats: &stats,
                    seed: k,
                },
                &p,
            )?;
            sink += x.samples[100];
        }
        std::hint::black_box(sink);
        Ok(t0.elapsed().as_secs_f64())
    })?;
    let scrape10 = best(&|| {
        let t0 = std::time::Instant::now();
        let surface = Surface::fractal(1 << 20, 1e-5, 2.0, 5e-6, 1)?;
        let n = 441_000;
        let x: Vec<f64> = (0..n).map(|i| 0.3 * i as f64 / fs).collect();
        let f = scrape_force(&surface, &x, fs, &ScrapeParams::default());
        let mut bm = bank_modes(&stats.sample(1)?);
        bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
        let y = scrape(&bm, &f, &x, fs, 8, 1)?;
        std::hint::black_box(&y);
        Ok(t0.elapsed().as_secs_f64())
    })?;
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        impacts100_s: f64,
        impacts100_render_strike_s: f64,
        scrape10s_s: f64,
        impact_audio_s: f64,
        modes: usize,
    }
    let v = Doc {
        benchmark: "stats",
        impacts100_s: impacts,
        impacts100_render_strike_s: library,
        scrape10s_s: scrape10,
        impact_audio_s: 1.0,
        modes: stats.modes,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "100 impacts (sample + Hertz pulse + 1 s render each, {} modes): {:.4} s ({:.4} s through render_strike, as Python calls it); 10 s scrape (8 location IRs): {:.3} s (best of 3)",
            stats.modes, impacts, library, scrape10
        );
    }
    Ok(())
}
