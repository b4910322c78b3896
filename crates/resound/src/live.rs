//! Live playback on the default audio device (cargo feature `live`, cpal): the same resonator
//! engine as offline rendering runs inside the audio callback, where it never allocates. Every
//! front end that plays (the CLI's `--play`, a live scene) calls these.

use crate::error::{Error, Result};
use crate::strike::Strike;
use serde::{Deserialize, Serialize};

/// What a live scene did on the device.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LivePlayReport {
    /// Device callbacks.
    pub callbacks: u64,
    /// Latency of the live path, samples (the device's own comes on top).
    pub latency: usize,
    /// Physics steps that came late.
    pub late_steps: u64,
    /// Cues dropped for a full queue.
    pub dropped_cues: u64,
    /// Voices stolen.
    pub voices_stolen: u64,
    /// Highest degradation level reached.
    pub degradation: u64,
}

impl std::fmt::Display for LivePlayReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} callbacks, latency {} samples + the device's, {} late steps, {} dropped cues, \
             {} voices stolen, degradation level {}",
            self.callbacks,
            self.latency,
            self.late_steps,
            self.dropped_cues,
            self.voices_stolen,
            self.degradation
        )
    }
}

/// Plays rendered `channels` (mixed to mono) at `sample_rate` on the default output device.
///
/// # Errors
/// No channels; as [`play`].
pub fn play_channels(channels: &[Vec<f32>], sample_rate: u32) -> Result<()> {
    let Some(n) = channels.iter().map(Vec::len).min() else {
        return Err(Error::Invalid("nothing to play".into()));
    };
    let k = channels.len() as f32;
    let mono: Vec<f32> = (0..n)
        .map(|i| channels.iter().map(|c| c[i]).sum::<f32>() / k)
        .collect();
    let seconds = n as f64 / f64::from(sample_rate);
    let strike = Strike {
        samples: Vec::new(),
        modes: Vec::new(),
        force: Vec::new(),
        extra: mono,
        info: Default::default(),
    };
    play(&strike, 1.0, sample_rate, seconds)
}

/// The default output device and its default configuration.
#[cfg(feature = "live")]
fn default_device() -> Result<(cpal::Device, cpal::SupportedStreamConfig)> {
    use cpal::traits::{DeviceTrait, HostTrait};
    let device = cpal::default_host()
        .default_output_device()
        .ok_or_else(|| device_error("no audio output device"))?;
    let config = device
        .default_output_config()
        .map_err(|e| device_error(format!("the audio output device is not usable: {e}")))?;
    Ok((device, config))
}

#[cfg(feature = "live")]
fn device_error(e: impl std::fmt::Display) -> Error {
    Error::Device(e.to_string())
}

/// Plays `strike` (its modes struck by its force through the engine, plus its added signal)
/// at `gain` for `seconds` on the default output device at `sample_rate`.
#[cfg(feature = "live")]
pub fn play(strike: &Strike, gain: f32, sample_rate: u32, seconds: f64) -> Result<()> {
    use cpal::traits::{DeviceTrait, StreamTrait};
    use resound_synth::{BankMode, Engine, EngineParams};
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    let (device, default) = default_device()?;
    let channels = usize::from(default.channels());
    let config = cpal::StreamConfig {
        channels: default.channels(),
        sample_rate: cpal::SampleRate(sample_rate),
        buffer_size: cpal::BufferSize::Default,
    };
    // Everything the callback touches is allocated here.
    let mut engine = Engine::new(EngineParams {
        sample_rate_hz: f64::from(sample_rate),
        voices: 1,
        modes_per_voice: strike.modes.len().max(1),
        force_capacity: strike.force.len().max(1),
        inputs: 1,
        cull_level: 1e-7,
        max_block: 8192,
    })?;
    let modes: Vec<BankMode> = strike
        .modes
        .iter()
        .map(|m| BankMode {
            gain: m.gain * f64::from(gain),
            ..*m
        })
        .collect();
    if !modes.is_empty() {
        let v = engine.start(&modes, 1.0)?;
        engine.excite(v, &strike.force, 0);
    }
    let extra: Vec<f32> = strike.extra.iter().map(|v| v * gain).collect();
    let mut mono = vec![0.0f32; 8192];
    let position = Arc::new(AtomicUsize::new(0));
    let pos_cb = Arc::clone(&position);
    let stream = device
        .build_output_stream(
            &config,
            move |data: &mut [f32], _: &cpal::OutputCallbackInfo| {
                for block in data.chunks_mut(mono.len() * channels) {
                    let frames = block.len() / channels;
                    let buf = &mut mono[..frames];
                    buf.fill(0.0);
                    engine.process(buf);
                    let pos = pos_cb.load(Ordering::Relaxed);
                    for (i, s) in buf.iter_mut().enumerate() {
                        if let Some(e) = extra.get(pos + i) {
                            *s += e;
                        }
                    }
                    pos_cb.store(pos + frames, Ordering::Relaxed);
                    for (frame, &s) in block.chunks_mut(channels).zip(buf.iter()) {
                        frame.fill(s);
                    }
                }
            },
            |e| eprintln!("audio error: {e}"),
            None,
        )
        .map_err(|e| {
            device_error(format!(
                "cannot open the audio device at {sample_rate} Hz ({e}); it takes {} Hz",
                default.sample_rate().0
            ))
        })?;
    stream
        .play()
        .map_err(|e| device_error(format!("cannot start playback: {e}")))?;
    let total = (seconds * f64::from(sample_rate)) as usize;
    while position.load(Ordering::Relaxed) < total {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    Ok(())
}

/// Plays the scene file `path` live on the default output device: rapier on its own thread,
/// the scene's audio side in the device callback (blocks of `block` samples asked for), the
/// physical level times `gain_db`. `progress` hears the build.
#[cfg(feature = "live")]
pub fn play_scene(
    path: &std::path::Path,
    params: &crate::scene::SceneRenderParams,
    block: usize,
    gain_db: f64,
    progress: crate::ProgressFn<'_>,
) -> Result<LivePlayReport> {
    use cpal::traits::{DeviceTrait, StreamTrait};
    use resound_physics::live::{live_scene, run_physics, LiveParams};
    check_gain_db(gain_db)?;
    use resound_synth::scene_audio::AudioStats;
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

    let (bodies, sp) = crate::scene::load_scene(path, params, progress)?;
    let (device, default) = default_device()?;
    let channels = usize::from(default.channels());
    let sample_rate = sp.sample_rate_hz as u32;
    // A callback may ask for more than `block` frames; the driver renders it in pieces.
    let (mut physics, mut tx, mut driver, latency) = live_scene(
        &bodies,
        &sp,
        &LiveParams {
            block,
            ..LiveParams::default()
        },
    )?;
    let total = (physics.total_samples() + latency) as u64;
    let stats = std::sync::Arc::clone(driver.stats());
    let gain = 10f32.powf((gain_db / 20.0) as f32);
    let config = cpal::StreamConfig {
        channels: default.channels(),
        sample_rate: cpal::SampleRate(sample_rate),
        buffer_size: cpal::BufferSize::Fixed(block as u32),
    };
    let stream = device
        .build_output_stream(
            &config,
            move |data: &mut [f32], _: &cpal::OutputCallbackInfo| {
                driver.fill_interleaved(data, channels);
                for v in data.iter_mut() {
                    *v = (*v * gain).clamp(-1.0, 1.0);
                }
            },
            |e| eprintln!("audio error: {e}"),
            None,
        )
        .map_err(|e| {
            device_error(format!(
                "cannot open the audio device at {sample_rate} Hz with {block}-sample blocks \
                 ({e}); the scene's sample_rate must be one the device takes ({} Hz), or \
                 another block size",
                default.sample_rate().0
            ))
        })?;
    let frontier = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    stream
        .play()
        .map_err(|e| device_error(format!("cannot start playback: {e}")))?;
    std::thread::scope(|s| {
        s.spawn(|| run_physics(&mut physics, &mut tx, block, &frontier, &stop));
        // A device that stops calling back must not hang us: the scene's length plus 5 s.
        let limit = std::time::Duration::from_secs_f64(total as f64 / sp.sample_rate_hz + 5.0);
        let t0 = std::time::Instant::now();
        while AudioStats::get(&stats.rendered) < total && t0.elapsed() < limit {
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        stop.store(true, Ordering::Relaxed);
    });
    drop(stream);
    Ok(LivePlayReport {
        callbacks: AudioStats::get(&stats.callbacks),
        latency,
        late_steps: AudioStats::get(&stats.late_steps),
        dropped_cues: AudioStats::get(&stats.dropped),
        voices_stolen: AudioStats::get(&stats.steals),
        degradation: AudioStats::get(&stats.degradation),
    })
}

/// Without the `live` feature there is no audio device support.
#[cfg(not(feature = "live"))]
pub fn play_scene(
    _path: &std::path::Path,
    _params: &crate::scene::SceneRenderParams,
    _block: usize,
    gain_db: f64,
    _progress: crate::ProgressFn<'_>,
) -> Result<LivePlayReport> {
    check_gain_db(gain_db)?;
    Err(Error::NoLiveAudio)
}

/// The live gain must be a level change a person could mean: within ±120 dB.
fn check_gain_db(gain_db: f64) -> Result<()> {
    if gain_db.is_finite() && gain_db.abs() <= 120.0 {
        return Ok(());
    }
    Err(Error::Param {
        field: "gain_db",
        message: format!("the live gain must be within ±120 dB, got {gain_db}"),
    })
}

/// Without the `live` feature there is no audio device support.
#[cfg(not(feature = "live"))]
pub fn play(_strike: &Strike, _gain: f32, _sample_rate: u32, _seconds: f64) -> Result<()> {
    Err(Error::NoLiveAudio)
}
