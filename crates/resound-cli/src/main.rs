//! `resound`: physically based contact sound from the command line.
//!
//! The binary is argument parsing plus glue (ripgrep's split): every subcommand calls one
//! library function, prints text by default or JSON with `--json`, and exits 2 on error.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod analyze_cmd;
mod batch_cmd;
mod bench_cmd;
mod compare_cmd;
mod demo_cmd;
mod estimate_cmd;
mod grains_cmd;
mod mesh_cmd;
mod modal_cmd;
mod scene_cmd;
mod scrape_cmd;
mod stats_cmd;
mod studio_cmd;
mod synth_cmd;
mod util;

/// Resound: find the material behind a recorded strike and make any object of it sound right.
#[derive(Parser, Debug)]
#[command(
    name = "resound",
    version,
    about = "Resound: physically based contact sound. Find the material behind a recorded strike; make any object of it sound right.",
    propagate_version = true
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the whole pipeline on bundled data: estimate a material from a real recording, render a physics scene (demo-out/).
    Demo(demo_cmd::DemoArgs),
    /// Compute an object's vibration modes from a closed surface or tet mesh and a material (FEM + eigen-solve).
    Modal(modal_cmd::ModalArgs),
    /// Make, inspect and check meshes (primitives, repair report).
    #[command(subcommand)]
    Mesh(mesh_cmd::MeshCmd),
    /// Find the damped sinusoids (frequency, damping, amplitude, phase) of a recorded strike.
    Analyze(analyze_cmd::AnalyzeArgs),
    /// How far apart two strikes sound: multi-resolution log-mel distance after onset alignment and energy normalisation.
    Compare(compare_cmd::CompareArgs),
    /// Estimate a material (Rayleigh α, β, γ = E/ρ, σ) from a recorded strike, the object's mesh and the hit point.
    Estimate(estimate_cmd::EstimateArgs),
    /// List, show, import, export and remove materials in the material library (SQLite).
    Materials(estimate_cmd::MaterialsArgs),
    /// Render one strike of an object of a material (modes + residual), or analysed modes, to WAV.
    Synth(synth_cmd::SynthArgs),
    /// Render a physics scene (TOML: bodies, materials, listener) to WAV and an event log.
    Scene(scene_cmd::SceneArgs),
    /// Scrape a probe over a surface texture (Traer 2019 §4) on an object, to WAV.
    Scrape(scrape_cmd::ScrapeArgs),
    /// Render a jobs file (JSON lines: mesh × material × hits × speeds) to content-addressed files, one shard per process, resumable.
    Batch(batch_cmd::BatchArgs),
    /// Per-material mode statistics (Traer 2019): fit to recordings, import PyImpact tables.
    #[command(subcommand)]
    Stats(stats_cmd::StatsCmd),
    /// Grains (Picard 2009): cut recordings into grains and correlation patterns, rebuild or time-scale them.
    #[command(subcommand)]
    Grains(grains_cmd::GrainsCmd),
    /// Inspect a saved modal model, optionally rescaled to another material or at a hit point.
    Model(modal_cmd::ModelInfoArgs),
    /// Resound Studio: a local web app to analyse, estimate, audition and preview in a browser.
    Studio(studio_cmd::StudioArgs),
    /// Run the benchmarks and print their figures (table or JSON).
    #[command(subcommand)]
    Bench(bench_cmd::BenchCmd),
    /// One benchmark case in a fresh process (used by `bench` to measure peak memory).
    #[command(hide = true)]
    BenchCase(bench_cmd::CaseArgs),
}

/// `println!` panics when stdout is a closed pipe (`resound analyze x.wav | head -1`); like
/// ripgrep, a closed pipe is a normal way to stop reading, so that ends the process quietly
/// with exit 0. Every other panic keeps the default report.
fn quiet_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        // The hook info shows the payload ("… failed printing to stdout: Broken pipe").
        let message = info.to_string();
        if message.contains("Broken pipe") || message.contains("os error 32") {
            std::process::exit(0);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    quiet_on_broken_pipe();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(a) => demo_cmd::run(a),
        Command::Modal(a) => modal_cmd::run(a),
        Command::Mesh(c) => mesh_cmd::run(c),
        Command::Model(a) => modal_cmd::run_info(a),
        Command::Analyze(a) => analyze_cmd::run(a),
        Command::Compare(a) => compare_cmd::run(a),
        Command::Estimate(a) => estimate_cmd::run(a),
        Command::Materials(c) => estimate_cmd::run_materials(c),
        Command::Synth(a) => synth_cmd::run(a),
        Command::Scene(a) => scene_cmd::run(a),
        Command::Batch(a) => batch_cmd::run(a),
        Command::Stats(c) => stats_cmd::run(c),
        Command::Scrape(a) => scrape_cmd::run(a),
        Command::Grains(c) => grains_cmd::run(c),
        Command::Studio(a) => studio_cmd::run(a),
        Command::Bench(c) => bench_cmd::run(c),
        Command::BenchCase(a) => resound_bench::run::run_case(a.into()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) {
                return ExitCode::SUCCESS;
            }
            match advice(&e) {
                Some(Advice::Flag(flag)) => eprintln!("error: {flag}: {e:#}"),
                Some(Advice::Hint(a)) => eprintln!("error: {e:#}; {a}"),
                None => eprintln!("error: {e:#}"),
            }
            ExitCode::from(2)
        }
    }
}

/// What to do about a library error: the flag a parameter error is about, or a hint.
enum Advice {
    Flag(&'static str),
    Hint(String),
}

/// What to do about a library error, in this CLI's flags: the library names no flag, so the
/// advice for each of its error variants lives here (Python says the same with its keywords).
fn advice(e: &anyhow::Error) -> Option<Advice> {
    const FLAGS: [(&str, &str); 11] = [
        ("channel", "--channel"),
        ("strike", "--strike"),
        ("gain_db", "--gain-db"),
        ("max_duration_s", "--max-duration-s"),
        ("floor_db", "--floor-db"),
        ("max_freq_hz", "--max-freq-hz"),
        ("speed_m_s", "--velocity"),
        ("duration_s", "--duration"),
        ("sample_rate_hz", "--sample-rate"),
        ("impactor_radius_m", "--impactor-radius"),
        ("impactor_mass_kg", "--impactor-mass"),
    ];
    let root = e
        .chain()
        .find_map(|c| c.downcast_ref::<resound::Error>())?
        .root();
    if let resound::Error::Param { field, .. } = root {
        let (_, flag) = FLAGS.iter().find(|(f, _)| f == field)?;
        return Some(Advice::Flag(flag));
    }
    Some(Advice::Hint(match root {
        resound::Error::Exists(_) => "pass --force to replace it".into(),
        resound::Error::Model(resound::core::ModalModelError::PoissonMismatch { .. }) => {
            "or pass --keep-nu to take only its E/ρ".into()
        }
        resound::Error::Implausible(..) => "keep it anyway with --allow-implausible".into(),
        resound::Error::NoLiveAudio => "rebuild with `cargo build --release --features live`, \
            or render to a file"
            .into(),
        resound::Error::Analyze(resound::signal::AnalyzeError::SampleRate(_)) => {
            "pass --resample-hz 48000".into()
        }
        resound::Error::Device(_) => "see --sample-rate (synth) or --block (scene)".into(),
        r if r.is_no_convergence() => "ask for fewer modes (the highest converge last): \
            --modes N, or --mesh-modes N with synth"
            .into(),
        r if r.is_too_many_modes() => "if the file is not in metres pass --scale (0.001 for \
            millimetres), else lower --max-freq-hz, ask for --modes N or raise --max-modes"
            .into(),
        _ => return None,
    }))
}
