//! Lists, case by case, the modes the wide analysis protocol misses and the spurious ones it
//! reports (a diagnostic beside `resound bench analyze`):
//! `cargo run --release -p resound-bench --example wide_diag -- SNR_DB CASES`.
use rand::rngs::SmallRng;
use rand::SeedableRng;
use resound_bench::analysis::{match_modes, wide_case, WIDE_FS};
use resound_core::DampedMode;
use resound_signal::{analyze, mode_level, AnalyzeParams, LEVEL_WINDOW_S};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let snr: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100.0);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let mut rng = SmallRng::seed_from_u64(3);
    let level = |m: &DampedMode| mode_level(m, LEVEL_WINDOW_S);
    for c in 0..n {
        let case = wide_case(&mut rng, snr);
        let a = match analyze(&case.signal, WIDE_FS, &AnalyzeParams::default()) {
            Ok(a) => a,
            Err(e) => {
                println!("case {c}: {e}");
                continue;
            }
        };
        let m = match_modes(&case.modes, &a.modes, None);
        let top = case.modes.iter().map(level).fold(0.0, f64::max);
        println!(
            "case {c}: {} true, {} found, onset error {:.2} ms",
            case.modes.len(),
            a.modes.len(),
            1e3 * (a.onset_s - case.onset as f64 / WIDE_FS)
        );
        for (i, t) in case.modes.iter().enumerate() {
            let found = m[i].map_or(String::new(), |j| {
                format!(
                    "-> {:9.2} {:8.2}",
                    a.modes[j].freq_hz, a.modes[j].damping_per_s
                )
            });
            println!(
                "  {} f {:9.2} d {:8.2} level {:6.1} dB {found}",
                if m[i].is_some() { " " } else { "X" },
                t.freq_hz,
                t.damping_per_s,
                20.0 * (level(t) / top).log10()
            );
        }
        for (j, f) in a.modes.iter().enumerate() {
            if !m.contains(&Some(j)) {
                println!(
                    "  spurious f {:9.2} d {:8.2} level {:6.1} dB",
                    f.freq_hz,
                    f.damping_per_s,
                    20.0 * (level(f) / top).log10()
                );
            }
        }
    }
}
