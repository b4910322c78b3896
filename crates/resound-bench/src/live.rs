//! `resound bench live`: the live backend driven by the simulated clock (no device), one core.
//!
//! Each body has 40 modes (200 Hz–12 kHz, metal-like damping); every body is struck every
//! 50 ms (staggered), and a quarter of them also roll or slide (a rub event every block). The
//! frontend's work (sending events) is not timed: on a device it runs on the physics thread.

use resound_synth::bank::BankMode;
use resound_synth::live::{channel, ClockReport, Event, SimulatedClock};
use resound_synth::{Engine, EngineParams};
use serde::Serialize;

/// One run of the live benchmark.
#[derive(Clone, Debug, Serialize)]
pub struct LiveRun {
    /// Sounding bodies.
    pub bodies: usize,
    /// Seconds of audio rendered.
    pub seconds: f64,
    /// Callback times against the deadline.
    pub clock: ClockReport,
    /// Events applied and dropped.
    pub events: u64,
    /// Events the queue had no room for.
    pub dropped_events: u64,
}

fn body_modes(k: usize) -> Vec<BankMode> {
    (0..40)
        .map(|j| {
            let f = 200.0 * 60f64.powf(j as f64 / 39.0) * (1.0 + 0.013 * (k % 7) as f64);
            BankMode {
                freq_hz: f,
                damping_per_s: 0.5 * (6.3 + 2.1e-8 * (std::f64::consts::TAU * f).powi(2)),
                gain: 0.02 / (1.0 + j as f64).sqrt() * if j % 2 == 0 { 1.0 } else { -1.0 },
            }
        })
        .collect()
}

/// Renders `seconds` with `bodies` sounding bodies at `block` samples per callback, 48 kHz.
///
/// # Errors
/// The engine cannot be built (too many bodies).
pub fn live_run(bodies: usize, seconds: f64, block: usize) -> Result<LiveRun, String> {
    let fs = 48_000.0;
    let mut engine = Engine::new(EngineParams {
        sample_rate_hz: fs,
        voices: bodies.max(1),
        modes_per_voice: 40,
        force_capacity: 8192,
        max_block: block.max(1),
        ..EngineParams::default()
    })
    .map_err(|e| e.to_string())?;
    let voices: Vec<_> = (0..bodies)
        .map(|k| engine.attach(&body_modes(k), k))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    // Every body's impact and (for a quarter) rub in one block: room for all of them.
    let (mut front, mut back) = channel(engine, 4 * bodies.max(1) + 16);
    let clock = SimulatedClock {
        block,
        sample_rate_hz: fs,
    };
    let blocks = (seconds * fs / block as f64).ceil() as usize;
    let period = (0.05 * fs) as usize;
    let report = clock.run(
        &mut back,
        blocks,
        &mut |k| {
            let start = k * block;
            for (b, &voice) in voices.iter().enumerate() {
                // Body b is struck at b·period/bodies + n·period.
                let phase = b * period / bodies.max(1);
                let next = if start <= phase {
                    phase
                } else {
                    phase + (start - phase).div_ceil(period) * period
                };
                if next < start + block {
                    front.send(Event::Impact {
                        voice,
                        impulse_n_s: 0.01,
                        contact_s: 3e-4,
                        delay: (next - start) as u32,
                    });
                }
                if b % 4 == 0 {
                    front.send(Event::Rub {
                        voice,
                        force_rms_n: 0.2,
                        samples: block as u32,
                        delay: 0,
                    });
                }
            }
        },
        &mut |_, _| {},
    );
    let (_, events, dropped, _, _) = back.stats().snapshot();
    Ok(LiveRun {
        bodies,
        seconds,
        clock: report,
        events,
        dropped_events: dropped,
    })
}
