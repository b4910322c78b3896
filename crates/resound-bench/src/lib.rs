//! Resound's benchmarks, out of the numeric libraries: what `resound bench …` runs.
//!
//! - [`analysis`]: Ren 2013's analysis protocol and noisy mixtures against the Cramér–Rao bound.
//! - [`esprit`]: a textbook ESPRIT, the baseline row of the wide protocol.
//! - [`live`]: the live backend on a simulated audio clock.
//! - [`recovery`]: Ren's Fig. 9 material-recovery protocol.
//! - [`throughput`]: resonator-bank throughput and residual-transfer latency.
//! - [`run`]: the `bench` subcommands (modal, analyze, estimate, synth, scene, stats, grains)
//!   with their tables and JSON.
//!
//! Speed is measured here, never asserted in tests (the machine is shared and noisy).
#![warn(missing_docs)]

pub mod analysis;
pub mod esprit;
pub mod live;
pub mod recovery;
pub mod run;
pub mod throughput;
