//! The live backend: events through the queue sound where they were scheduled, exactly as the
//! engine driven directly; the callback never allocates; overload and stale voices are counted.
#![allow(clippy::unwrap_used)]

use assert_no_alloc::assert_no_alloc;
use resound_synth::bank::BankMode;
use resound_synth::live::{channel, Event, SimulatedClock};
use resound_synth::{Engine, EngineParams};
use std::sync::atomic::Ordering;

#[cfg(debug_assertions)]
#[global_allocator]
static A: assert_no_alloc::AllocDisabler = assert_no_alloc::AllocDisabler;

fn modes() -> Vec<BankMode> {
    [(440.0, 3.0, 0.3), (1210.0, 8.0, -0.2), (2630.0, 20.0, 0.1)]
        .iter()
        .map(|&(freq_hz, damping_per_s, gain)| BankMode {
            freq_hz,
            damping_per_s,
            gain,
        })
        .collect()
}

fn engine() -> Engine {
    Engine::new(EngineParams {
        voices: 4,
        modes_per_voice: 8,
        force_capacity: 8192,
        ..EngineParams::default()
    })
    .unwrap()
}

#[test]
fn an_impact_sounds_from_its_scheduled_sample_exactly_as_the_engine_driven_directly() {
    let mut e = engine();
    let voice = e.attach(&modes(), 0).unwrap();
    let (mut front, mut back) = channel(e, 16);
    assert!(front.send(Event::Impact {
        voice,
        impulse_n_s: 0.01,
        contact_s: 0.0005,
        delay: 100,
    }));
    let mut live = vec![0.0f32; 2048];
    for block in live.chunks_mut(256) {
        back.process(block);
    }
    // The resonators answer a force one sample later (their state update).
    let first = live.iter().position(|v| *v != 0.0).unwrap();
    assert_eq!(
        first, 101,
        "sound starts one sample after the scheduled force"
    );
    // The same pulse scheduled on an engine directly (the offline path).
    let mut direct = engine();
    let v2 = direct.attach(&modes(), 0).unwrap();
    let n = (0.0005f64 * 48_000.0).round() as usize;
    let sine = |i: usize| (std::f64::consts::PI * (i as f64 + 0.5) / n as f64).sin();
    let shape: Vec<f32> = (0..n).map(|i| sine(i) as f32).collect();
    let sum: f64 = (0..n).map(sine).sum();
    direct.excite_scaled(v2, &shape, f64::from(0.01f32) * 48_000.0 / sum, 100);
    let mut offline = vec![0.0f32; 2048];
    for block in offline.chunks_mut(256) {
        direct.process(block);
    }
    assert!(live == offline, "the live path differs from the direct one");
    let (callbacks, events, dropped, rejected, _) = back.stats().snapshot();
    assert_eq!((callbacks, events, dropped, rejected), (8, 1, 0, 0));
    // The impulse is carried: a short pulse of 0.01 N·s gives each mode about gain × 0.01.
    let peak = live.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(peak > 2e-3 && peak < 7e-3, "peak {peak}");
}

#[test]
fn the_callback_never_allocates_and_overload_is_counted() {
    let mut e = engine();
    let a = e.attach(&modes(), 0).unwrap();
    let b = e.attach(&modes(), 1).unwrap();
    let (mut front, mut back) = channel(e, 4);
    let mut out = vec![0.0f32; 512];
    for k in 0..6u32 {
        front.send(Event::Impact {
            voice: a,
            impulse_n_s: 0.01,
            contact_s: 0.001,
            delay: 10 * k,
        });
        front.send(Event::Rub {
            voice: b,
            force_rms_n: 0.5,
            samples: 512,
            delay: 0,
        });
        assert_no_alloc(|| back.process(&mut out));
    }
    let (callbacks, events, dropped, rejected, _) = back.stats().snapshot();
    assert_eq!(callbacks, 6);
    assert_eq!(events, 12);
    assert_eq!((dropped, rejected), (0, 0));
    assert!(out.iter().any(|v| *v != 0.0));
    // More events than the queue holds: the rest are dropped and counted, never blocking.
    for _ in 0..10 {
        front.send(Event::Rub {
            voice: b,
            force_rms_n: 0.5,
            samples: 64,
            delay: 0,
        });
    }
    assert_eq!(front.stats().dropped_events.load(Ordering::Relaxed), 6);
    assert_no_alloc(|| back.process(&mut out));
    // A pulse that does not fit the force ring is rejected, not truncated silently.
    front.send(Event::Rub {
        voice: a,
        force_rms_n: 0.5,
        samples: 4096,
        delay: 8000,
    });
    assert_no_alloc(|| back.process(&mut out));
    let (_, events, _, rejected, _) = back.stats().snapshot();
    assert_eq!((events, rejected), (16, 1));
}

#[test]
fn the_simulated_clock_times_every_callback_and_sound_follows_the_events() {
    let mut e = engine();
    let voice = e.attach(&modes(), 0).unwrap();
    let (mut front, mut back) = channel(e, 64);
    let clock = SimulatedClock {
        block: 256,
        sample_rate_hz: 48_000.0,
    };
    let mut heard = vec![0.0f32; 0];
    let report = clock.run(
        &mut back,
        40,
        &mut |k| {
            if k == 10 {
                front.send(Event::Impact {
                    voice,
                    impulse_n_s: 0.02,
                    contact_s: 0.0003,
                    delay: 0,
                });
            }
        },
        &mut |_, block| heard.extend_from_slice(block),
    );
    assert_eq!(report.callbacks, 40);
    assert!((report.deadline_s - 256.0 / 48_000.0).abs() < 1e-12);
    assert!(report.p50_share > 0.0 && report.p50_share <= report.p99_share);
    assert!(report.p99_share <= report.max_share && report.max_share.is_finite());
    assert!(report.misses <= 40);
    assert_eq!(heard.len(), 40 * 256);
    // Silent before the impact's block, sounding from its first sample on.
    assert!(heard[..10 * 256].iter().all(|v| *v == 0.0));
    assert!(heard[10 * 256 + 1] != 0.0);
}

/// Mono, listener at the origin, one spare source 1 m away with `capacity` silent modes.
fn spare_scene(
    capacity: usize,
) -> (
    resound_synth::scene_audio::CueSender,
    resound_synth::scene_audio::SceneAudio,
) {
    use resound_synth::scene_audio::{scene_audio, SceneAudioParams, Source};
    let params = SceneAudioParams {
        sample_rate_hz: 48_000.0,
        stereo: false,
        listener: [0.0; 3],
        max_delay_s: 0.1,
        max_block: 512,
        force_capacity: 4096,
        cull_level: 1e-9,
        cue_capacity: 64,
        sample_capacity: 4096,
        governor: None,
        air: None,
        reflection: None,
        ambisonics: false,
    };
    let spare = Source {
        modes: vec![(1000.0, 1000.0); capacity],
        gains: vec![0.0; capacity],
        grains: None,
        position: [1.0, 0.0, 0.0],
        radiation: Vec::new(),
    };
    scene_audio(&params, vec![spare]).unwrap()
}

/// Zero crossings per second of `x` over its second half (a pure tone: twice its frequency).
fn crossings_hz(x: &[f32], fs: f64) -> f64 {
    let h = &x[x.len() / 2..];
    let n = h
        .windows(2)
        .filter(|w| (w[0] < 0.0) != (w[1] < 0.0))
        .count();
    0.5 * n as f64 * fs / h.len() as f64
}

#[test]
fn a_spare_source_takes_new_modes_and_the_listener_moves_without_allocating() {
    use resound_synth::scene_audio::Cue;
    let fs = 48_000.0;
    let (mut tx, mut audio) = spare_scene(4);
    // Before any Sound cue, a force on the spare source is silent (its gains are zero).
    tx.step(0);
    tx.force(0, 0, &[1.0], 1.0, 0);
    let mut quiet = vec![0.0f32; 4800];
    assert_no_alloc(|| audio.process(&mut [&mut quiet]));
    assert!(quiet.iter().all(|v| *v == 0.0));
    // One 700 Hz mode, then a strike.
    tx.step(4800);
    assert!(tx.sound(0, &[(700.0, 2.0)], &[0.5]));
    tx.force(0, 0, &[1.0], 1.0, 0);
    let mut near = vec![0.0f32; 9600];
    assert_no_alloc(|| audio.process(&mut [&mut near]));
    let f = crossings_hz(&near, fs);
    assert!((f - 700.0).abs() < 5.0, "{f} Hz");
    // The same strike heard from 3 m instead of 1 m: a third of the level (1/r).
    let (mut tx2, mut audio2) = spare_scene(4);
    tx2.step(0);
    assert!(tx2.send(Cue::Listener {
        position: [-2.0, 0.0, 0.0]
    }));
    assert!(tx2.sound(0, &[(700.0, 2.0)], &[0.5]));
    tx2.force(0, 0, &[1.0], 1.0, 0);
    let mut far = vec![0.0f32; 9600];
    assert_no_alloc(|| audio2.process(&mut [&mut far]));
    let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let ratio = peak(&near) / peak(&far);
    assert!((ratio - 3.0).abs() < 0.05, "near/far {ratio}");
    // More modes than the source was built with are refused, and it keeps sounding as before.
    tx.step(14_400);
    assert!(tx.sound(0, &[(500.0, 1.0); 5], &[0.1; 5]));
    let mut rest = vec![0.0f32; 480];
    audio.process(&mut [&mut rest]);
    assert!(audio.stats().rejected.load(Ordering::Relaxed) >= 1);
    // Zero modes silence it: a later strike adds nothing.
    tx.step(14_880);
    assert!(tx.sound(0, &[], &[]));
    tx.force(0, 0, &[1.0], 1.0, 0);
    let mut after = vec![0.0f32; 4800];
    audio.process(&mut [&mut after]);
    assert!(
        peak(&after[2400..]) < 1e-3 * peak(&near),
        "{}",
        peak(&after[2400..])
    );
}
