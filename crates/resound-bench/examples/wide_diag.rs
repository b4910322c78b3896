//! Lists the modes the wide protocol misses (diagnostics; `cargo run --release --example wide_diag -p resound-bench -- SNR N`).
use rand::rngs::SmallRng;
use rand::SeedableRng;
use resound_bench::analysis::{match_modes, wide_case, WIDE_FS};
use resound_signal::{analyze, AnalyzeParams};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let snr: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100.0);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let mut rng = SmallRng::seed_from_u64(3);
    for c in 0..n {
        let case = wide_case(&mut rng, snr);
        if std::env::var("POLES").ok().and_then(|v| v.parse::<usize>().ok()) == Some(c) { poles_of(&case); }
        let a = analyze(&case.signal, WIDE_FS, &AnalyzeParams::default()).unwrap();
        let m = match_modes(&case.modes, &a.modes, None);
        let lv = |m: &resound_core::DampedMode| resound_signal::mode_level(m, 0.25);
        let strongest = case.modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
        let sl = case.modes.iter().map(lv).fold(0.0, f64::max);
        println!("case {c}: {} true, {} found, onset err {:.2} ms", case.modes.len(), a.modes.len(), 1e3 * (a.onset_s - case.onset as f64 / WIDE_FS));
        for (i, t) in case.modes.iter().enumerate() {
            println!("  {} f {:9.2} d {:8.2} a {:6.1} dB L {:6.1} {}", if m[i].is_some() { " " } else { "X" }, t.freq_hz, t.damping_per_s, 20.0 * (t.amplitude / strongest).log10(), 20.0 * (lv(t) / sl).log10(),
                m[i].map(|j| format!("-> {:9.2} {:8.2}", a.modes[j].freq_hz, a.modes[j].damping_per_s)).unwrap_or_default());
        }
        for (j, f) in a.modes.iter().enumerate() {
            if !m.contains(&Some(j)) {
                println!("  spurious f {:9.2} d {:8.2} a {:6.1} dB", f.freq_hz, f.damping_per_s, 20.0 * (f.amplitude / strongest).log10());
            }
        }
    }
}

#[allow(dead_code)]
pub fn poles_of(case: &resound_bench::analysis::WideCase) {
    let seg: Vec<f64> = case.signal[case.onset..].iter().map(|v| v - case.signal[0]).collect();
    let p = resound_signal::subspace::find_poles(&seg, WIDE_FS, case.sigma.max(1e-9), &Default::default(), (1e-3, 1500.0), 15.0);
    for q in p {
        println!("    pole f {:9.2} d {:8.2} T {:.3} s {:.1}", q.freq_hz, q.damping_per_s, q.window_s, q.strength);
    }
}
