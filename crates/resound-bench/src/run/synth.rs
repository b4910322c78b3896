//! `bench synth`: resonator-bank throughput and residual transfer.

use super::*;

/// `bench synth` figures.
#[derive(Serialize)]
struct SynthDoc {
    benchmark: &'static str,
    modes: usize,
    mode_samples_per_s: f64,
    modes_realtime_48k: f64,
    portable_modes_realtime_48k: f64,
    scalar_modes_realtime_48k: f64,
    ratio_vs_scalar: f64,
    residual_transfer_p50_ms: f64,
    residual_transfer_p99_ms: f64,
    residual_events: usize,
}

/// Runs `bench synth` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_synth(a: SynthBenchArgs) -> Result<()> {
    use crate::throughput::{
        bank_mode_samples_per_s, residual_transfer_latencies_ms, scalar_loop_mode_samples_per_s,
    };
    if a.modes == 0 || !(a.seconds > 0.0) || a.events == 0 {
        bail!("--modes, --seconds and --events must be positive");
    }
    // Best of three runs each: the machine is shared; the best run is the least disturbed.
    let best = |f: &dyn Fn() -> f64| (0..3).map(|_| f()).fold(0.0, f64::max);
    let simd = best(&|| bank_mode_samples_per_s(a.modes, a.seconds, false));
    let portable = best(&|| bank_mode_samples_per_s(a.modes, a.seconds, true));
    let scalar = best(&|| scalar_loop_mode_samples_per_s(a.modes, a.seconds));
    let lat = residual_transfer_latencies_ms(a.events, 1);
    let pct = |q: f64| lat[((lat.len() - 1) as f64 * q).round() as usize];
    let v = SynthDoc {
        benchmark: "synth",
        modes: a.modes,
        mode_samples_per_s: simd,
        modes_realtime_48k: simd / 48_000.0,
        portable_modes_realtime_48k: portable / 48_000.0,
        scalar_modes_realtime_48k: scalar / 48_000.0,
        ratio_vs_scalar: simd / scalar,
        residual_transfer_p50_ms: pct(0.5),
        residual_transfer_p99_ms: pct(0.99),
        residual_events: a.events,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "bank ({} modes): {:.3e} mode-samples/s = {:.0} modes in real time at 48 kHz (portable path {:.0}; plain scalar loop {:.0}; ratio {:.1}x)",
            a.modes,
            simd,
            simd / 48_000.0,
            portable / 48_000.0,
            scalar / 48_000.0,
            simd / scalar
        );
        println!(
            "residual transfer (1 s, 10 fast Griffin-Lim iterations, {} events): p50 {:.2} ms, p99 {:.2} ms",
            a.events,
            pct(0.5),
            pct(0.99)
        );
    }
    Ok(())
}
