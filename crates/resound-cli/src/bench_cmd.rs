//! `resound bench …` and the hidden `bench-case`: the flags of each benchmark; the runners and
//! their tables live in resound-bench.

use anyhow::Result;
use clap::{Args, Subcommand};
use resound_bench::run;

/// Declares a benchmark's flags once: the clap struct here (every field a `--long` flag) and
/// its conversion into the runner's plain arguments of the same name in resound-bench
/// (`run::…`).
macro_rules! bench_args {
    ($(#[$m:meta])* $name:ident { $($(#[$fm:meta])* $f:ident: $t:ty,)* }) => {
        $(#[$m])*
        #[derive(Args, Debug)]
        pub struct $name { $($(#[$fm])* #[arg(long)] pub $f: $t,)* }
        impl From<$name> for run::$name {
            fn from(a: $name) -> Self {
                Self { $($f: a.$f,)* }
            }
        }
    };
}

/// Benchmarks.
#[derive(Subcommand, Debug)]
pub enum BenchCmd {
    /// Modal analysis: the steel bar and the Spot mesh at ~10k, ~30k, ~100k DOFs, 200 modes.
    Modal(ModalBenchArgs),
    /// Recording analysis: Ren's 100-sinusoid protocol, noisy mixtures against the Cramér–Rao
    /// bound, time per second of audio; stage 1 alone (Ren's method) for comparison.
    Analyze(AnalyzeBenchArgs),
    /// Material estimation: Ren's Fig. 9 protocol on Spot (three Table I-like materials,
    /// noise-free and 40 dB) with the default (auto) image route, and noise-free with the
    /// closed-form and the straightforward synthesize+STFT image each.
    Estimate(EstimateBenchArgs),
    /// Synthesis: resonator-bank throughput (modes one core sustains in real time at 48 kHz)
    /// against a plain scalar loop, and residual transfer latency (1 s residual, 10 fast
    /// Griffin–Lim iterations).
    Synth(SynthBenchArgs),
    /// Scenes: 10 and 100 bodies (steel balls, ceramic boxes, wooden cylinders) dropped into a
    /// wooden box, 10 s of stereo audio: real-time factor of physics + sound, peak memory,
    /// voices alive. Each case runs `resound scene` in a child process.
    Scene(SceneBenchArgs),
    /// Statistical model: sample and render 100 impacts (1 s each, 44.1 kHz) from the PyImpact
    /// metal_3 table, and a 10 s scrape over a fractal surface (8 location IRs).
    Stats(StatsBenchArgs),
    /// Grains (Picard 2009): analyse the ramp rolling/sliding recordings and the game hit sounds
    /// of shared/data (grains + patterns), compression and rebuild quality, time scaled to
    /// Picard's 94 recordings / 14.6 MB.
    Grains(GrainsBenchArgs),
    /// Live: the backend on a simulated 48 kHz clock (256-sample blocks, one core): bodies of
    /// 40 modes struck every 50 ms (a quarter also rolling) — callback time against the
    /// deadline at `--bodies`, misses over `--seconds`, and the bodies at the first miss.
    Live(LiveBenchArgs),
    /// Dataset generation: a jobs file of `--meshes` boxes × `--hits` hit points (one job
    /// each, built-in materials in turn) through `resound batch`, as 1 and as 2 local worker
    /// processes (`--shard i/2`): jobs per minute, time to the first output, models solved.
    Batch(BatchBenchArgs),
    /// Acoustic transfer: Spot (26 cm ceramic) with 200 modes — the modal solve and the transfer
    /// fit (time, coefficient bytes, peak memory), then the run-time cost of one mode's radiation
    /// factor at a moving listener, against rendering that mode for one 256-sample block.
    Radiation(RadiationBenchArgs),
}

bench_args! {
    /// Arguments of `bench radiation`.
    RadiationBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Modes.
        #[arg(default_value_t = 200)]
        modes: usize,
        /// Most equivalent sources of the fit.
        #[arg(default_value_t = 800)]
        sources: usize,
    }
}

bench_args! {
    /// Arguments of `bench batch`.
    BatchBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Meshes (boxes of different sizes).
        #[arg(default_value_t = 20)]
        meshes: usize,
        /// Hit points per mesh (one job each).
        #[arg(default_value_t = 10)]
        hits: usize,
        /// Modes per model.
        #[arg(default_value_t = 60)]
        modes: usize,
        /// Length of each strike, s.
        #[arg(default_value_t = 1.0)]
        duration_s: f64,
    }
}

bench_args! {
    /// Arguments of `bench live`.
    LiveBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Bodies of the main run.
        #[arg(default_value_t = 100)]
        bodies: usize,
        /// Seconds of the main run.
        #[arg(default_value_t = 60.0)]
        seconds: f64,
        /// Samples per callback.
        #[arg(default_value_t = 256)]
        block: usize,
        /// Largest body count tried when searching for the first deadline miss (doubling from
        /// `--bodies`, 5 s each).
        #[arg(default_value_t = 3200)]
        max_bodies: usize,
    }
}

bench_args! {
    /// Arguments of `bench grains`.
    GrainsBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// The shared recordings (with `spatialaudio-ramp/` and `minetest-game/`); default: the
        /// first of ../shared/data/recordings, /work/shared/data/recordings that exists.
        data: Option<std::path::PathBuf>,
    }
}

bench_args! {
    /// Arguments of `bench stats`.
    StatsBenchArgs {
        /// JSON on stdout.
        json: bool,
    }
}

bench_args! {
    /// Arguments of `bench scene`.
    SceneBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Body counts.
        #[arg(default_value = "10,100", value_delimiter = ',')]
        bodies: Vec<usize>,
        /// Seconds of audio.
        #[arg(default_value_t = 10.0)]
        seconds: f64,
        /// Keep the scene files, library, cache and WAVs in this directory (default: a temporary one).
        dir: Option<std::path::PathBuf>,
        /// Physics steps per second (the scene files' default).
        #[arg(default_value_t = 240.0)]
        steps_per_second: f64,
    }
}

bench_args! {
    /// Arguments of `bench synth`.
    SynthBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Modes in the bank.
        #[arg(default_value_t = 4096)]
        modes: usize,
        /// Seconds of audio rendered per measurement.
        #[arg(default_value_t = 2.0)]
        seconds: f64,
        /// Residual transfer events.
        #[arg(default_value_t = 200)]
        events: usize,
    }
}

bench_args! {
    /// Arguments of `bench estimate`.
    EstimateBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Skip the closed-form / synthesize+STFT comparison rows.
        no_synthesized: bool,
    }
}

bench_args! {
    /// Arguments of `bench analyze`.
    AnalyzeBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Single damped sinusoids (protocol 1).
        #[arg(default_value_t = 100)]
        trials: usize,
        /// Mixtures per SNR (protocol 2).
        #[arg(default_value_t = 40)]
        mixtures: usize,
        /// SNRs of protocol 2, dB.
        #[arg(default_value = "60,40,25")]
        snr_db: String,
        /// Random seed.
        #[arg(default_value_t = 1)]
        seed: u64,
        /// Skip the stage-1-only (Ren 2013 alone) comparison rows.
        no_stage1: bool,
        /// Cases per SNR of the wide protocol (4): 20 Hz–22 kHz, d 0.1–1000 1/s, doublets, a noisy
        /// lead-in with a DC offset (0: skip).
        #[arg(default_value_t = 40)]
        wide: usize,
        /// SNRs of the wide protocol, dB.
        #[arg(default_value = "100,60,40,25")]
        wide_snr_db: String,
        /// Run only the wide protocol.
        wide_only: bool,
        /// Skip the textbook ESPRIT baseline rows of the wide protocol.
        no_baseline: bool,
    }
}

bench_args! {
    /// Arguments of `bench modal`.
    ModalBenchArgs {
        /// JSON on stdout.
        json: bool,
        /// Target DOF counts.
        #[arg(default_value = "10000,30000,100000", value_delimiter = ',')]
        dofs: Vec<usize>,
        /// Elastic modes per solve.
        #[arg(default_value_t = 200)]
        modes: usize,
        /// Meshes: bar, spot.
        #[arg(default_value = "bar,spot")]
        meshes: String,
        /// Also certify the count with a Sturm check (one more factorization).
        sturm: bool,
        /// Also run faer's single-vector Lanczos (the baseline) on cases up to this many DOFs and
        /// report the speed-up ratio measured in the same run (0: off).
        #[arg(default_value_t = 0)]
        compare_up_to: usize,
        /// Also solve each case's K, M with scipy's eigsh in shift-invert mode (CHOLMOD from
        /// scikit-sparse when installed, else SuperLU) in the same run: time, memory, ratio
        /// and frequency agreement. Needs python3 with scipy.
        peer: bool,
    }
}

bench_args! {
    /// One case (hidden subcommand).
    CaseArgs {
        /// bar or spot.
        mesh: String,
        /// Target DOFs.
        target_dofs: usize,
        /// Elastic modes.
        modes: usize,
        /// Sturm check.
        sturm: bool,
        /// Use faer's single-vector Lanczos instead of block Lanczos.
        faer_lanczos: bool,
        /// After the solve, write K.mtx and M.mtx into this folder and list every frequency.
        export: Option<std::path::PathBuf>,
    }
}

pub fn run(c: BenchCmd) -> Result<()> {
    match c {
        BenchCmd::Modal(a) => run::run_modal(a.into()),
        BenchCmd::Analyze(a) => run::run_analyze(a.into()),
        BenchCmd::Estimate(a) => run::run_estimate(a.into()),
        BenchCmd::Synth(a) => run::run_synth(a.into()),
        BenchCmd::Scene(a) => run::run_scene(a.into()),
        BenchCmd::Stats(a) => run::run_stats(a.into()),
        BenchCmd::Grains(a) => run::run_grains(a.into()),
        BenchCmd::Live(a) => run::run_live(a.into()),
        BenchCmd::Batch(a) => run::run_batch_bench(a.into()),
        BenchCmd::Radiation(a) => run::run_radiation(a.into()),
    }
}
