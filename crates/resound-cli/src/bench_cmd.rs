//! `resound bench …` and the hidden `bench-case`: the flags of each benchmark; the runners and
//! their tables live in resound-bench.

use anyhow::Result;
use clap::{Args, Subcommand};
use resound_bench::run;

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

/// Arguments of `bench radiation`.
#[derive(Args, Debug)]
pub struct RadiationBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Modes.
    #[arg(long, default_value_t = 200)]
    pub modes: usize,
    /// Most equivalent sources of the fit.
    #[arg(long, default_value_t = 800)]
    pub sources: usize,
}

/// Arguments of `bench batch`.
#[derive(Args, Debug)]
pub struct BatchBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Meshes (boxes of different sizes).
    #[arg(long, default_value_t = 20)]
    pub meshes: usize,
    /// Hit points per mesh (one job each).
    #[arg(long, default_value_t = 10)]
    pub hits: usize,
    /// Modes per model.
    #[arg(long, default_value_t = 60)]
    pub modes: usize,
    /// Length of each strike, s.
    #[arg(long, default_value_t = 1.0)]
    pub duration_s: f64,
}

/// Arguments of `bench live`.
#[derive(Args, Debug)]
pub struct LiveBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Bodies of the main run.
    #[arg(long, default_value_t = 100)]
    pub bodies: usize,
    /// Seconds of the main run.
    #[arg(long, default_value_t = 60.0)]
    pub seconds: f64,
    /// Samples per callback.
    #[arg(long, default_value_t = 256)]
    pub block: usize,
    /// Largest body count tried when searching for the first deadline miss (doubling from
    /// `--bodies`, 5 s each).
    #[arg(long, default_value_t = 3200)]
    pub max_bodies: usize,
}

/// Arguments of `bench grains`.
#[derive(Args, Debug)]
pub struct GrainsBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// The shared recordings (with `spatialaudio-ramp/` and `minetest-game/`); default: the
    /// first of ../shared/data/recordings, /work/shared/data/recordings that exists.
    #[arg(long)]
    pub data: Option<std::path::PathBuf>,
}

/// Arguments of `bench stats`.
#[derive(Args, Debug)]
pub struct StatsBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `bench scene`.
#[derive(Args, Debug)]
pub struct SceneBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Body counts.
    #[arg(long, default_value = "10,100", value_delimiter = ',')]
    pub bodies: Vec<usize>,
    /// Seconds of audio.
    #[arg(long, default_value_t = 10.0)]
    pub seconds: f64,
    /// Keep the scene files, library, cache and WAVs in this directory (default: a temporary one).
    #[arg(long)]
    pub dir: Option<std::path::PathBuf>,
    /// Physics steps per second (the scene files' default).
    #[arg(long, default_value_t = 240.0)]
    pub steps_per_second: f64,
}

/// Arguments of `bench synth`.
#[derive(Args, Debug)]
pub struct SynthBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Modes in the bank.
    #[arg(long, default_value_t = 4096)]
    pub modes: usize,
    /// Seconds of audio rendered per measurement.
    #[arg(long, default_value_t = 2.0)]
    pub seconds: f64,
    /// Residual transfer events.
    #[arg(long, default_value_t = 200)]
    pub events: usize,
}

/// Arguments of `bench estimate`.
#[derive(Args, Debug)]
pub struct EstimateBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Skip the closed-form / synthesize+STFT comparison rows.
    #[arg(long)]
    pub no_synthesized: bool,
}

/// Arguments of `bench analyze`.
#[derive(Args, Debug)]
pub struct AnalyzeBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Single damped sinusoids (protocol 1).
    #[arg(long, default_value_t = 100)]
    pub trials: usize,
    /// Mixtures per SNR (protocol 2).
    #[arg(long, default_value_t = 40)]
    pub mixtures: usize,
    /// SNRs of protocol 2, dB.
    #[arg(long, default_value = "60,40,25")]
    pub snr_db: String,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Skip the stage-1-only (Ren 2013 alone) comparison rows.
    #[arg(long)]
    pub no_stage1: bool,
    /// Cases per SNR of the wide protocol (4): 20 Hz–22 kHz, d 0.1–1000 1/s, doublets, a noisy
    /// lead-in with a DC offset (0: skip).
    #[arg(long, default_value_t = 40)]
    pub wide: usize,
    /// SNRs of the wide protocol, dB.
    #[arg(long, default_value = "100,60,40,25")]
    pub wide_snr_db: String,
    /// Run only the wide protocol.
    #[arg(long)]
    pub wide_only: bool,
}

/// Arguments of `bench modal`.
#[derive(Args, Debug)]
pub struct ModalBenchArgs {
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Target DOF counts.
    #[arg(long, default_value = "10000,30000,100000", value_delimiter = ',')]
    pub dofs: Vec<usize>,
    /// Elastic modes per solve.
    #[arg(long, default_value_t = 200)]
    pub modes: usize,
    /// Meshes: bar, spot.
    #[arg(long, default_value = "bar,spot")]
    pub meshes: String,
    /// Also certify the count with a Sturm check (one more factorization).
    #[arg(long)]
    pub sturm: bool,
    /// Also run faer's single-vector Lanczos (the baseline) on cases up to this many DOFs and
    /// report the speed-up ratio measured in the same run (0: off).
    #[arg(long, default_value_t = 0)]
    pub compare_up_to: usize,
}

/// One case (hidden subcommand).
#[derive(Args, Debug)]
pub struct CaseArgs {
    /// bar or spot.
    #[arg(long)]
    pub mesh: String,
    /// Target DOFs.
    #[arg(long)]
    pub target_dofs: usize,
    /// Elastic modes.
    #[arg(long)]
    pub modes: usize,
    /// Sturm check.
    #[arg(long)]
    pub sturm: bool,
    /// Use faer's single-vector Lanczos instead of block Lanczos.
    #[arg(long)]
    pub faer_lanczos: bool,
}

impl From<RadiationBenchArgs> for run::RadiationBenchArgs {
    fn from(a: RadiationBenchArgs) -> Self {
        Self {
            json: a.json,
            modes: a.modes,
            sources: a.sources,
        }
    }
}

impl From<BatchBenchArgs> for run::BatchBenchArgs {
    fn from(a: BatchBenchArgs) -> Self {
        Self {
            json: a.json,
            meshes: a.meshes,
            hits: a.hits,
            modes: a.modes,
            duration_s: a.duration_s,
        }
    }
}

impl From<LiveBenchArgs> for run::LiveBenchArgs {
    fn from(a: LiveBenchArgs) -> Self {
        Self {
            json: a.json,
            bodies: a.bodies,
            seconds: a.seconds,
            block: a.block,
            max_bodies: a.max_bodies,
        }
    }
}

impl From<GrainsBenchArgs> for run::GrainsBenchArgs {
    fn from(a: GrainsBenchArgs) -> Self {
        Self {
            json: a.json,
            data: a.data,
        }
    }
}

impl From<StatsBenchArgs> for run::StatsBenchArgs {
    fn from(a: StatsBenchArgs) -> Self {
        Self { json: a.json }
    }
}

impl From<SceneBenchArgs> for run::SceneBenchArgs {
    fn from(a: SceneBenchArgs) -> Self {
        Self {
            json: a.json,
            bodies: a.bodies,
            seconds: a.seconds,
            dir: a.dir,
            steps_per_second: a.steps_per_second,
        }
    }
}

impl From<SynthBenchArgs> for run::SynthBenchArgs {
    fn from(a: SynthBenchArgs) -> Self {
        Self {
            json: a.json,
            modes: a.modes,
            seconds: a.seconds,
            events: a.events,
        }
    }
}

impl From<EstimateBenchArgs> for run::EstimateBenchArgs {
    fn from(a: EstimateBenchArgs) -> Self {
        Self {
            json: a.json,
            no_synthesized: a.no_synthesized,
        }
    }
}

impl From<AnalyzeBenchArgs> for run::AnalyzeBenchArgs {
    fn from(a: AnalyzeBenchArgs) -> Self {
        Self {
            json: a.json,
            trials: a.trials,
            mixtures: a.mixtures,
            snr_db: a.snr_db,
            seed: a.seed,
            no_stage1: a.no_stage1,
            wide: a.wide,
            wide_snr_db: a.wide_snr_db,
            wide_only: a.wide_only,
        }
    }
}

impl From<ModalBenchArgs> for run::ModalBenchArgs {
    fn from(a: ModalBenchArgs) -> Self {
        Self {
            json: a.json,
            dofs: a.dofs,
            modes: a.modes,
            meshes: a.meshes,
            sturm: a.sturm,
            compare_up_to: a.compare_up_to,
        }
    }
}

impl From<CaseArgs> for run::CaseArgs {
    fn from(a: CaseArgs) -> Self {
        Self {
            mesh: a.mesh,
            target_dofs: a.target_dofs,
            modes: a.modes,
            sturm: a.sturm,
            faer_lanczos: a.faer_lanczos,
        }
    }
}

/// Runs a benchmark.
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
