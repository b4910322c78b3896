//! `bench live`: the live backend on a simulated clock.

use super::*;

/// Runs `bench live` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_live(a: LiveBenchArgs) -> Result<()> {
    use crate::live::live_run;
    if a.block == 0 || a.block > 8192 || a.bodies == 0 || !(a.seconds > 0.0 && a.seconds <= 3600.0)
    {
        bail!("--block must be 1–8192, --bodies ≥ 1, --seconds in (0, 3600]");
    }
    // The backend runs on the calling thread: one core, as an audio thread has.
    let main = live_run(a.bodies, a.seconds, a.block).map_err(anyhow::Error::msg)?;
    let mut search = Vec::new();
    let mut n = a.bodies;
    let mut first_miss = None;
    while n <= a.max_bodies {
        let r = live_run(n, 5.0, a.block).map_err(anyhow::Error::msg)?;
        let missed = r.clock.misses > 0;
        if !a.json {
            eprintln!(
                "bench live: {n} bodies: p99 {:.3}, max {:.3} of the deadline, {} misses",
                r.clock.p99_share, r.clock.max_share, r.clock.misses
            );
        }
        search.push(r);
        if missed {
            first_miss = Some(n);
            break;
        }
        n *= 2;
    }
    // Bisect between the last clean count and the first miss, to an eighth.
    if let Some(miss) = first_miss {
        let (mut lo, mut hi) = (miss / 2, miss);
        while hi - lo > (lo / 8).max(1) && lo >= a.bodies {
            let mid = (lo + hi) / 2;
            let r = live_run(mid, 5.0, a.block).map_err(anyhow::Error::msg)?;
            if !a.json {
                eprintln!(
                    "bench live: {mid} bodies: p99 {:.3}, max {:.3} of the deadline, {} misses",
                    r.clock.p99_share, r.clock.max_share, r.clock.misses
                );
            }
            if r.clock.misses > 0 {
                hi = mid;
            } else {
                lo = mid;
            }
            search.push(r);
        }
        first_miss = Some(hi);
    }
    // Overload: twice the first miss, with and without the governor.
    let overload = match first_miss {
        Some(miss) => {
            let n = 2 * miss;
            let plain = live_run(n, 5.0, a.block).map_err(anyhow::Error::msg)?;
            let governed = crate::live::live_run_with(
                n,
                5.0,
                a.block,
                Some(resound::synth::scene_audio::Governor::default()),
            )
            .map_err(anyhow::Error::msg)?;
            Some((plain, governed))
        }
        None => None,
    };
    let bound = a.block + 200;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "benchmark": "live",
                "backend": "scene_audio",
                "sample_rate_hz": 48000,
                "block": a.block,
                "main": main,
                "search": search,
                "first_miss_bodies": first_miss,
                "overload": overload.as_ref().map(|(p, g)| serde_json::json!({"without_governor": p, "with_governor": g})),
                "contact_to_sound_latency_bound_samples": bound,
            }))?
        );
        return Ok(());
    }
    let c = &main.clock;
    println!(
        "{} bodies, {:.0} s at 48 kHz, {}-sample blocks ({:.2} ms deadline): callback p50 {:.3}, p99 {:.3}, max {:.3} of the deadline; {} misses; {} excitations, {} dropped, {} late steps",
        main.bodies, main.seconds, a.block, 1e3 * c.deadline_s, c.p50_share, c.p99_share, c.max_share, c.misses, main.events, main.dropped_events, main.late_steps
    );
    match first_miss {
        Some(n) => println!(
            "first deadline miss at {n} bodies (doubling from {}, then bisecting to an eighth)",
            a.bodies
        ),
        None if search.is_empty() => println!(
            "no search for the first miss: --max-bodies {} is below --bodies {}",
            a.max_bodies, a.bodies
        ),
        None => println!(
            "no deadline miss up to {} bodies",
            search.last().map_or(a.bodies, |r| r.bodies)
        ),
    }
    if let Some((p, g)) = &overload {
        println!(
            "overload ({} bodies, 5 s): without the governor {} misses (p99 {:.2}); with it {} misses (p99 {:.2}), level {}, {} voices stolen",
            p.bodies, p.clock.misses, p.clock.p99_share, g.clock.misses, g.clock.p99_share, g.degradation, g.steals
        );
    }
    match main.measured_latency_samples {
        Some(l) => println!(
            "contact-to-sound latency: {l} samples ({:.2} ms) measured on the output (bound: one block + one physics step = {bound} samples), plus the device's buffering",
            1e3 * l as f64 / 48_000.0
        ),
        None => println!("contact-to-sound latency: no sound to measure it on"),
    }
    Ok(())
}
