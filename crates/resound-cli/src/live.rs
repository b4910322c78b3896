//! Live playback (`resound synth --play`, cargo feature `live`): the same resonator engine as
//! offline rendering runs inside the audio callback (cpal), where it never allocates.

use anyhow::Result;
use resound::strike::Strike;

/// Plays `strike` (its modes struck by its force through the engine, plus its added signal)
/// at `gain` for `seconds` on the default output device at `sample_rate`.
#[cfg(feature = "live")]
pub fn play(strike: &Strike, gain: f32, sample_rate: u32, seconds: f64) -> Result<()> {
    use anyhow::{anyhow, Context};
    use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};
    use resound::synth::{BankMode, Engine, EngineParams};
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    let host = cpal::default_host();
    let device = host
        .default_output_device()
        .context("no audio output device")?;
    let default = device
        .default_output_config()
        .map_err(|e| anyhow!("the audio output device is not usable: {e}"))?;
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
            anyhow!(
                "cannot open the audio device at {sample_rate} Hz ({e}); try --sample-rate {}",
                default.sample_rate().0
            )
        })?;
    stream
        .play()
        .map_err(|e| anyhow!("cannot start playback: {e}"))?;
    let total = (seconds * f64::from(sample_rate)) as usize;
    while position.load(Ordering::Relaxed) < total {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    Ok(())
}

/// Without the `live` feature there is no audio device support.
#[cfg(not(feature = "live"))]
pub fn play(_strike: &Strike, _gain: f32, _sample_rate: u32, _seconds: f64) -> Result<()> {
    anyhow::bail!(
        "this resound was built without live audio; rebuild with `cargo build --release --features live` (needs ALSA headers: libasound2-dev)"
    )
}
