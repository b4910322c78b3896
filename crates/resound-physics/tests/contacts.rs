//! Contacts of simple scenes against physics and expectations.
#![allow(clippy::unwrap_used)]

use resound_physics::{simulate, BodySound, BodySpec, ContactKind, SceneParams, Shape};
use resound_synth::excitation::Elastic;

/// A sound model without FEM: three modes, equal gains at a cloud of points on a sphere of
/// `radius` (enough for the nearest-vertex lookup).
fn sound(radius: f64) -> BodySound {
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
    let modes = vec![(900.0, 15.0), (2300.0, 25.0), (5100.0, 40.0)];
    let gains = vec![0.02f32; vertices.len() * modes.len()];
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
        restitution: 0.6,
        friction: 0.4,
        sound: Some(sound(1.0)),
        surface: None,
        grains: None,
    }
}

fn params(duration: f64) -> SceneParams {
    SceneParams {
        duration_s: duration,
        listener: [0.0, 0.3, 0.5],
        ..SceneParams::default()
    }
}

fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

#[test]
fn a_dropped_ball_bounces_on_free_fall_and_restitution_times() {
    let h = 0.5;
    let r = 0.03;
    let ball = BodySpec {
        name: "ball".into(),
        shape: Shape::Ball(r),
        fixed: false,
        density: 7800.0,
        position: [0.0, h + r, 0.0],
        sound: Some(sound(r)),
        ..floor()
    };
    let out = simulate(&[floor(), ball], &params(1.6), &|_| {}).unwrap();
    let impacts: Vec<f64> = out
        .events
        .iter()
        .filter(|e| e.kind == ContactKind::Impact)
        .map(|e| e.time_s)
        .collect();
    assert!(impacts.len() >= 3, "{:?}", out.events);
    let g = 9.81;
    let t1 = (2.0 * h / g).sqrt();
    assert!(
        (impacts[0] - t1).abs() < 2e-3,
        "first impact {} vs free fall {t1}",
        impacts[0]
    );
    // Bounce intervals: 2 e v / g with the rebound speed shrinking by e each time.
    let e = 0.6;
    let v1 = g * t1;
    let want = 2.0 * e * v1 / g;
    let first = impacts[1] - impacts[0];
    assert!(
        (first / want - 1.0).abs() < 0.08,
        "first bounce {first} vs {want}"
    );
    let ratio = (impacts[2] - impacts[1]) / first;
    eprintln!("impacts at {impacts:?}: first {:.4} s (free fall {t1:.4}), bounce {first:.4} s (want {want:.4}), ratio {ratio:.3}", impacts[0]);
    assert!(
        (ratio - e).abs() < 0.06,
        "interval ratio {ratio} vs restitution {e}"
    );
    // The impacts are heard: sound right after the first one, silence before.
    let fs = 48_000.0;
    let before = &out.channels[0][..((t1 - 0.01) * fs) as usize];
    let after = &out.channels[0][(t1 * fs) as usize + 200..((t1 + 0.05) * fs) as usize];
    assert!(
        rms(before) == 0.0 && rms(after) > 1e-4,
        "{} {}",
        rms(before),
        rms(after)
    );
}

fn slide(speed: f64) -> (Vec<f32>, resound_physics::SceneStats) {
    slide_on(speed, None)
}

fn slide_on(
    speed: f64,
    surface: Option<std::sync::Arc<resound_synth::scrape::Surface>>,
) -> (Vec<f32>, resound_physics::SceneStats) {
    let half = 0.05;
    let cube = BodySpec {
        name: "box".into(),
        shape: Shape::Cuboid([half; 3]),
        fixed: false,
        density: 500.0,
        position: [0.0, half, 0.0],
        linvel: [speed, 0.0, 0.0],
        friction: 0.2,
        sound: Some(sound(half)),
        ..floor()
    };
    let mut p = params(0.3);
    p.stereo = false;
    let floor = BodySpec { surface, ..floor() };
    let out = simulate(&[floor, cube], &p, &|_| {}).unwrap();
    (out.channels[0].clone(), out.stats)
}

#[test]
fn a_sliding_box_sounds_continuously_and_louder_when_faster() {
    let (slow, s1) = slide(1.0);
    let (fast, s2) = slide(3.0);
    assert!(
        s1.sliding_steps > 20 && s2.sliding_steps > 20,
        "{s1:?} {s2:?}"
    );
    // Continuous: every 20 ms window of the first 0.1 s has sound.
    let fs = 48_000;
    for w in fast[fs / 100..fs / 10].chunks(fs / 50) {
        assert!(rms(w) > 0.0);
    }
    let (a, b) = (rms(&slow[..fs / 10]), rms(&fast[..fs / 10]));
    eprintln!("sliding rms at 1 m/s {a:.3e}, at 3 m/s {b:.3e}; {s1:?}");
    assert!(b > 1.5 * a, "slow {a} fast {b}");
}

#[test]
fn sliding_on_a_textured_surface_scrapes_louder_when_faster() {
    let surface = std::sync::Arc::new(
        resound_synth::scrape::Surface::fractal(1 << 16, 1e-5, 2.0, 5e-6, 2).unwrap(),
    );
    let (slow, s1) = slide_on(1.0, Some(surface.clone()));
    let (fast, _) = slide_on(3.0, Some(surface));
    assert!(s1.sliding_steps > 20, "{s1:?}");
    let fs = 48_000;
    let (a, b) = (rms(&slow[..fs / 10]), rms(&fast[..fs / 10]));
    eprintln!("textured sliding rms at 1 m/s {a:.3e}, at 3 m/s {b:.3e}");
    assert!(a > 0.0 && b > 1.5 * a, "slow {a} fast {b}");
    // And it differs from the untextured sliding sound.
    let (plain, _) = slide(1.0);
    assert_ne!(plain, slow);
}

#[test]
fn a_rolling_ball_is_rolling_not_sliding_and_not_impacts() {
    let r = 0.04;
    let v = 1.0;
    let ball = BodySpec {
        name: "ball".into(),
        shape: Shape::Ball(r),
        fixed: false,
        density: 1200.0,
        position: [0.0, r, 0.0],
        linvel: [v, 0.0, 0.0],
        angvel: [0.0, 0.0, -v / r],
        sound: Some(sound(r)),
        ..floor()
    };
    let out = simulate(&[floor(), ball], &params(0.5), &|_| {}).unwrap();
    let s = &out.stats;
    eprintln!("rolling: {s:?}");
    assert!(s.rolling_steps > 100, "{s:?}");
    assert!(s.sliding_steps * 20 < s.rolling_steps, "{s:?}");
    assert!(s.impacts <= 1, "{s:?}");
    assert!(rms(&out.channels[0][4800..]) > 0.0);
}

#[test]
fn resting_contacts_are_silent() {
    let half = 0.05;
    let cube = BodySpec {
        name: "box".into(),
        shape: Shape::Cuboid([half; 3]),
        fixed: false,
        density: 500.0,
        position: [0.0, half, 0.0],
        sound: Some(sound(half)),
        ..floor()
    };
    let out = simulate(&[floor(), cube], &params(1.0), &|_| {}).unwrap();
    let late: Vec<_> = out.events.iter().filter(|e| e.time_s > 0.1).collect();
    assert!(late.is_empty(), "{late:?}");
    let tail = &out.channels[0][9600..];
    assert!(
        tail.iter().all(|v| v.abs() < 1e-6),
        "droning: rms {}",
        rms(tail)
    );
}

#[test]
fn bad_bodies_and_settings_are_named() {
    let mut b = floor();
    b.density = -1.0;
    let e = simulate(&[b], &params(1.0), &|_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("floor") && e.contains("density"), "{e}");
    let mut b = floor();
    b.fixed = false;
    b.shape = Shape::TriMesh {
        vertices: vec![[0.0; 3]; 3],
        triangles: vec![[0, 1, 2]],
    };
    assert!(simulate(&[b], &params(1.0), &|_| {})
        .unwrap_err()
        .to_string()
        .contains("fixed"));
    assert!(simulate(&[floor()], &params(-1.0), &|_| {}).is_err());
}

/// Issue 15, item 5: a ball thrown at 1e30 m/s used to fall straight down (rapier gives up on
/// such states in f32) and the scene rendered as if nothing were wrong.
#[test]
fn issue_15_absurd_velocities_are_errors_not_ignored() {
    let ball = |v: [f64; 3], w: [f64; 3]| BodySpec {
        name: "ball".into(),
        shape: Shape::Ball(0.02),
        fixed: false,
        density: 7800.0,
        position: [0.0, 0.5, 0.0],
        linvel: v,
        angvel: w,
        ..floor()
    };
    let e = simulate(
        &[floor(), ball([1e30, 0.0, 0.0], [0.0; 3])],
        &params(0.5),
        &|_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("ball") && e.contains("velocity") && e.contains("1.000e30"),
        "{e}"
    );
    assert!(simulate(
        &[floor(), ball([0.0; 3], [0.0, 0.0, 1e9])],
        &params(0.5),
        &|_| {}
    )
    .is_err());
    // A fast but physical throw still runs.
    assert!(simulate(
        &[floor(), ball([30.0, 0.0, 0.0], [0.0; 3])],
        &params(0.5),
        &|_| {}
    )
    .is_ok());
}

/// A grain dictionary of a synthetic knock recording and a synthetic rolling/sliding one.
fn grains() -> resound_physics::GrainSound {
    use resound_grains::{analyze, Contact, Recording};
    let fs = 48_000.0;
    let mut seed = 1u64;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let knocks: Vec<f32> = (0..24_000)
        .map(|i| {
            let t = (i % 6000) as f64 / fs;
            ((0.5 * (std::f64::consts::TAU * 1800.0 * t).sin() + noise()) * (-t * 60.0).exp())
                as f32
        })
        .collect();
    let slide: Vec<f32> = (0..48_000)
        .map(|i| {
            let t = i as f64 / fs;
            (0.1 * (std::f64::consts::TAU * 800.0 * t).sin() + 0.2 * noise()) as f32
        })
        .collect();
    let recs = [
        Recording {
            name: "knocks".into(),
            contact: Contact::Impact,
            samples: knocks,
        },
        Recording {
            name: "slide".into(),
            contact: Contact::Sliding,
            samples: slide,
        },
    ];
    let (dictionary, _) = analyze(&recs, fs, &Default::default(), &|_| {}).unwrap();
    resound_physics::GrainSound {
        dictionary: std::sync::Arc::new(dictionary),
        params: Default::default(),
    }
}

#[test]
fn grains_are_silent_without_contacts_and_grow_with_contact_power() {
    let silent_floor = BodySpec {
        sound: None,
        ..floor()
    };
    // Falling freely for 0.25 s, then hitting the floor.
    let ball = BodySpec {
        name: "ball".into(),
        shape: Shape::Ball(0.03),
        fixed: false,
        density: 7800.0,
        position: [0.0, 0.33, 0.0],
        sound: None,
        grains: Some(grains()),
        ..floor()
    };
    let out = simulate(&[silent_floor.clone(), ball], &params(0.4), &|_| {}).unwrap();
    let t_hit = out.events.first().map(|e| e.time_s).unwrap();
    let fs = 48_000.0;
    let hit = (t_hit * fs) as usize;
    assert!(t_hit > 0.2, "hit at {t_hit}");
    assert!(out.channels[0][..hit - 100].iter().all(|&v| v == 0.0));
    assert!(rms(&out.channels[0][hit..hit + 4800]) > 1e-3);
    // Sliding: louder with more contact power (faster).
    let slide = |speed: f64| {
        let cube = BodySpec {
            name: "box".into(),
            shape: Shape::Cuboid([0.05; 3]),
            fixed: false,
            density: 500.0,
            position: [0.0, 0.05, 0.0],
            linvel: [speed, 0.0, 0.0],
            friction: 0.2,
            sound: None,
            grains: Some(grains()),
            ..floor()
        };
        let mut p = params(0.3);
        p.stereo = false;
        let out = simulate(&[silent_floor.clone(), cube], &p, &|_| {}).unwrap();
        assert!(out.stats.sliding_steps > 20);
        rms(&out.channels[0][2400..12_000])
    };
    let (slow, fast) = (slide(1.0), slide(3.0));
    eprintln!("grain sliding rms {slow:.3e} at 1 m/s, {fast:.3e} at 3 m/s");
    assert!(slow > 0.0 && fast > 2.0 * slow, "{slow} → {fast}");
}

/// A plate that sounds one mode (1 kHz, 2 1/s of its own), its gains the same everywhere.
fn one_mode_plate(position: [f64; 3]) -> BodySpec {
    let mut s = sound(0.1);
    s.modes = vec![(1000.0, 2.0)];
    s.gains = vec![0.02f32; s.vertices.len()];
    BodySpec {
        name: "plate".into(),
        shape: Shape::Cuboid([0.1, 0.005, 0.1]),
        fixed: false,
        density: 2700.0,
        position,
        restitution: 0.0,
        sound: Some(s),
        ..floor()
    }
}

/// The decay rate (1/s) of the envelope of `x` between `t0` and `t1` s: the slope of
/// ln RMS over 10 ms windows, least squares.
fn decay_rate(x: &[f32], fs: f64, t0: f64, t1: f64) -> f64 {
    let w = (0.01 * fs) as usize;
    let (mut pts, mut k) = (Vec::new(), (t0 * fs) as usize);
    while k + w <= (t1 * fs) as usize {
        pts.push(((k + w / 2) as f64 / fs, rms(&x[k..k + w]).ln()));
        k += w;
    }
    let n = pts.len() as f64;
    let (mt, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mt) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mt).powi(2)).sum();
    -sxy / sxx
}

#[test]
fn a_plate_at_rest_on_a_table_falls_quiet_by_contact_damping_and_a_free_one_rings_on() {
    let fs = 48_000.0;
    // At rest: dropped flat from 5 mm onto a silent floor, it lies there after the impact.
    let silent_floor = BodySpec {
        sound: None,
        restitution: 0.0,
        ..floor()
    };
    let resting = one_mode_plate([0.0, 0.01, 0.0]);
    let out = simulate(&[silent_floor, resting], &params(0.6), &|_| {}).unwrap();
    let t_hit = out
        .events
        .iter()
        .find(|e| e.kind == ContactKind::Impact)
        .expect("the plate lands")
        .time_s;
    let d_rest = decay_rate(&out.channels[0], fs, t_hit + 0.03, t_hit + 0.12);
    // The model: own rate + π f η, η the mean of the plate's and the (silent) floor's loss
    // factors, the contact carrying the plate's whole weight.
    let want = 2.0 + std::f64::consts::PI * 1000.0 * resound_physics::DEFAULT_CONTACT_LOSS;
    // Hanging free: no gravity, struck sideways by a silent ball that bounces off.
    let free = one_mode_plate([0.0, 0.2, 0.0]);
    let ball = BodySpec {
        name: "ball".into(),
        shape: Shape::Ball(0.01),
        density: 7800.0,
        position: [-0.2, 0.2, 0.0],
        linvel: [2.0, 0.0, 0.0],
        restitution: 0.8,
        sound: None,
        ..floor()
    };
    let ball = BodySpec {
        fixed: false,
        ..ball
    };
    let zero_g = SceneParams {
        gravity: [0.0; 3],
        ..params(1.5)
    };
    let out_free = simulate(&[free, ball], &zero_g, &|_| {}).unwrap();
    let t_free = out_free
        .events
        .iter()
        .find(|e| e.kind == ContactKind::Impact)
        .expect("the ball strikes the plate")
        .time_s;
    let d_free = decay_rate(&out_free.channels[0], fs, t_free + 0.05, t_free + 1.0);
    eprintln!(
        "decay at rest {d_rest:.1} 1/s (model {want:.1}), hanging free {d_free:.2} 1/s (own 2)"
    );
    assert!(
        (d_rest / want - 1.0).abs() < 0.15,
        "at rest {d_rest} vs {want}"
    );
    assert!((d_free - 2.0).abs() < 0.5, "free {d_free} vs its own 2 1/s");
}

#[test]
fn air_absorbs_each_mode_by_iso_9613_over_the_distance_to_the_listener() {
    // A silent ball strikes the sounding floor; the listener 20 m away.
    let ball = BodySpec {
        name: "ball".into(),
        shape: Shape::Ball(0.01),
        fixed: false,
        density: 7800.0,
        position: [0.0, 0.1, 0.0],
        sound: None,
        ..floor()
    };
    let far = |air| SceneParams {
        listener: [0.0, 0.0, 20.0],
        stereo: false,
        air,
        ..params(0.6)
    };
    let air = resound_synth::air::Air::default();
    let with = simulate(&[floor(), ball.clone()], &far(Some(air)), &|_| {}).unwrap();
    let without = simulate(&[floor(), ball], &far(None), &|_| {}).unwrap();
    let fs = 48_000.0;
    // Each mode's amplitude: the correlation with its own frequency over the ringing.
    let amp = |x: &[f32], f: f64| {
        let (re, im) = x.iter().enumerate().fold((0.0, 0.0), |(a, b), (n, &v)| {
            let w = std::f64::consts::TAU * f * n as f64 / fs;
            (a + f64::from(v) * w.cos(), b + f64::from(v) * w.sin())
        });
        (re * re + im * im).sqrt()
    };
    for f in [900.0, 2300.0, 5100.0] {
        let got_db = 20.0 * (amp(&with.channels[0], f) / amp(&without.channels[0], f)).log10();
        let want_db = -air.attenuation_db_per_m(f) * 20.0;
        assert!(
            (got_db - want_db).abs() < 0.02,
            "{f} Hz: {got_db:.3} dB vs ISO 9613-1 {want_db:.3} dB over 20 m"
        );
    }
}
