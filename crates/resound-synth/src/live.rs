//! Live rendering: the physics side sends excitations through a lock-free queue to the audio
//! side, whose callback renders them with the allocation-free [`Engine`].
//!
//! - [`channel`] splits an [`Engine`] (with its objects attached beforehand) into a
//!   [`Frontend`] (any thread: physics, game loop) and a [`Backend`] (the audio callback). The
//!   queue is `rtrb`'s single-producer single-consumer ring: pushing and popping never lock,
//!   block or allocate.
//! - [`Backend::process`] is the callback: it takes every queued [`Event`], turns it into a
//!   force on its voice (a half-sine pulse for an impact, band-limited noise for rubbing), and
//!   renders the block. It never allocates, locks or blocks; events and dropped events are
//!   counted in atomics ([`LiveStats`]), shared with the frontend.
//! - [`SimulatedClock`] drives a backend at a device's block rate without a device and reports
//!   each callback's CPU time against the block's deadline (tests and `resound bench live`).
//!
//! Offline rendering of the same events through the same backend gives the same samples: the
//! frontend's events carry their delay within the next block, so timing does not depend on when
//! the callback runs.

use crate::engine::{Engine, VoiceId};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// An excitation, sent from the frontend to the backend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A strike: a half-sine force pulse carrying `impulse_n_s` over `contact_s`, starting
    /// `delay` samples into the next block.
    Impact {
        /// The struck object's voice.
        voice: VoiceId,
        /// Impulse, N·s.
        impulse_n_s: f32,
        /// Contact duration, s (at least one sample; at most [`MAX_PULSE_S`]).
        contact_s: f32,
        /// Samples into the next block.
        delay: u32,
    },
    /// Rolling or sliding over the next `samples`: a white-noise force of RMS `force_rms_n`
    /// (the surface's roughness, as in Traer 2019 scraping), starting `delay` samples in.
    Rub {
        /// The object's voice.
        voice: VoiceId,
        /// RMS force, N.
        force_rms_n: f32,
        /// Duration, samples (at most [`MAX_RUB_SAMPLES`]).
        samples: u32,
        /// Samples into the next block.
        delay: u32,
    },
}

/// Longest impact pulse the backend renders, s (longer contacts are shortened to it).
pub const MAX_PULSE_S: f32 = 0.01;
/// Longest rub one event renders, samples (send one event per block for a lasting contact).
pub const MAX_RUB_SAMPLES: usize = 4096;

/// Counters shared by the frontend and the backend (relaxed atomics: statistics only).
#[derive(Debug, Default)]
pub struct LiveStats {
    /// Callbacks run.
    pub callbacks: AtomicU64,
    /// Events applied.
    pub events: AtomicU64,
    /// Events the queue had no room for (the frontend counts them).
    pub dropped_events: AtomicU64,
    /// Events whose voice had gone or whose force did not fit.
    pub rejected_events: AtomicU64,
    /// Callbacks that took longer than their block lasts (the driver or the clock counts them).
    pub xruns: AtomicU64,
}

impl LiveStats {
    fn bump(counter: &AtomicU64) {
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// A snapshot: (callbacks, events, dropped, rejected, xruns).
    pub fn snapshot(&self) -> (u64, u64, u64, u64, u64) {
        (
            self.callbacks.load(Ordering::Relaxed),
            self.events.load(Ordering::Relaxed),
            self.dropped_events.load(Ordering::Relaxed),
            self.rejected_events.load(Ordering::Relaxed),
            self.xruns.load(Ordering::Relaxed),
        )
    }
}

/// The sending side (physics thread).
pub struct Frontend {
    tx: rtrb::Producer<Event>,
    stats: Arc<LiveStats>,
}

impl Frontend {
    /// Queues `event`; false (and counted as dropped) when the queue is full. Never blocks.
    pub fn send(&mut self, event: Event) -> bool {
        match self.tx.push(event) {
            Ok(()) => true,
            Err(_) => {
                LiveStats::bump(&self.stats.dropped_events);
                false
            }
        }
    }

    /// The shared counters.
    pub fn stats(&self) -> &Arc<LiveStats> {
        &self.stats
    }
}

/// The rendering side (audio callback).
pub struct Backend {
    engine: Engine,
    rx: rtrb::Consumer<Event>,
    stats: Arc<LiveStats>,
    pulse: Vec<f32>,
    rub: Vec<f32>,
    rng: u64,
}

/// Splits `engine` (objects attached) into a frontend and a backend joined by a queue of
/// `capacity` events.
pub fn channel(engine: Engine, capacity: usize) -> (Frontend, Backend) {
    let (tx, rx) = rtrb::RingBuffer::new(capacity.max(1));
    let stats = Arc::new(LiveStats::default());
    let fs = engine.params().sample_rate_hz;
    let pulse_len = ((f64::from(MAX_PULSE_S) * fs).ceil() as usize).max(1);
    (
        Frontend {
            tx,
            stats: Arc::clone(&stats),
        },
        Backend {
            engine,
            rx,
            stats,
            pulse: vec![0.0; pulse_len],
            rub: vec![0.0; MAX_RUB_SAMPLES],
            rng: 0x9E37_79B9_7F4A_7C15,
        },
    )
}

impl Backend {
    /// The audio callback: applies every queued event, then renders `out` (overwritten).
    /// Never allocates, locks or blocks.
    pub fn process(&mut self, out: &mut [f32]) {
        while let Ok(e) = self.rx.pop() {
            let ok = self.apply(e);
            LiveStats::bump(if ok {
                &self.stats.events
            } else {
                &self.stats.rejected_events
            });
        }
        out.fill(0.0);
        self.engine.process(out);
        LiveStats::bump(&self.stats.callbacks);
    }

    fn apply(&mut self, e: Event) -> bool {
        let fs = self.engine.params().sample_rate_hz;
        match e {
            Event::Impact {
                voice,
                impulse_n_s,
                contact_s,
                delay,
            } => {
                if !(impulse_n_s.is_finite() && contact_s.is_finite()) {
                    return false;
                }
                let n = ((f64::from(contact_s.clamp(0.0, MAX_PULSE_S)) * fs).round() as usize)
                    .clamp(1, self.pulse.len());
                let pulse = &mut self.pulse[..n];
                let mut sum = 0.0f64;
                for (i, p) in pulse.iter_mut().enumerate() {
                    let s = (std::f64::consts::PI * (i as f64 + 0.5) / n as f64).sin();
                    *p = s as f32;
                    sum += s;
                }
                // The engine's force samples are newtons (its resonators integrate over 1/fs).
                let scale = f64::from(impulse_n_s) * fs / sum;
                self.engine
                    .excite_scaled(voice, &self.pulse[..n], scale, delay as usize)
                    == n
            }
            Event::Rub {
                voice,
                force_rms_n,
                samples,
                delay,
            } => {
                if !force_rms_n.is_finite() {
                    return false;
                }
                let n = (samples as usize).min(self.rub.len());
                // Uniform white noise of unit RMS (xorshift: no allocation, no lock).
                let mut state = self.rng;
                for r in &mut self.rub[..n] {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    let u = (state >> 40) as f32 / (1u64 << 24) as f32;
                    *r = (u - 0.5) * 12f32.sqrt();
                }
                self.rng = state;
                self.engine.excite_scaled(
                    voice,
                    &self.rub[..n],
                    f64::from(force_rms_n),
                    delay as usize,
                ) == n
            }
        }
    }

    /// The engine (to inspect voices).
    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// The shared counters.
    pub fn stats(&self) -> &Arc<LiveStats> {
        &self.stats
    }
}

/// What [`SimulatedClock::run`] measured: each callback's CPU time as a share of its block's
/// deadline (`block / sample_rate`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ClockReport {
    /// Callbacks run.
    pub callbacks: usize,
    /// Block length, samples.
    pub block: usize,
    /// The deadline, s.
    pub deadline_s: f64,
    /// Median, 99th percentile and largest callback time over the deadline.
    pub p50_share: f64,
    /// See `p50_share`.
    pub p99_share: f64,
    /// See `p50_share`.
    pub max_share: f64,
    /// Callbacks over their deadline.
    pub misses: usize,
}

impl ClockReport {
    /// Summarises callback times given as shares of the deadline of `block` samples at
    /// `sample_rate_hz`.
    pub fn from_shares(shares: &[f64], block: usize, sample_rate_hz: f64) -> Self {
        let mut sorted = shares.to_vec();
        sorted.sort_by(f64::total_cmp);
        let q = |p: f64| {
            sorted
                .get(((sorted.len() as f64 - 1.0) * p).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        Self {
            callbacks: shares.len(),
            block,
            deadline_s: block as f64 / sample_rate_hz,
            p50_share: q(0.5),
            p99_share: q(0.99),
            max_share: sorted.last().copied().unwrap_or(0.0),
            misses: shares.iter().filter(|&&t| t > 1.0).count(),
        }
    }
}

/// A device stand-in: calls the backend block after block, as a driver would, and times it.
pub struct SimulatedClock {
    /// Samples per callback.
    pub block: usize,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
}

impl SimulatedClock {
    /// Runs `blocks` callbacks. Before each, `frontend(k)` runs (untimed: on a device it is
    /// another thread) to send that block's events; `sink(k, block)` receives the rendered
    /// samples. Deadline misses are counted in the backend's `xruns`.
    pub fn run(
        &self,
        backend: &mut Backend,
        blocks: usize,
        frontend: &mut dyn FnMut(usize),
        sink: &mut dyn FnMut(usize, &[f32]),
    ) -> ClockReport {
        let deadline_s = self.block as f64 / self.sample_rate_hz;
        let mut buf = vec![0.0f32; self.block];
        let mut times = Vec::with_capacity(blocks);
        for k in 0..blocks {
            frontend(k);
            let t0 = Instant::now();
            backend.process(&mut buf);
            let dt = t0.elapsed().as_secs_f64();
            if dt > deadline_s {
                LiveStats::bump(&backend.stats.xruns);
            }
            times.push(dt / deadline_s);
            sink(k, &buf);
        }
        ClockReport::from_shares(&times, self.block, self.sample_rate_hz)
    }
}
