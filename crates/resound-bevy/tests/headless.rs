//! The plugin headless: bars dropped onto a table sound at each impact, not in free fall, and
//! fall quiet at rest.
#![allow(clippy::unwrap_used)]

use resound::synth::excitation::Elastic;
use resound_bevy::{drop_scene, Sounding};

const ALUMINIUM: Elastic = Elastic {
    youngs_modulus: 70e9,
    poisson_ratio: 0.33,
};

fn sound() -> Sounding {
    Sounding {
        modes: vec![(820.0, 12.0), (2270.0, 20.0), (4450.0, 35.0)],
        gains: vec![0.05, 0.03, 0.02],
        radiation: None,
        elastic: ALUMINIUM,
        contact_loss: resound::physics::DEFAULT_CONTACT_LOSS,
    }
}

fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

#[test]
fn dropped_bars_sound_at_each_impact_and_are_silent_in_free_fall_and_at_rest() {
    let heights = [0.2f32, 0.35, 0.5];
    let mut app = drop_scene::app(&sound(), &heights);
    let out = drop_scene::run(&mut app, 3.0);
    let fs = out.sample_rate_hz;
    assert_eq!(out.channels.len(), 2);
    let mix: Vec<f32> = out.channels[0]
        .iter()
        .zip(&out.channels[1])
        .map(|(a, b)| a + b)
        .collect();
    // rapier advances a fixed step every frame, the first included (whose clock has no
    // elapsed time): the sound keeps the physics' time, 3 s of it.
    assert_eq!(mix.len(), (3.0 * fs) as usize);
    assert!(!out.impacts.is_empty());
    // Free fall: the lowest bar lands after √(2h/g) = 0.20 s; nothing sounds before.
    let first = out.impacts[0].0;
    let fall = (2.0 * f64::from(heights[0]) / 9.81).sqrt();
    assert!(
        (first - fall).abs() < 2.0 / drop_scene::FPS,
        "first impact at {first} s, free fall lasts {fall} s"
    );
    let onset = mix.iter().position(|&v| v != 0.0).unwrap();
    assert!(
        onset as f64 >= first * fs,
        "sound at {} s before the first impact at {first} s",
        onset as f64 / fs
    );
    // Every bar lands: an impact within two frames of its free-fall time, and sound starts
    // there (the frame of the impact plus the propagation delay is louder than before it).
    for &h in &heights {
        let t = (2.0 * f64::from(h) / 9.81).sqrt();
        let hit = out
            .impacts
            .iter()
            .find(|(ti, ..)| (ti - t).abs() < 2.0 / drop_scene::FPS)
            .unwrap_or_else(|| panic!("no impact near {t} s: {:?}", out.impacts));
        let k = (hit.0 * fs) as usize;
        let frame = (fs / drop_scene::FPS) as usize;
        let before = rms(&mix[k.saturating_sub(frame)..k]);
        let after = rms(&mix[k..k + 2 * frame]);
        // The earlier bars still ring: a rise of a fifth at least.
        assert!(
            after > 1.2 * before && after > 0.0,
            "impact at {} s: {after} vs {before}",
            hit.0
        );
    }
    // At rest: no impacts in the last second, and the sound has died away.
    let last = out.impacts.last().unwrap().0;
    assert!(last < 2.0, "impacts until {last} s");
    let peak = mix.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let tail = &mix[(2.8 * fs) as usize..];
    assert!(
        rms(tail) < 1e-4 * f64::from(peak),
        "tail {} vs peak {peak}",
        rms(tail)
    );
}

#[test]
fn the_headless_example_estimates_a_material_and_writes_a_readable_wav() {
    let dir = std::env::temp_dir().join(format!("resound-bevy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("drop.wav");
    let recording = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/recordings/steel_nut_M4_2.wav");
    let (material, output) = drop_scene::estimate_and_drop(&recording, &out).unwrap();
    assert!(
        material.gamma > 1e6 && material.gamma < 1e10,
        "{}",
        material.gamma
    );
    assert!(output.impacts.len() >= 3);
    let clip = resound::io::load_audio(&out).unwrap();
    assert_eq!(clip.channels.len(), 2);
    assert_eq!(clip.sample_rate_hz, 48_000);
    let peak = clip.channels[0]
        .iter()
        .chain(&clip.channels[1])
        .fold(0.0f32, |m, v| m.max(v.abs()));
    assert!((peak - 0.891).abs() < 0.01, "peak {peak}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Zero crossings per second over `x` (a pure tone: twice its frequency).
fn tone_hz(x: &[f32], fs: f64) -> f64 {
    let n = x
        .windows(2)
        .filter(|w| (w[0] < 0.0) != (w[1] < 0.0))
        .count();
    0.5 * n as f64 * fs / x.len() as f64
}

/// One bar at rest from the start; after 1 s a bar of one 1500 Hz mode is spawned 0.3 m up,
/// with the listener at `listener`. Returns the mono mix and the spawned bar's impact time.
fn spawn_run(listener: [f32; 3]) -> (Vec<f32>, f64, f64) {
    use bevy::prelude::{Transform, With};
    let mut app = drop_scene::app(&sound(), &[0.0]);
    let out = drop_scene::run(&mut app, 1.0);
    let before = out.impacts.len();
    {
        let world = app.world_mut();
        let mut q = world.query_filtered::<&mut Transform, With<resound_bevy::Listener>>();
        for mut t in q.iter_mut(world) {
            t.translation = listener.into();
        }
    }
    let bell = Sounding {
        modes: vec![(1500.0, 4.0)],
        gains: vec![0.05],
        radiation: None,
        elastic: ALUMINIUM,
        contact_loss: resound::physics::DEFAULT_CONTACT_LOSS,
    };
    drop_scene::spawn_bar(app.world_mut(), &bell, 0.3, 0.3);
    let out = drop_scene::run(&mut app, 1.0);
    let fs = out.sample_rate_hz;
    let hit = out.impacts[before..]
        .iter()
        .map(|i| i.0)
        .find(|&t| t > 1.0)
        .expect("the spawned bar's impact");
    let mix = out.channels[0]
        .iter()
        .zip(&out.channels[1])
        .map(|(a, b)| a + b)
        .collect();
    (mix, hit, fs)
}

#[test]
fn a_body_spawned_while_running_sounds_at_its_impact_and_the_listener_is_followed() {
    let near = [0.3f32, 0.5, 0.3];
    let (mix, hit, fs) = spawn_run(near);
    // It falls 0.3 m from t ≈ 1 s: it lands √(2h/g) = 0.25 s later.
    let fall = (2.0 * 0.3f64 / 9.81).sqrt();
    assert!(
        (hit - 1.0 - fall).abs() < 3.0 / drop_scene::FPS,
        "spawned bar lands at {hit} s"
    );
    let k = (hit * fs) as usize;
    let frame = (fs / drop_scene::FPS) as usize;
    let quiet = rms(&mix[k - 3 * frame..k - frame]);
    let ring = &mix[k + frame..k + 7 * frame];
    assert!(rms(ring) > 100.0 * quiet, "{} vs {quiet}", rms(ring));
    // Its own pitch: the spawned source took the new modes, not the first bar's 820 Hz (the
    // rebounds' pulses add a few crossings: within 5 %).
    let f = tone_hz(ring, fs);
    assert!((f / 1500.0 - 1.0).abs() < 0.05, "{f} Hz");
    // The same run heard from 4× the distance (moved before the spawn): a quarter the level.
    let rest = [0.3f64, 0.015, 0.0];
    let dist = |l: [f32; 3]| {
        (0..3)
            .map(|c| (f64::from(l[c]) - rest[c]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let d_near = dist(near);
    let far = [0.3f32, 0.015 + (4.0 * d_near) as f32, 0.0];
    let (mix_far, hit_far, _) = spawn_run(far);
    assert!((hit_far - hit).abs() < 1e-9);
    let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let kf = (hit_far * fs) as usize;
    let ratio = f64::from(peak(&mix[k..k + 10 * frame]) / peak(&mix_far[kf..kf + 20 * frame]));
    let want = dist(far) / d_near;
    assert!(
        (ratio / want - 1.0).abs() < 0.1,
        "near/far {ratio}, 1/r says {want}"
    );
}

/// Issue 19: a `Sounding::radiating` body radiates each mode by its model's acoustic transfer
/// at the listener as seen from the body. A fixed steel bar turned 90° about y, with a silent
/// ball dropped on it, rendered plain and radiating: the same contacts, so each mode's level
/// (windowed DFT at its frequency) changes by that mode's factor at the listener in the bar's
/// frame (`AcousticTransfer::factor`). The factors differ from mode to mode and from the
/// un-turned bar's, so a constant scale or a wrong frame fails.
#[test]
fn a_radiating_body_is_heard_by_its_transfer_in_its_own_frame() {
    use bevy::prelude::*;
    use bevy_rapier3d::prelude::*;
    let steel = resound::core::Material::preset("steel").unwrap();
    let size = [0.2, 0.03, 0.02];
    let mut model =
        resound::modal::ModalBuilder::surface(&resound::fem::primitive::bar(size), &steel)
            .modes(8)
            .solve()
            .unwrap()
            .model;
    resound::radiation::add_transfer(&mut model, &resound::modal::TransferParams::default())
        .unwrap();
    let material =
        resound::material::resolve_material("preset:steel", std::path::Path::new("."), None)
            .unwrap();
    let plain = Sounding::from_material(&model, &material, 0, 48_000.0);
    let heard = Sounding::radiating(&model, &material, 0, 48_000.0).unwrap();
    assert_eq!(plain.modes, heard.modes);
    let listener = Vec3::new(0.25, 0.35, 0.15);
    let turn = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let render = |sound: &Sounding| {
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            TransformPlugin,
            RapierPhysicsPlugin::<NoUserData>::default(),
            resound_bevy::ResoundPlugin::default(),
        ))
        .insert_resource(TimestepMode::Fixed {
            dt: (1.0 / drop_scene::FPS) as f32,
            substeps: 4,
        })
        .insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
            std::time::Duration::from_secs_f64(1.0 / drop_scene::FPS),
        ));
        let world = app.world_mut();
        world.spawn((
            Transform::from_rotation(turn),
            RigidBody::Fixed,
            Collider::cuboid(0.1, 0.015, 0.01),
            sound.clone(),
        ));
        world.spawn((
            Transform::from_xyz(0.0, 0.08, 0.03),
            RigidBody::Dynamic,
            Collider::ball(0.01),
            ColliderMassProperties::Density(7850.0),
            Restitution::coefficient(0.5),
        ));
        world.spawn((
            Transform::from_translation(listener),
            resound_bevy::Listener,
        ));
        app.finish();
        drop_scene::run(&mut app, 1.5)
    };
    let a = render(&plain);
    let b = render(&heard);
    assert!(!a.impacts.is_empty());
    assert_eq!(a.impacts.len(), b.impacts.len());
    let fs = a.sample_rate_hz;
    // Hann-windowed DFT magnitude at f over 0.4–1.4 s (after the first impact).
    let (k0, n) = ((0.4 * fs) as usize, fs as usize);
    let level = |x: &[f32], f: f64| {
        let (mut re, mut im) = (0.0, 0.0);
        for (k, &v) in x[k0..k0 + n].iter().enumerate() {
            let w = 0.5 - 0.5 * (std::f64::consts::TAU * k as f64 / n as f64).cos();
            let ph = std::f64::consts::TAU * f * k as f64 / fs;
            re += w * f64::from(v) * ph.cos();
            im += w * f64::from(v) * ph.sin();
        }
        re.hypot(im)
    };
    let r = heard.radiation.as_ref().unwrap();
    let local = (turn.inverse() * listener).to_array().map(f64::from);
    let unturned = listener.to_array().map(f64::from);
    let mut scratch = resound::core::radiation::FieldScratch::default();
    let plain_levels: Vec<f64> = plain
        .modes
        .iter()
        .map(|m| level(&a.channels[0], m.0))
        .collect();
    let top = plain_levels.iter().copied().fold(0.0, f64::max);
    let (mut compared, mut worst, mut lo, mut hi, mut sensitive) =
        (0, 0.0f64, f64::MAX, 0.0f64, false);
    for (k, &(f, _)) in plain.modes.iter().enumerate() {
        let want = r
            .transfer
            .factor(r.modes[k], f, local, &mut scratch)
            .unwrap();
        let other = r
            .transfer
            .factor(r.modes[k], f, unturned, &mut scratch)
            .unwrap();
        let got = level(&b.channels[0], f) / plain_levels[k];
        eprintln!(
            "mode {k}: {f:8.1} Hz  level {:.3e}  factor {want:.4e}  measured {got:.4e}  \
             (un-turned {other:.4e})",
            plain_levels[k]
        );
        // Below that, the other modes' window leakage is comparable.
        if plain_levels[k] < 1e-7 * top {
            continue;
        }
        compared += 1;
        worst = worst.max((got / want - 1.0).abs());
        lo = lo.min(want);
        hi = hi.max(want);
        sensitive |= (other / want - 1.0).abs() > 0.1;
    }
    assert!(compared >= 4, "{compared} modes loud enough");
    assert!(worst < 0.03, "measured factors off by up to {worst:.3}");
    assert!(
        hi / lo > 2.0,
        "factors {lo:.3e}..{hi:.3e}: too alike to tell"
    );
    assert!(sensitive, "the bar's turn changes no factor");
}

/// The bar of [`drop_scene`] dropped from `h` m onto its table, as a scene file.
fn drop_scene_file(h: f64) -> String {
    drop_scene_file_with(h, "")
}

/// [`drop_scene_file`] with `extra` lines added to the bar's body.
fn drop_scene_file_with(h: f64, extra: &str) -> String {
    let [x, y, z] = drop_scene::BAR.map(|v| 2.0 * f64::from(v));
    format!(
        "duration = 0.6\nseed = 1\n[listener]\nposition = [0.0, 0.5, 0.3]\n\
         [[body]]\nname = \"table\"\nfixed = true\nshape = {{ box = [2.0, 0.1, 2.0] }}\n\
         material = \"preset:wood\"\ndensity = 700\nposition = [0.0, -0.05, 0.0]\n\
         restitution = 0.3\nsound = false\n\
         [[body]]\nname = \"bar\"\nshape = {{ box = [{x}, {y}, {z}] }}\n\
         material = \"preset:aluminium\"\ndensity = 2700\nposition = [-0.3, {}, 0.0]\n\
         restitution = 0.3\nmodes = 6\n{extra}",
        h + 0.5 * y
    )
}

#[test]
fn a_game_and_the_same_scene_offline_excite_the_same_impact() {
    // One contact model (resound::physics::contact) for both: the bar's first impact has the
    // same approach speed and solver impulse in Bevy (60 frames/s, 4 substeps) as in the
    // offline scene, and both are the free fall's: v = √(2gh), m·v ≲ J ≤ m·v·(1 + e).
    let h = 0.3;
    let mut app = drop_scene::app(&sound(), &[h as f32]);
    let game = drop_scene::run(&mut app, 0.6);
    let (v_game, j_game) = game.impact_figures[0];
    let offline = resound::scene::render_scene_text(
        &drop_scene_file(h),
        "drop",
        std::path::Path::new("."),
        &resound::scene::SceneRenderParams::default(),
        &|_| {},
    )
    .unwrap();
    let first = offline
        .events
        .iter()
        .find(|e| e.kind == resound::physics::ContactKind::Impact)
        .unwrap();
    let (v_scene, j_scene) = (first.speed_m_s, first.force);
    let v_fall = (2.0 * 9.81 * h).sqrt();
    let [x, y, z] = drop_scene::BAR.map(|v| 2.0 * f64::from(v));
    let j_fall = 2700.0 * x * y * z * v_fall * 1.3;
    // The game sees the approach of the frame before (up to g/60 = 0.16 m/s slow) and takes
    // the impulse from the bar's momentum change over the frame; the offline scene takes the
    // solver's impulse of its first step in touch. Either stops the bar (m·v) and at most
    // bounces it back (m·v·(1 + e)); the rebound may follow as contact.
    let stop = j_fall / 1.3;
    for (what, v, j) in [("game", v_game, j_game), ("scene", v_scene, j_scene)] {
        assert!(
            (v / v_fall - 1.0).abs() < 0.08,
            "{what}: {v} m/s vs {v_fall}"
        );
        assert!(
            j > 0.8 * stop && j < 1.05 * j_fall,
            "{what}: {j} N·s vs {stop}–{j_fall}"
        );
    }
    assert!(
        (v_game / v_scene - 1.0).abs() < 0.08,
        "{v_game} vs {v_scene} m/s"
    );
    assert!(
        (j_game / j_scene - 1.0).abs() < 0.15,
        "{j_game} vs {j_scene} N·s"
    );
}

/// RMS of `x` from `t0` s for `len_s` s.
fn rms_from(x: &[f32], fs: f64, t0: f64, len_s: f64) -> f64 {
    let a = (t0 * fs).round().max(0.0) as usize;
    let b = ((t0 + len_s) * fs).round() as usize;
    rms(&x[a.min(x.len())..b.min(x.len())])
}

/// Mono mix of the first two channels (or the one).
fn mono(channels: &[Vec<f32>]) -> Vec<f32> {
    match channels {
        [a, b, ..] => a.iter().zip(b).map(|(a, b)| a + b).collect(),
        [a] => a.clone(),
        [] => Vec::new(),
    }
}

#[test]
fn a_game_body_built_from_the_scene_sounds_like_the_scene_offline() {
    // The same body on both sides: the scene file's bar, built by the library
    // (resound::scene::build_scene), heard in the game at the vertex the offline render's
    // first impact struck, damped by its contact with the table as offline. The first impact
    // then has the same modes, the same Hertz pulse (within the ≤ 8 % approach-speed
    // difference of the other test) and the same 1/r to the one listener: its level agrees
    // within 2 dB.
    let h = 0.3;
    let text = drop_scene_file(h);
    let scene = resound::io::scene::parse_scene(&text, "drop").unwrap();
    let (bodies, _) = resound::scene::build_scene(
        &scene,
        &resound::scene::BuildOptions {
            base_dir: std::path::Path::new("."),
            library: None,
            cache_dir: None,
            progress: &|_| {},
        },
    )
    .unwrap();
    let bar = bodies.iter().find(|b| b.name == "bar").unwrap();
    let body = bar.sound.clone().unwrap();
    let offline = resound::scene::render_scene_text(
        &text,
        "drop",
        std::path::Path::new("."),
        &resound::scene::SceneRenderParams {
            keep_level: true,
            ..Default::default()
        },
        &|_| {},
    )
    .unwrap();
    let first = offline
        .events
        .iter()
        .find(|e| e.kind == resound::physics::ContactKind::Impact)
        .unwrap()
        .clone();
    // The bar falls without turning: the contact point in the body frame.
    let centre = [-0.3, first.point[1] + f64::from(drop_scene::BAR[1]), 0.0];
    let local: Vec<f64> = (0..3).map(|c| first.point[c] - centre[c]).collect();
    let vertex = body
        .vertices
        .iter()
        .enumerate()
        .min_by(|(_, a), (_, b)| {
            let d = |v: &[f64; 3]| (0..3).map(|c| (v[c] - local[c]).powi(2)).sum::<f64>();
            d(a).total_cmp(&d(b))
        })
        .unwrap()
        .0;
    let sound = Sounding::at_vertex(body, vertex);
    // The most the first impact can reach at the listener: every mode in phase, 1/r.
    let bound = {
        let sum: f64 = sound.gains.iter().map(|g| f64::from(g.abs())).sum();
        let r = (0.3f64.powi(2) + 0.5f64.powi(2) + 0.3f64.powi(2)).sqrt();
        sum * first.force / r
    };
    eprintln!("modes {:?} elastic {:?}", sound.modes, sound.elastic);
    let mut app = drop_scene::app(&sound, &[h as f32]);
    let game = drop_scene::run(&mut app, 0.6);
    let (t_game, t_scene) = (game.impacts[0].0, first.time_s);
    assert!(
        (t_game - t_scene).abs() < 2.0 / drop_scene::FPS,
        "impact at {t_game} s in the game, {t_scene} s offline"
    );
    let (g, s) = (mono(&game.channels), mono(&offline.channels));
    let (fs_g, fs_s) = (game.sample_rate_hz, f64::from(offline.sample_rate_hz));
    // Where each render's sound starts: the first sample above a tenth of its peak (the game
    // hears a contact at the end of its frame, the scene within its step).
    let onset = |x: &[f32], fs: f64| {
        let peak = x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        x.iter().position(|v| v.abs() > 0.1 * peak).unwrap_or(0) as f64 / fs
    };
    let (on_g, on_s) = (onset(&g, fs_g), onset(&s, fs_s));
    let pk = |x: &[f32]| f64::from(x.iter().fold(0.0f32, |m, v| m.max(v.abs())));
    eprintln!(
        "peaks: game {:.3e}, scene {:.3e}; Σ|gain|·J/r {bound:.3e}",
        pk(&g),
        pk(&s)
    );
    eprintln!(
        "onsets: game {on_g:.4} s (impact {t_game:.4}), scene {on_s:.4} s (impact {t_scene:.4})"
    );
    assert!(
        (on_g - on_s).abs() < 2.0 / drop_scene::FPS,
        "the sound starts at {on_g} s in the game, {on_s} s offline"
    );
    // The impact's level: the peak over the first 10 ms from the onset, per channel summed as
    // energy (the two renderers place the source with their own pan law and interaural
    // delay, which a mono sum would comb-filter). Later the two worlds part: rapier on its
    // own at the scene's step rocks the bar on an edge for 60 ms (sliding, damped by the
    // table), bevy_rapier at 60 frames/s × 4 substeps does not, so what follows the first
    // impact is not compared.
    let level = |chs: &[Vec<f32>], fs: f64, t0: f64| {
        let a = (t0 * fs) as usize;
        let b = ((t0 + 0.01) * fs) as usize;
        chs.iter()
            .map(|c| pk(&c[a.min(c.len())..b.min(c.len())]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let level_g = level(&game.channels, fs_g, on_g);
    let level_s = level(&offline.channels, fs_s, on_s);
    let db = 20.0 * (level_g / level_s).log10();
    let (j_g, j_s) = (game.impact_figures[0].1, first.force);
    eprintln!(
        "vertex {vertex}: game {level_g:.3e} vs scene {level_s:.3e} ({db:+.2} dB); impulse \
         {j_g:.4e} vs {j_s:.4e} N·s ({:+.2} dB)",
        20.0 * (j_g / j_s).log10()
    );
    assert!(level_s > 0.0 && db.abs() < 2.0, "{db:+.2} dB");
    // Neither can ring louder than every mode in phase allows (the old offline render did).
    for (what, l) in [("game", level_g), ("scene", level_s)] {
        assert!(
            l <= 1.05 * bound,
            "{what}: {l:.3e} > Σ|gain|·J/r {bound:.3e}"
        );
    }
}

/// One 200 Hz mode (own decay 2/s) of `gain` (amplitude per N·s), aluminium for Hertz.
fn one_mode(gain: f32) -> Sounding {
    Sounding {
        modes: vec![(200.0, 2.0)],
        gains: vec![gain],
        radiation: None,
        elastic: ALUMINIUM,
        contact_loss: resound::physics::DEFAULT_CONTACT_LOSS,
    }
}

#[test]
fn a_game_body_resting_on_the_table_rings_shorter_by_its_contact_damping() {
    // One 200 Hz mode (own decay 2/s) on a bar that settles on the table: resting with its
    // whole weight, it takes on the pair's loss factor η = (0.02 + 0.02)/2 (the shared contact
    // model, as offline), so it decays at 2 + π·200·η = 14.6 1/s once at rest.
    let one = one_mode(100.0);
    let mut app = drop_scene::app(&one, &[0.02]);
    let out = drop_scene::run(&mut app, 1.2);
    let fs = out.sample_rate_hz;
    let env = |t0: f64| {
        out.channels
            .iter()
            .map(|c| rms_from(c, fs, t0, 0.05).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    // Log-slope of the envelope while it lies still (from 0.27 s) and after rapier puts it to
    // sleep (0.75 s), which must not end the damping. (Gain 100 keeps the mode above the
    // cull level to the end.)
    let expected = 2.0 + std::f64::consts::PI * 200.0 * resound::physics::DEFAULT_CONTACT_LOSS;
    for (what, t0, t1) in [("awake", 0.32, 0.62), ("asleep", 0.8, 1.1)] {
        let (e0, e1) = (env(t0), env(t1));
        let d = (e0 / e1).ln() / (t1 - t0);
        eprintln!("{what}: decay {d:.2} 1/s (expected {expected:.2})");
        assert!(
            e1 > 0.0 && (d / expected - 1.0).abs() < 0.1,
            "{what}: {d} vs {expected} 1/s"
        );
    }
    assert_eq!(out.impacts.len(), 1, "it settles after one impact");
}

#[test]
fn a_game_impact_is_as_loud_as_its_impulse_and_the_distance_say() {
    // One 200 Hz mode of gain 1 (amplitude per N·s) struck by the drop's impulse J, heard at
    // r from the bar: the mode rings at J·|F(200 Hz)|/J ≈ 0.98 J (the 0.6 ms Hertz pulse
    // passes 200 Hz nearly whole) over r, split by the equal-power pan (√(L² + R²) of it).
    let one = one_mode(1.0);
    let mut app = drop_scene::app(&one, &[0.3]);
    let out = drop_scene::run(&mut app, 0.6);
    let j = out.impact_figures[0].1;
    let r = (0.3f64.powi(2) + 0.5f64.powi(2) + 0.3f64.powi(2)).sqrt();
    let (l, rr) = (&out.channels[0], &out.channels[1]);
    let pk = |x: &[f32]| f64::from(x.iter().fold(0.0f32, |m, v| m.max(v.abs())));
    let heard = pk(l).hypot(pk(rr));
    eprintln!(
        "peak {heard:.4e} (left {:.4e}, right {:.4e}); J/r {:.4e}",
        pk(l),
        pk(rr),
        j / r
    );
    assert!(
        (heard / (j / r) - 1.0).abs() < 0.1,
        "heard {heard:.4e} vs J/r {:.4e}",
        j / r
    );
}
