//! Live scenes: rapier steps on its own thread and sends each step's cues through the
//! lock-free queues; the audio side renders device blocks as they are asked for.
//!
//! The physics thread keeps at most one block ahead of the audio clock (it steps while the
//! next step ends before the end of the block the device will ask for next), and every cue is
//! delayed by a fixed latency (one physics step by default), so a step's cues are in the
//! queue before the block they fall in is rendered. The contact-to-sound latency is that
//! delay plus the device's own buffering; the audio side counts steps whose cues came late
//! (the physics fell behind) in `late_steps`.
//!
//! [`render_live`] runs this with a simulated device: [`Pacing::Lockstep`] waits for the
//! physics thread before each block (deterministic: its output equals the offline
//! [`crate::simulate`] output delayed by the latency, up to the culling of silent voices at
//! other block ends), [`Pacing::RealTime`] calls the audio side at the device's pace and lets
//! the physics keep up or not. A real device drives the same [`Driver`] from its callback
//! (`resound scene --live`).

use crate::scene::ScenePhysics;
use crate::{BodySpec, Event, SceneError, SceneParams, SceneStats};
use resound_synth::scene_audio::{scene_audio, AudioStats, CueSender, Governor, SceneAudio};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How the simulated device calls the audio side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pacing {
    /// Before each block, wait until the physics has sent the cues due in it.
    Lockstep,
    /// One block per block duration of wall time, whatever the physics does.
    RealTime,
}

/// Settings of a live run.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveParams {
    /// Device block, samples.
    pub block: usize,
    /// Delay of every cue, samples (`None`: one physics step).
    pub latency_samples: Option<usize>,
    /// Overload handling of the callback (`None`: render everything).
    pub governor: Option<Governor>,
    /// Simulated device pacing.
    pub pacing: Pacing,
}

impl Default for LiveParams {
    fn default() -> Self {
        Self {
            block: 256,
            latency_samples: None,
            governor: Some(Governor::default()),
            pacing: Pacing::Lockstep,
        }
    }
}

/// Figures of a live run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LiveReport {
    /// Device block, samples.
    pub block: usize,
    /// The cues' delay, samples.
    pub latency_samples: usize,
    /// Callbacks.
    pub callbacks: u64,
    /// Median, 99th percentile and largest callback time over the block's deadline.
    pub p50_share: f64,
    /// See `p50_share`.
    pub p99_share: f64,
    /// See `p50_share`.
    pub max_share: f64,
    /// Callbacks over their deadline.
    pub xruns: u64,
    /// Steps whose cues arrived after their start.
    pub late_steps: u64,
    /// Cues the queues had no room for.
    pub dropped_cues: u64,
    /// Voices faded out under overload.
    pub steals: u64,
    /// Highest degradation level reached.
    pub max_degradation: u64,
}

/// Output of [`render_live`].
#[derive(Clone, Debug, PartialEq)]
pub struct LiveOutput {
    /// One or two channels, the scene's duration plus the latency.
    pub channels: Vec<Vec<f32>>,
    /// The event log.
    pub events: Vec<Event>,
    /// Physics figures.
    pub stats: SceneStats,
    /// Live figures.
    pub report: LiveReport,
}

/// The audio side as a device callback sees it: renders planar blocks of any length into
/// interleaved or planar outputs, and shares the counters.
pub struct Driver {
    audio: SceneAudio,
    planar: [Vec<f32>; 2],
    block: usize,
}

impl Driver {
    /// Wraps `audio`; callbacks of more than `block` samples are rendered in pieces.
    pub fn new(audio: SceneAudio, block: usize) -> Self {
        let block = block.max(1);
        Self {
            audio,
            planar: [vec![0.0; block], vec![0.0; block]],
            block,
        }
    }

    /// Scene channels (1 or 2).
    pub fn channels(&self) -> usize {
        self.audio.channels()
    }

    /// The shared counters.
    pub fn stats(&self) -> &Arc<AudioStats> {
        self.audio.stats()
    }

    /// Fills `out` (interleaved, `device_channels` per frame): the scene's channels go to the
    /// first one or two device channels (mono is copied to both), others are silent. Never
    /// allocates, locks or blocks.
    pub fn fill_interleaved(&mut self, out: &mut [f32], device_channels: usize) {
        let dc = device_channels.max(1);
        for frames in out.chunks_mut(self.block * dc) {
            let n = frames.len() / dc;
            let [l, r] = &mut self.planar;
            let (l, r) = (&mut l[..n], &mut r[..n]);
            l.fill(0.0);
            r.fill(0.0);
            if self.audio.channels() == 2 {
                self.audio.process(&mut [&mut *l, &mut *r]);
            } else {
                self.audio.process(&mut [&mut *l]);
                r.copy_from_slice(l);
            }
            for (i, f) in frames.chunks_mut(dc).enumerate() {
                f.fill(0.0);
                f[0] = l[i];
                if dc > 1 {
                    f[1] = r[i];
                }
            }
        }
    }

    /// Renders planar channels (adding into them).
    pub fn process(&mut self, out: &mut [&mut [f32]]) {
        self.audio.process(out);
    }
}

/// Builds the two sides of a live scene: the physics (to run on its own thread), its cue
/// sender, and the device callback's [`Driver`].
pub fn live_scene(
    bodies: &[BodySpec],
    params: &SceneParams,
    live: &LiveParams,
) -> Result<(ScenePhysics, CueSender, Driver, usize), SceneError> {
    if params.ambisonics {
        return Err(SceneError::Setting(
            "ambisonics are rendered offline; a live scene plays stereo or mono".into(),
        ));
    }
    if live.block == 0 || live.block > 1 << 16 {
        return Err(SceneError::Setting(format!(
            "device blocks must be 1–65536 samples, got {}",
            live.block
        )));
    }
    let (mut physics, mut sources) = ScenePhysics::new(bodies, params, live.block)?;
    let step = physics.step_span(0).1.max(1);
    let latency = live.latency_samples.unwrap_or(step);
    if latency > 10 * params.sample_rate_hz as usize {
        return Err(SceneError::Setting(format!(
            "a latency of {latency} samples is over 10 s"
        )));
    }
    physics.set_offset(latency as u64);
    sources.params.governor = live.governor;
    // The queues must hold what the physics sends while one block and the latency play.
    let ahead = (live.block + latency).div_ceil(step) + 2;
    sources.params.cue_capacity = (sources.params.cue_capacity * ahead).next_power_of_two();
    sources.params.sample_capacity *= ahead;
    let (tx, audio) = scene_audio(&sources.params, sources.sources)?;
    Ok((physics, tx, Driver::new(audio, live.block), latency))
}

/// Runs the physics on this thread until the scene ends or `stop` is set, at most one block
/// ahead of the audio clock `tx.rendered()`. `frontier` gets the end sample of the next step
/// not yet run (`u64::MAX` once done).
pub fn run_physics(
    physics: &mut ScenePhysics,
    tx: &mut CueSender,
    block: usize,
    frontier: &AtomicU64,
    stop: &AtomicBool,
) {
    let steps = physics.steps();
    while physics.steps_done() < steps && !stop.load(Ordering::Relaxed) {
        let next_end = physics.step_span(physics.steps_done()).1 as u64;
        frontier.store(next_end, Ordering::Release);
        if next_end <= tx.rendered() + block as u64 {
            physics.step(tx);
        } else {
            std::thread::sleep(Duration::from_micros(200));
        }
    }
    frontier.store(u64::MAX, Ordering::Release);
}

/// Runs a scene live against a simulated device (see the module docs) and returns what the
/// device would have played.
pub fn render_live(
    bodies: &[BodySpec],
    params: &SceneParams,
    live: &LiveParams,
) -> Result<LiveOutput, SceneError> {
    let (mut physics, mut tx, mut driver, latency) = live_scene(bodies, params, live)?;
    let total = physics.total_samples() + latency;
    let block = live.block;
    let blocks = total.div_ceil(block);
    let fs = params.sample_rate_hz;
    let deadline_s = block as f64 / fs;
    let stats = Arc::clone(driver.stats());
    let frontier = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let n_ch = driver.channels();
    let mut channels = vec![vec![0.0f32; blocks * block]; n_ch];
    let mut times = Vec::with_capacity(blocks);
    let mut max_degradation = 0;
    let physics_out = std::thread::scope(|s| {
        let handle = s.spawn(|| {
            run_physics(&mut physics, &mut tx, block, &frontier, &stop);
            physics
        });
        let t_start = Instant::now();
        for k in 0..blocks {
            let end = ((k + 1) * block) as u64;
            match live.pacing {
                Pacing::Lockstep => {
                    while frontier.load(Ordering::Acquire) <= end && !handle.is_finished() {
                        std::thread::yield_now();
                    }
                }
                Pacing::RealTime => {
                    let due = Duration::from_secs_f64(k as f64 * deadline_s);
                    let now = t_start.elapsed();
                    if due > now {
                        std::thread::sleep(due - now);
                    }
                }
            }
            let (lo, hi) = (k * block, (k + 1) * block);
            let t0 = Instant::now();
            match channels.as_mut_slice() {
                [a] => driver.process(&mut [&mut a[lo..hi]]),
                [a, b] => driver.process(&mut [&mut a[lo..hi], &mut b[lo..hi]]),
                _ => {}
            }
            let share = t0.elapsed().as_secs_f64() / deadline_s;
            if share > 1.0 {
                stats.xruns.fetch_add(1, Ordering::Relaxed);
            }
            max_degradation = max_degradation.max(AudioStats::get(&stats.degradation));
            times.push(share);
        }
        stop.store(true, Ordering::Relaxed);
        handle.join()
    });
    let physics =
        physics_out.map_err(|_| SceneError::Setting("the physics thread panicked".into()))?;
    for c in &mut channels {
        c.truncate(total);
    }
    let clock = resound_synth::live::ClockReport::from_shares(&times, block, fs);
    let report = LiveReport {
        block,
        latency_samples: latency,
        callbacks: AudioStats::get(&stats.callbacks),
        p50_share: clock.p50_share,
        p99_share: clock.p99_share,
        max_share: clock.max_share,
        xruns: AudioStats::get(&stats.xruns),
        late_steps: AudioStats::get(&stats.late_steps),
        dropped_cues: AudioStats::get(&stats.dropped),
        steals: AudioStats::get(&stats.steals),
        max_degradation,
    };
    let max_voices = AudioStats::get(&stats.max_sounding) as usize;
    let (events, mut scene_stats) = physics.finish();
    scene_stats.max_voices = max_voices;
    Ok(LiveOutput {
        channels,
        events,
        stats: scene_stats,
        report,
    })
}
