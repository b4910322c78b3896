//! Live scenes: the live path (physics on its own thread, cues through the queues, device
//! blocks of another length) plays what the offline renderer writes, delayed by the latency;
//! the audio callback never allocates; overload degrades instead of failing.
#![allow(clippy::unwrap_used)]

use assert_no_alloc::assert_no_alloc;
use resound_physics::live::{live_scene, render_live, LiveParams, Pacing};
use resound_physics::{simulate, BodySound, BodySpec, SceneParams, Shape};
use resound_synth::excitation::Elastic;
use resound_synth::scene_audio::{AudioStats, Governor};

#[cfg(debug_assertions)]
#[global_allocator]
static A: assert_no_alloc::AllocDisabler = assert_no_alloc::AllocDisabler;

fn sound(radius: f64, f0: f64) -> BodySound {
    let mut vertices = Vec::new();
    for i in 0..6 {
        for j in 0..12 {
            let th = std::f64::consts::PI * (i as f64 + 0.5) / 6.0;
            let ph = std::f64::consts::TAU * j as f64 / 12.0;
            vertices.push([
                radius * th.sin() * ph.cos(),
                radius * th.cos(),
                radius * th.sin() * ph.sin(),
            ]);
        }
    }
    let modes = vec![(f0, 15.0), (2.6 * f0, 25.0), (5.4 * f0, 40.0)];
    // Gains that change over the surface: the contact point matters.
    let gains = vertices
        .iter()
        .flat_map(|v| {
            let y = (v[1] / radius) as f32;
            [0.02 * (1.0 + y), 0.01 * (1.0 - y), 0.015]
        })
        .collect();
    BodySound {
        modes,
        vertices,
        gains,
        elastic: Elastic {
            youngs_modulus: 70e9,
            poisson_ratio: 0.25,
        },
        contact_loss: resound_physics::DEFAULT_CONTACT_LOSS,
        radiation: None,
    }
}

fn floor() -> BodySpec {
    BodySpec {
        name: "floor".into(),
        shape: Shape::Cuboid([2.0, 0.05, 2.0]),
        fixed: true,
        density: 700.0,
        position: [0.0, -0.05, 0.0],
        rotation: [0.0; 3],
        linvel: [0.0; 3],
        angvel: [0.0; 3],
        restitution: 0.5,
        friction: 0.4,
        sound: Some(sound(1.0, 300.0)),
        surface: None,
        grains: None,
    }
}

/// A floor, two dropped balls (one thrown sideways: it bounces, then rolls) and a sliding box.
fn scene() -> Vec<BodySpec> {
    let ball = |name: &str, x: f64, vx: f64, f0: f64| BodySpec {
        name: name.into(),
        shape: Shape::Ball(0.03),
        fixed: false,
        density: 7800.0,
        position: [x, 0.4, 0.0],
        linvel: [vx, 0.0, 0.0],
        sound: Some(sound(0.03, f0)),
        ..floor()
    };
    let slider = BodySpec {
        name: "box".into(),
        shape: Shape::Cuboid([0.04, 0.02, 0.04]),
        position: [0.3, 0.021, 0.2],
        linvel: [-1.5, 0.0, 0.0],
        fixed: false,
        density: 2000.0,
        sound: Some(sound(0.04, 1300.0)),
        ..floor()
    };
    vec![
        floor(),
        ball("a", -0.2, 0.0, 900.0),
        ball("b", 0.1, 0.8, 1700.0),
        slider,
    ]
}

fn params() -> SceneParams {
    SceneParams {
        duration_s: 1.2,
        listener: [0.0, 0.3, 0.5],
        ..SceneParams::default()
    }
}

#[test]
fn the_live_path_plays_the_offline_output_delayed_by_its_latency() {
    let bodies = scene();
    let offline = simulate(&bodies, &params(), &|_| {}).unwrap();
    let live = render_live(
        &bodies,
        &params(),
        &LiveParams {
            block: 256,
            latency_samples: None,
            governor: None,
            pacing: Pacing::Lockstep,
        },
    )
    .unwrap();
    let l = live.report.latency_samples;
    // One physics step at 240 steps/s and 48 kHz.
    assert_eq!(l, 200);
    assert_eq!(live.report.late_steps, 0);
    assert_eq!(live.report.dropped_cues, 0);
    assert_eq!(live.events, offline.events);
    assert!(offline.stats.impacts >= 3 && offline.stats.sliding_steps > 0);
    for (a, b) in offline.channels.iter().zip(&live.channels) {
        assert_eq!(b.len(), a.len() + l);
        let peak = a.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(peak > 1e-3, "the scene sounds: peak {peak}");
        // Nothing before the latency.
        assert!(b[..l].iter().all(|&v| v == 0.0));
        let diff = a
            .iter()
            .zip(&b[l..])
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        // Blocks of 256 against steps of 200: only the culling of decayed modes at other
        // block ends differs (modes below 1e-7 of output amplitude).
        assert!(
            diff <= 1e-5 * peak,
            "largest difference {diff} of peak {peak}"
        );
    }
}

#[test]
fn the_scene_callback_never_allocates() {
    let bodies = scene();
    let live = LiveParams {
        block: 128,
        ..LiveParams::default()
    };
    let (mut physics, mut tx, mut driver, latency) = live_scene(&bodies, &params(), &live).unwrap();
    assert_eq!(latency, 200);
    let mut out = vec![0.0f32; 128 * 2];
    let mut energy = 0.0f64;
    let steps = physics.steps();
    while physics.steps_done() < steps {
        // The physics (which may allocate) runs up to one block ahead, as its thread would.
        while physics.steps_done() < steps
            && physics.step_span(physics.steps_done()).1 as u64 <= tx.rendered() + 128
        {
            physics.step(&mut tx);
        }
        assert_no_alloc(|| driver.fill_interleaved(&mut out, 2));
        energy += out.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>();
    }
    assert!(energy > 0.0);
    let s = driver.stats();
    assert_eq!(AudioStats::get(&s.late_steps), 0);
    assert!(AudioStats::get(&s.cues) > 100);
}

#[test]
fn overload_culls_and_steals_instead_of_failing() {
    // A governor that finds every callback too slow: it degrades step by step to its last
    // level (cull level ×1000, then a voice budget down to one voice).
    let bodies = scene();
    let live = render_live(
        &bodies,
        &params(),
        &LiveParams {
            block: 256,
            latency_samples: None,
            governor: Some(Governor {
                high: 0.0,
                low: -1.0,
                calm_callbacks: 1,
            }),
            pacing: Pacing::Lockstep,
        },
    )
    .unwrap();
    assert_eq!(live.report.max_degradation, 8);
    assert!(live.report.steals > 0);
    let offline = simulate(&bodies, &params(), &|_| {}).unwrap();
    let l = live.report.latency_samples;
    for (a, b) in offline.channels.iter().zip(&live.channels) {
        assert!(b.iter().all(|v| v.is_finite()));
        let (ea, eb): (f64, f64) = (
            a.iter().map(|&v| f64::from(v).powi(2)).sum(),
            b[l..].iter().map(|&v| f64::from(v).powi(2)).sum(),
        );
        // Still sounding, and no louder than the full render.
        assert!(eb > 0.05 * ea && eb < 1.01 * ea, "energy {eb} vs full {ea}");
        // A stolen voice fades out over a block: no step larger than the scene's own.
        let step = |x: &[f32]| x.windows(2).fold(0.0f32, |m, w| m.max((w[1] - w[0]).abs()));
        assert!(
            step(&b[l..]) <= 1.05 * step(a),
            "{} vs {}",
            step(&b[l..]),
            step(a)
        );
    }
}
