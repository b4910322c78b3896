//! Lists, case by case, the modes the wide analysis protocol misses and the spurious ones it
//! reports, with each found mode's error over its CRB (a diagnostic beside `resound bench analyze`;
//! `R` marks the modes its recall counts):
//! `cargo run --release -p resound-bench --example wide_diag -- SNR_DB CASES`.
use rand::rngs::SmallRng;
use rand::SeedableRng;
use resound_bench::analysis::{match_modes, wide_case, WIDE_FS};
use resound_core::DampedMode;
use resound_signal::crb::cramer_rao;
use resound_signal::{analyze, mode_level, AnalyzeParams, LEVEL_WINDOW_S};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let snr: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100.0);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let mut rng = SmallRng::seed_from_u64(3);
    let level = |m: &DampedMode| mode_level(m, LEVEL_WINDOW_S);
    let only: Option<usize> = args.get(3).and_then(|s| s.parse().ok());
    for c in 0..n {
        let case = wide_case(&mut rng, snr);
        if only.is_some_and(|o| o != c) {
            continue;
        }
        let a = match analyze(&case.signal, WIDE_FS, &AnalyzeParams::default()) {
            Ok(a) => a,
            Err(e) => {
                println!("case {c}: {e}");
                continue;
            }
        };
        let n_strike = case.signal.len() - case.onset;
        let bounds = cramer_rao(&case.modes, WIDE_FS, n_strike, case.sigma.max(1e-12));
        let m = match_modes(&case.modes, &a.modes, bounds.as_deref());
        let top = case.modes.iter().map(level).fold(0.0, f64::max);
        // The benchmark's reference modes: within 60 dB of the strongest and Σ s² ≥ 100 σ².
        let reference = |t: &DampedMode| {
            let energy = t.amplitude
                * t.amplitude
                * WIDE_FS
                * (-(-2.0 * t.damping_per_s * n_strike as f64 / WIDE_FS).exp_m1())
                / (4.0 * t.damping_per_s);
            level(t) >= top * 1e-3 && energy >= 100.0 * case.sigma * case.sigma
        };
        println!(
            "case {c}: {} true, {} found, onset error {:.2} ms, high-pass {}",
            case.modes.len(),
            a.modes.len(),
            1e3 * (a.onset_s - case.onset as f64 / WIDE_FS),
            a.conditioning.highpass_reason
        );
        for (i, t) in case.modes.iter().enumerate() {
            let found = m[i].map_or(String::new(), |j| {
                let (ef, ed) = bounds.as_ref().map_or((f64::NAN, f64::NAN), |b| {
                    (
                        (a.modes[j].freq_hz - t.freq_hz).abs() / b[i].freq_hz,
                        (a.modes[j].damping_per_s - t.damping_per_s).abs() / b[i].damping_per_s,
                    )
                });
                format!(
                    "-> {:9.2} {:8.2}  f/CRB {ef:7.1} d/CRB {ed:7.1}",
                    a.modes[j].freq_hz, a.modes[j].damping_per_s
                )
            });
            println!(
                "  {}{} f {:9.2} d {:8.2} level {:6.1} dB {found}",
                if m[i].is_some() { " " } else { "X" },
                if reference(t) { "R" } else { " " },
                t.freq_hz,
                t.damping_per_s,
                20.0 * (level(t) / top).log10()
            );
        }
        for (j, f) in a.modes.iter().enumerate() {
            if !m.contains(&Some(j)) {
                let energy = f.amplitude
                    * f.amplitude
                    * WIDE_FS
                    * (-(-2.0 * f.damping_per_s * n_strike as f64 / WIDE_FS).exp_m1())
                    / (4.0 * f.damping_per_s);
                println!(
                    "  spurious f {:9.2} d {:8.2} level {:6.1} dB energy {:7.1} σ²",
                    f.freq_hz,
                    f.damping_per_s,
                    20.0 * (level(f) / top).log10(),
                    energy / (case.sigma * case.sigma)
                );
            }
        }
    }
}
