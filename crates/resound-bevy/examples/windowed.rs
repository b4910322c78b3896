//! A window and a sound card: a bar of aluminium falls onto a wooden table every second, and
//! you hear each one land, bounce and come to rest from where the camera is.
//!
//! ```text
//! sudo apt install libasound2-dev libudev-dev libwayland-dev libxkbcommon-dev
//! cargo run --release -p resound-bevy --features window --example windowed
//! ```

use bevy::prelude::*;
use bevy_rapier3d::prelude::*;
use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};
use resound_bevy::{drop_scene::BAR, Listener, ResoundAudio, ResoundPlugin, Sounding, StartSet};

const SAMPLE_RATE_HZ: f64 = 48_000.0;

/// The sound of the bars: Resound's aluminium on a bar of their size, struck near one end.
#[derive(Resource, Clone)]
struct BarSound(Sounding);

/// Keeps the device stream playing (cpal streams are not `Send`).
struct Playing(#[allow(dead_code)] cpal::Stream);

#[derive(Resource)]
struct Spawner(Timer, u32);

fn main() -> resound::Result<()> {
    let size = BAR.map(|h| 2.0 * f64::from(h));
    let bar = resound::fem::primitive::bar(size);
    let aluminium = resound::core::Material::preset("aluminium")?;
    let model = resound::modal::ModalBuilder::surface(&bar, &aluminium)
        .modes(40)
        .solve()?
        .model;
    let sound = Sounding::from_reference(&model, "preset:aluminium", None, 0, SAMPLE_RATE_HZ)?;
    App::new()
        .add_plugins((
            DefaultPlugins,
            RapierPhysicsPlugin::<NoUserData>::default(),
            ResoundPlugin {
                sample_rate_hz: SAMPLE_RATE_HZ,
                capture: false,
                ..Default::default()
            },
        ))
        .insert_resource(BarSound(sound))
        .insert_resource(Spawner(Timer::from_seconds(1.0, TimerMode::Repeating), 0))
        .add_systems(Startup, setup)
        .add_systems(PostStartup, play.after(StartSet))
        .add_systems(Update, spawn)
        .run();
    Ok(())
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Mesh3d(meshes.add(Cuboid::new(2.0, 0.1, 2.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.55, 0.4, 0.25))),
        Transform::from_xyz(0.0, -0.05, 0.0),
        RigidBody::Fixed,
        Collider::cuboid(1.0, 0.05, 1.0),
        Restitution::coefficient(0.3),
    ));
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 0.5, 0.8).looking_at(Vec3::ZERO, Vec3::Y),
        Listener,
    ));
}

/// Every second a bar, from 0.2–0.6 m, at a place along the table.
fn spawn(
    mut commands: Commands,
    time: Res<Time>,
    mut spawner: ResMut<Spawner>,
    sound: Res<BarSound>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    if !spawner.0.tick(time.delta()).just_finished() {
        return;
    }
    spawner.1 += 1;
    let k = spawner.1;
    let x = -0.4 + 0.1 * (k % 9) as f32;
    let h = 0.2 + 0.05 * (k % 9) as f32;
    commands.spawn((
        Mesh3d(meshes.add(Cuboid::new(2.0 * BAR[0], 2.0 * BAR[1], 2.0 * BAR[2]))),
        MeshMaterial3d(materials.add(Color::srgb(0.8, 0.8, 0.85))),
        Transform::from_xyz(x, h, 0.0).with_rotation(Quat::from_rotation_y(0.7 * k as f32)),
        RigidBody::Dynamic,
        Collider::cuboid(BAR[0], BAR[1], BAR[2]),
        ColliderMassProperties::Density(2700.0),
        Restitution::coefficient(0.3),
        sound.0.clone(),
    ));
}

/// Takes the audio side to the default output device.
fn play(world: &mut World) {
    let Some(audio) = world
        .get_resource_mut::<ResoundAudio>()
        .and_then(|mut a| a.0.get_mut().ok().and_then(|l| l.audio.take()))
    else {
        error!("resound: no audio side to play");
        return;
    };
    match open(audio) {
        Ok(stream) => world.insert_non_send(Playing(stream)),
        Err(e) => error!("resound: no sound: {e}"),
    }
}

fn open(mut audio: resound::synth::scene_audio::SceneAudio) -> Result<cpal::Stream, String> {
    let device = cpal::default_host()
        .default_output_device()
        .ok_or("no audio output device")?;
    let default = device.default_output_config().map_err(|e| e.to_string())?;
    let channels = default.channels() as usize;
    let config = cpal::StreamConfig {
        channels: default.channels(),
        sample_rate: cpal::SampleRate(SAMPLE_RATE_HZ as u32),
        buffer_size: cpal::BufferSize::Default,
    };
    // Planar scratch for the two channels, sized once: the callback never allocates.
    let mut left = vec![0.0f32; 8192];
    let mut right = vec![0.0f32; 8192];
    let stream = device
        .build_output_stream(
            &config,
            move |data: &mut [f32], _: &cpal::OutputCallbackInfo| {
                for block in data.chunks_mut(8192 * channels) {
                    let frames = block.len() / channels;
                    let (l, r) = (&mut left[..frames], &mut right[..frames]);
                    l.fill(0.0);
                    r.fill(0.0);
                    audio.process(&mut [&mut *l, &mut *r]);
                    for (k, frame) in block.chunks_mut(channels).enumerate() {
                        for (c, v) in frame.iter_mut().enumerate() {
                            let s = if c % 2 == 0 { l[k] } else { r[k] };
                            *v = (4.0 * s).clamp(-1.0, 1.0);
                        }
                    }
                }
            },
            |e| eprintln!("audio error: {e}"),
            None,
        )
        .map_err(|e| format!("cannot open the device at {SAMPLE_RATE_HZ} Hz: {e}"))?;
    stream.play().map_err(|e| e.to_string())?;
    Ok(stream)
}
