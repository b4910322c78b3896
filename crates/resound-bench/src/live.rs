//! `resound bench live`: the scenes' audio side (`resound_synth::scene_audio::SceneAudio`, the
//! backend `resound scene --live` runs in its device callback) driven by a simulated device,
//! one core.
//!
//! Each body has 40 modes (200 Hz–12 kHz, metal-like damping) and sits on a circle 2 m around
//! the listener (stereo, spatialized). A stand-in physics frontend runs 240 steps per second,
//! one block ahead of the audio clock, and sends each step's cues one step late (the live
//! scheduling): every body is struck every 50 ms (a 0.3 ms half-sine, staggered), and a
//! quarter of them roll or slide (a step of noise force every step). The frontend's work is not
//! timed: on a device it runs on the physics thread. The callback is.

pub use resound_synth::live::ClockReport;
use resound_synth::scene_audio::{scene_audio, AudioStats, Governor, SceneAudioParams, Source};
use serde::Serialize;
use std::time::Instant;

/// One run of the live benchmark.
#[derive(Clone, Debug, Serialize)]
pub struct LiveRun {
    /// Sounding bodies.
    pub bodies: usize,
    /// Seconds of audio rendered.
    pub seconds: f64,
    /// Callback times against the deadline.
    pub clock: ClockReport,
    /// Excitations applied (impacts and rubs).
    pub events: u64,
    /// Cues the queues had no room for.
    pub dropped_events: u64,
    /// Steps whose cues came after their start.
    pub late_steps: u64,
    /// Voices faded out by the governor.
    pub steals: u64,
    /// Highest degradation level the governor reached.
    pub degradation: u64,
    /// The first impact's sound onset after its contact instant, less the propagation delay,
    /// samples (the scheduled latency is one physics step, 200 samples, and a resonator's output
    /// follows its force by one sample).
    pub measured_latency_samples: Option<usize>,
}

fn body_modes(k: usize) -> Vec<(f64, f64)> {
    (0..40)
        .map(|j| {
            let f = 200.0 * 60f64.powf(j as f64 / 39.0) * (1.0 + 0.013 * (k % 7) as f64);
            (
                f,
                0.5 * (6.3 + 2.1e-8 * (std::f64::consts::TAU * f).powi(2)),
            )
        })
        .collect()
}

/// Renders `seconds` with `bodies` sounding bodies at `block` samples per callback, 48 kHz.
///
/// # Errors
/// The audio side cannot be built (too many bodies).
pub fn live_run(bodies: usize, seconds: f64, block: usize) -> Result<LiveRun, String> {
    live_run_with(bodies, seconds, block, None)
}

/// [`live_run`] with the callback's overload `governor` (culling, then voice stealing).
///
/// # Errors
/// The audio side cannot be built (too many bodies).
pub fn live_run_with(
    bodies: usize,
    seconds: f64,
    block: usize,
    governor: Option<Governor>,
) -> Result<LiveRun, String> {
    let fs = 48_000.0;
    let step = 200usize;
    let radius = 2.0;
    let sources = (0..bodies)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / bodies.max(1) as f64;
            Source {
                modes: body_modes(k),
                gains: (0..40)
                    .map(|j| 0.02 / (1.0 + j as f32).sqrt() * if j % 2 == 0 { 1.0 } else { -1.0 })
                    .collect(),
                grains: None,
                position: [radius * a.cos(), 0.0, radius * a.sin()],
                radiation: Vec::new(),
            }
        })
        .collect();
    let ahead = (block + step).div_ceil(step) + 2;
    let params = SceneAudioParams {
        sample_rate_hz: fs,
        stereo: true,
        listener: [0.0; 3],
        max_delay_s: 0.1,
        max_block: block.max(step),
        force_capacity: 8192,
        cull_level: 1e-7,
        cue_capacity: (ahead * (2 * bodies + 4)).next_power_of_two(),
        sample_capacity: ahead * (bodies * 16 + bodies.div_ceil(4) * step) + 1024,
        governor,
        air: Some(resound_synth::air::Air::default()),
        reflection: None,
        ambisonics: false,
    };
    let (mut tx, mut audio) = scene_audio(&params, sources).map_err(|e| e.to_string())?;
    let pulse: Vec<f32> = {
        let n = (3e-4 * fs).round() as usize;
        let raw: Vec<f64> = (0..n)
            .map(|i| (std::f64::consts::PI * (i as f64 + 0.5) / n as f64).sin())
            .collect();
        let sum: f64 = raw.iter().sum();
        // 0.01 N·s: force samples in newtons (the resonators integrate over 1/fs).
        raw.iter().map(|&v| (0.01 * fs * v / sum) as f32).collect()
    };
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut noise = vec![0.0f32; step];
    let period = (0.05 * fs) as usize;
    let blocks = (seconds * fs / block as f64).ceil() as usize;
    let total_steps = (blocks * block).div_ceil(step);
    let mut next_step = 0usize;
    let mut out = [vec![0.0f32; block], vec![0.0f32; block]];
    let mut times = Vec::with_capacity(blocks);
    let mut onset = None;
    let mut max_degradation = 0;
    let first_contact = 0usize; // body 0 is struck at sample 0
    for k in 0..blocks {
        // The physics runs until its next step would end past the block after this one.
        while next_step < total_steps && (next_step + 1) * step <= (k + 1) * block {
            let s0 = next_step * step;
            tx.step((s0 + step) as u64);
            for b in 0..bodies {
                let phase = b * period / bodies.max(1);
                let next = if s0 <= phase {
                    phase
                } else {
                    phase + (s0 - phase).div_ceil(period) * period
                };
                if next < s0 + step {
                    tx.force(b, 0, &pulse, 1.0, next - s0);
                }
                if b % 4 == 0 {
                    for v in &mut noise {
                        rng ^= rng << 13;
                        rng ^= rng >> 7;
                        rng ^= rng << 17;
                        *v = ((rng >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 12f32.sqrt();
                    }
                    tx.force(b, 0, &noise, 0.2, 0);
                }
            }
            next_step += 1;
        }
        let [l, r] = &mut out;
        l.fill(0.0);
        r.fill(0.0);
        let t0 = Instant::now();
        audio.process(&mut [&mut l[..], &mut r[..]]);
        times.push(t0.elapsed().as_secs_f64() * fs / block as f64);
        max_degradation = max_degradation.max(AudioStats::get(&audio.stats().degradation));
        if onset.is_none() {
            if let Some(i) = l
                .iter()
                .zip(r.iter())
                .position(|(a, b)| *a != 0.0 || *b != 0.0)
            {
                onset = Some(k * block + i);
            }
        }
    }
    let propagation = (radius / resound_synth::spatial::SPEED_OF_SOUND_M_S * fs).round() as usize;
    let s = audio.stats();
    Ok(LiveRun {
        bodies,
        seconds,
        clock: ClockReport::from_shares(&times, block, fs),
        events: AudioStats::get(&s.cues),
        dropped_events: AudioStats::get(&s.dropped),
        late_steps: AudioStats::get(&s.late_steps),
        steals: AudioStats::get(&s.steals),
        degradation: max_degradation,
        measured_latency_samples: onset.map(|o| o.saturating_sub(first_contact + propagation)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_impact_sounds_one_physics_step_after_its_contact() {
        let r = live_run(4, 0.3, 256).unwrap();
        // One physics step, plus the sample by which a resonator's output follows its force.
        assert_eq!(r.measured_latency_samples, Some(201));
        assert_eq!(r.late_steps, 0);
        assert_eq!(r.dropped_events, 0);
    }
}
