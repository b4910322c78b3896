//! `resound bench …`: the benchmark runners and their tables. Modal cases run in a fresh child
//! process (`resound bench-case`) so peak memory (VmHWM) belongs to that case alone; scene cases
//! run `resound scene` likewise. Call these from the `resound` binary (they re-run it).

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use resound::core::Material;
use resound::fem::{discretize, primitive, SurfaceMesh};
use resound::modal::{EigenMethod, Geometry, ModalBuilder, ModalParams};
use serde::{Deserialize, Serialize};
use std::process::Command;

/// The bundled CC0 mesh (Keenan Crane's Spot), see assets/meshes/LICENSE-spot.md.
const SPOT_OBJ: &[u8] = include_bytes!("../../../assets/meshes/spot.obj");
/// Spot is in arbitrary units with a 1.7 long side: 0.15 makes it a 26 cm ceramic cow.
const SPOT_SCALE: f64 = 0.15;

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

fn bench_mesh(name: &str) -> Result<(SurfaceMesh, Material)> {
    Ok(match name {
        "bar" => (
            primitive::bar([0.3, 0.02, 0.01]),
            Material::preset("steel")?,
        ),
        "spot" => {
            let dir = tempfile_dir()?;
            let p = dir.join("spot.obj");
            std::fs::write(&p, SPOT_OBJ)?;
            let m = match resound::io::load_mesh(&p, SPOT_SCALE)? {
                resound::io::LoadedMesh::Surface(s) => s,
                resound::io::LoadedMesh::Tets(_) => bail!("spot is a surface"),
            };
            let _ = std::fs::remove_dir_all(&dir);
            (m, Material::preset("ceramic")?)
        }
        other => bail!("unknown benchmark mesh '{other}' (bar, spot)"),
    })
}

fn tempfile_dir() -> Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("resound-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}

fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Runs one case and prints one JSON line.
pub fn run_case(a: CaseArgs) -> Result<()> {
    let (mesh, material) = bench_mesh(&a.mesh)?;
    let (surface, _) = mesh.repaired(0)?;
    let resolution = discretize::resolution_for_dofs(&surface, a.target_dofs);
    let t0 = std::time::Instant::now();
    let vp = discretize::VoxelParams {
        resolution,
        ..Default::default()
    };
    let (fem, _) = discretize::discretize_surface(&surface, &material, &vp)?;
    let assemble_s = t0.elapsed().as_secs_f64();
    let method = if a.faer_lanczos {
        EigenMethod::Lanczos
    } else {
        EigenMethod::BlockLanczos
    };
    let p = ModalParams {
        method,
        n_modes: Some(a.modes),
        sturm_check: a.sturm,
        resolution,
        ..Default::default()
    };
    let solved = ModalBuilder::new(
        Geometry::Fem {
            fem: &fem,
            components: 1,
        },
        &material,
    )
    .params(p)
    .solve()?;
    let (model, info) = (solved.model, solved.info);
    let total_s = t0.elapsed().as_secs_f64();
    let v = ModalCase {
        mesh: a.mesh.clone(),
        method: if a.faer_lanczos {
            "faer-lanczos"
        } else {
            "block-lanczos"
        }
        .into(),
        material: material.name.clone(),
        target_dofs: a.target_dofs,
        resolution,
        dofs: info.dofs,
        elements: info.elements,
        nnz: info.eigen.nnz_k,
        nnz_factor: info.eigen.nnz_l,
        modes: model.n_modes(),
        assemble_s,
        factor_s: info.eigen.factor_s,
        eigen_s: info.eigen.eigen_s,
        sturm_s: info.eigen.sturm_s,
        total_s,
        operator_applications: info.eigen.applications,
        max_rel_residual: info.eigen.max_rel_residual,
        peak_rss_mib: peak_rss_mib(),
        f1_hz: model.freqs_hz().first().copied(),
        f_last_hz: model.freqs_hz().last().copied(),
        baseline_faer_lanczos_total_s: None,
        speedup_vs_faer_lanczos: None,
    };
    println!("{}", serde_json::to_string(&v)?);
    Ok(())
}

/// One modal case, as the child process prints it (one JSON line).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModalCase {
    /// bar or spot.
    pub mesh: String,
    /// block-lanczos or faer-lanczos.
    pub method: String,
    /// Material.
    pub material: String,
    /// DOFs aimed at.
    pub target_dofs: usize,
    /// Voxels along the longest side.
    pub resolution: usize,
    /// DOFs.
    pub dofs: usize,
    /// Elements.
    pub elements: usize,
    /// Nonzeros of K.
    pub nnz: usize,
    /// Nonzeros of the factor.
    pub nnz_factor: usize,
    /// Modes.
    pub modes: usize,
    /// Discretization and assembly, s.
    pub assemble_s: f64,
    /// Factorization, s.
    pub factor_s: f64,
    /// Lanczos, s.
    pub eigen_s: f64,
    /// Sturm check, s.
    pub sturm_s: f64,
    /// Everything, s.
    pub total_s: f64,
    /// Operator applications.
    pub operator_applications: usize,
    /// Largest true relative residual.
    pub max_rel_residual: f64,
    /// Peak resident memory of the case, MiB.
    pub peak_rss_mib: Option<f64>,
    /// First frequency, Hz.
    pub f1_hz: Option<f64>,
    /// Last frequency, Hz.
    pub f_last_hz: Option<f64>,
    /// The baseline's time on the same case, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline_faer_lanczos_total_s: Option<f64>,
    /// Baseline time over ours.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speedup_vs_faer_lanczos: Option<f64>,
}

fn run_child(
    exe: &std::path::Path,
    mesh: &str,
    dofs: usize,
    modes: usize,
    sturm: bool,
    faer: bool,
) -> Result<ModalCase> {
    let mut cmd = Command::new(exe);
    cmd.args([
        "bench-case",
        "--mesh",
        mesh,
        "--target-dofs",
        &dofs.to_string(),
        "--modes",
        &modes.to_string(),
    ]);
    if sturm {
        cmd.arg("--sturm");
    }
    if faer {
        cmd.arg("--faer-lanczos");
    }
    let out = cmd.output().context("running a benchmark case")?;
    if !out.status.success() {
        bail!(
            "benchmark case {mesh}/{dofs} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    serde_json::from_slice(&out.stdout).context("parsing a benchmark case")
}

/// Runs a benchmark.
pub fn run(c: BenchCmd) -> Result<()> {
    let a = match c {
        BenchCmd::Modal(a) => a,
        BenchCmd::Analyze(a) => return run_analyze(a),
        BenchCmd::Estimate(a) => return run_estimate(a),
        BenchCmd::Synth(a) => return run_synth(a),
        BenchCmd::Scene(a) => return run_scene(a),
        BenchCmd::Stats(a) => return run_stats(a),
        BenchCmd::Grains(a) => return run_grains(a),
        BenchCmd::Live(a) => return run_live(a),
        BenchCmd::Batch(a) => return run_batch_bench(a),
        BenchCmd::Radiation(a) => return run_radiation(a),
    };
    let exe = std::env::current_exe().context("locating the resound binary")?;
    if a.dofs.contains(&0) {
        bail!("--dofs: every count must be positive");
    }
    let dofs = a.dofs.clone();
    let mut rows: Vec<ModalCase> = Vec::new();
    for mesh in a.meshes.split(',').map(str::trim) {
        for &d in &dofs {
            if !a.json {
                eprintln!("bench modal: {mesh} ~{d} DOFs, {} modes ...", a.modes);
            }
            let mut v = run_child(&exe, mesh, d, a.modes, a.sturm, false)?;
            if d <= a.compare_up_to {
                if !a.json {
                    eprintln!("bench modal: {mesh} ~{d} DOFs with faer's single-vector Lanczos (baseline) ...");
                }
                let base = run_child(&exe, mesh, d, a.modes, a.sturm, true)?;
                v.baseline_faer_lanczos_total_s = Some(base.total_s);
                v.speedup_vs_faer_lanczos = Some(base.total_s / v.total_s);
            }
            rows.push(v);
        }
    }
    let cpu = std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("model name"))
            .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
    });
    #[derive(Serialize)]
    struct Targets {
        #[serde(rename = "30k_dofs_s")]
        dofs_30k_s: f64,
        #[serde(rename = "100k_dofs_s")]
        dofs_100k_s: f64,
        peak_mib: f64,
    }
    #[derive(Serialize)]
    struct Doc<'a> {
        benchmark: &'static str,
        threads: usize,
        cpu: Option<String>,
        targets: Targets,
        cases: &'a [ModalCase],
    }
    let doc = Doc {
        benchmark: "modal",
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        cpu,
        targets: Targets {
            dofs_30k_s: 5.0,
            dofs_100k_s: 30.0,
            peak_mib: 4096.0,
        },
        cases: &rows,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!(
            "{:<5} {:>8} {:>9} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}",
            "mesh",
            "dofs",
            "nnz",
            "nnz(L)",
            "factor_s",
            "eigen_s",
            "total_s",
            "peak_MiB",
            "f1_hz",
            "speedup"
        );
        for r in &rows {
            println!(
                "{:<5} {:>8} {:>9} {:>10} {:>9.2} {:>9.2} {:>9.2} {:>9.0} {:>9.1} {:>8.2}",
                r.mesh,
                r.dofs,
                r.nnz,
                r.nnz_factor,
                r.factor_s,
                r.eigen_s,
                r.total_s,
                r.peak_rss_mib.unwrap_or(f64::NAN),
                r.f1_hz.unwrap_or(f64::NAN),
                r.speedup_vs_faer_lanczos.unwrap_or(f64::NAN),
            );
        }
    }
    Ok(())
}

fn run_analyze(a: AnalyzeBenchArgs) -> Result<()> {
    use crate::analysis::{mixtures, single_sinusoids, wide};
    use resound::signal::AnalyzeParams;
    let parse = |list: &str| {
        list.split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .with_context(|| format!("bad SNR '{s}'"))
            })
            .collect::<Result<Vec<f64>>>()
    };
    let snrs = if a.wide_only {
        Vec::new()
    } else {
        parse(&a.snr_db)?
    };
    let wide_snrs = if a.wide == 0 {
        Vec::new()
    } else {
        parse(&a.wide_snr_db)?
    };
    let mut methods = vec![("refined", AnalyzeParams::default())];
    if !a.no_stage1 {
        methods.push((
            "stage1",
            AnalyzeParams {
                refine: false,
                ..AnalyzeParams::default()
            },
        ));
    }
    #[derive(Serialize)]
    struct Method {
        #[serde(skip_serializing_if = "Option::is_none")]
        single: Option<crate::analysis::SingleReport>,
        mixtures: Vec<crate::analysis::MixtureReport>,
        wide: Vec<crate::analysis::WideReport>,
        seconds_per_audio_second: f64,
    }
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        #[serde(skip_serializing_if = "Option::is_none")]
        refined: Option<Method>,
        #[serde(skip_serializing_if = "Option::is_none")]
        stage1: Option<Method>,
    }
    let mut out = Doc {
        benchmark: "analyze",
        refined: None,
        stage1: None,
    };
    for (name, params) in &methods {
        if !a.json {
            eprintln!("bench analyze [{name}]: {} single sinusoids ...", a.trials);
        }
        let single = (!a.wide_only).then(|| single_sinusoids(a.trials, a.seed, params));
        let mut mix = Vec::new();
        for &snr in &snrs {
            if !a.json {
                eprintln!(
                    "bench analyze [{name}]: {} mixtures at {snr} dB SNR ...",
                    a.mixtures
                );
            }
            mix.push(mixtures(snr, a.mixtures, a.seed + 1, params));
        }
        let mut wides = Vec::new();
        for &snr in &wide_snrs {
            if !a.json {
                eprintln!(
                    "bench analyze [{name}]: {} wide-range cases at {snr} dB SNR ...",
                    a.wide
                );
            }
            wides.push(wide(snr, a.wide, a.seed + 2, params));
        }
        let secs: f64 =
            mix.iter().map(|m| m.seconds_per_audio_second).sum::<f64>() / mix.len().max(1) as f64;
        if !a.json {
            if let Some(single) = &single {
                println!(
                    "[{name}] protocol 1 (Ren 2013, {} noise-free single modes, 44.1 kHz, 1 s):",
                    single.trials
                );
                println!(
                "  mean error f {:.2e} %  d {:.2e} %  (max {:.2e} %, {:.2e} %), missed {}, {:.3} s per s of audio",
                single.mean_freq_error_pct,
                single.mean_damping_error_pct,
                single.max_freq_error_pct,
                single.max_damping_error_pct,
                single.missed,
                single.seconds_per_audio_second
            );
                println!("[{name}] protocol 2 (mixtures of 1-24 modes, white noise):");
                println!(
                    "  {:>6} {:>7} {:>9} {:>11} {:>10} {:>12} {:>12} {:>10}",
                    "SNR_dB",
                    "modes",
                    "recall",
                    "recall(det)",
                    "spurious",
                    "f_err/CRB",
                    "d_err/CRB",
                    "s/s audio"
                );
                for m in &mix {
                    println!(
                        "  {:>6.0} {:>7} {:>9.3} {:>11.3} {:>10.3} {:>12.2} {:>12.2} {:>10.3}",
                        m.snr_db,
                        m.reference_modes,
                        m.recall,
                        m.recall_detectable,
                        m.spurious,
                        m.median_freq_error_over_crb,
                        m.median_damping_error_over_crb,
                        m.seconds_per_audio_second
                    );
                }
                println!("[{name}] mean analysis time per second of audio (mixtures): {secs:.3} s");
            }
            if !wides.is_empty() {
                println!("[{name}] protocol 4 (wide: 20 Hz-22 kHz, d 0.1-1000 1/s, doublets, noisy lead-in + DC, 48 kHz):");
                println!(
                    "  {:>6} {:>6} {:>7} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>7} {:>9}",
                    "SNR_dB",
                    "modes",
                    "recall",
                    "spurious",
                    "d>100",
                    "f<300",
                    "doublet",
                    "f/CRB",
                    "d/CRB",
                    "onset2ms",
                    "failed",
                    "s/s"
                );
                for w in &wides {
                    println!(
                        "  {:>6.0} {:>6} {:>7.3} {:>9.3} {:>8.3} {:>8.3} {:>8.3} {:>9.2} {:>9.2} {:>9.2} {:>7} {:>9.3}",
                        w.snr_db, w.reference_modes, w.recall, w.spurious, w.recall_damped, w.recall_low,
                        w.recall_doublet, w.median_freq_error_over_crb, w.median_damping_error_over_crb,
                        w.onset_within_2ms, w.failed, w.seconds_per_audio_second
                    );
                }
            }
        }
        let m = Some(Method {
            single,
            mixtures: mix,
            wide: wides,
            seconds_per_audio_second: secs,
        });
        if *name == "refined" {
            out.refined = m;
        } else {
            out.stage1 = m;
        }
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    }
    Ok(())
}

fn run_live(a: LiveBenchArgs) -> Result<()> {
    use crate::live::live_run;
    if a.block == 0 || a.block > 8192 || a.bodies == 0 || !(a.seconds > 0.0 && a.seconds <= 3600.0)
    {
        bail!("--block must be 1–8192, --bodies ≥ 1, --seconds in (0, 3600]");
    }
    // The backend runs on the calling thread: one core, as an audio thread has.
    let main = live_run(a.bodies, a.seconds, a.block).map_err(anyhow::Error::msg)?;
    let mut search = Vec::new();
    let mut n = a.bodies;
    let mut first_miss = None;
    while n <= a.max_bodies {
        let r = live_run(n, 5.0, a.block).map_err(anyhow::Error::msg)?;
        let missed = r.clock.misses > 0;
        if !a.json {
            eprintln!(
                "bench live: {n} bodies: p99 {:.3}, max {:.3} of the deadline, {} misses",
                r.clock.p99_share, r.clock.max_share, r.clock.misses
            );
        }
        search.push(r);
        if missed {
            first_miss = Some(n);
            break;
        }
        n *= 2;
    }
    // Bisect between the last clean count and the first miss, to an eighth.
    if let Some(miss) = first_miss {
        let (mut lo, mut hi) = (miss / 2, miss);
        while hi - lo > (lo / 8).max(1) && lo >= a.bodies {
            let mid = (lo + hi) / 2;
            let r = live_run(mid, 5.0, a.block).map_err(anyhow::Error::msg)?;
            if !a.json {
                eprintln!(
                    "bench live: {mid} bodies: p99 {:.3}, max {:.3} of the deadline, {} misses",
                    r.clock.p99_share, r.clock.max_share, r.clock.misses
                );
            }
            if r.clock.misses > 0 {
                hi = mid;
            } else {
                lo = mid;
            }
            search.push(r);
        }
        first_miss = Some(hi);
    }
    // Overload: twice the first miss, with and without the governor.
    let overload = match first_miss {
        Some(miss) => {
            let n = 2 * miss;
            let plain = live_run(n, 5.0, a.block).map_err(anyhow::Error::msg)?;
            let governed = crate::live::live_run_with(
                n,
                5.0,
                a.block,
                Some(resound::synth::scene_audio::Governor::default()),
            )
            .map_err(anyhow::Error::msg)?;
            Some((plain, governed))
        }
        None => None,
    };
    let bound = a.block + 200;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "benchmark": "live",
                "backend": "scene_audio",
                "sample_rate_hz": 48000,
                "block": a.block,
                "main": main,
                "search": search,
                "first_miss_bodies": first_miss,
                "overload": overload.as_ref().map(|(p, g)| serde_json::json!({"without_governor": p, "with_governor": g})),
                "contact_to_sound_latency_bound_samples": bound,
            }))?
        );
        return Ok(());
    }
    let c = &main.clock;
    println!(
        "{} bodies, {:.0} s at 48 kHz, {}-sample blocks ({:.2} ms deadline): callback p50 {:.3}, p99 {:.3}, max {:.3} of the deadline; {} misses; {} excitations, {} dropped, {} late steps",
        main.bodies, main.seconds, a.block, 1e3 * c.deadline_s, c.p50_share, c.p99_share, c.max_share, c.misses, main.events, main.dropped_events, main.late_steps
    );
    match first_miss {
        Some(n) => println!(
            "first deadline miss at {n} bodies (doubling from {}, then bisecting to an eighth)",
            a.bodies
        ),
        None if search.is_empty() => println!(
            "no search for the first miss: --max-bodies {} is below --bodies {}",
            a.max_bodies, a.bodies
        ),
        None => println!(
            "no deadline miss up to {} bodies",
            search.last().map_or(a.bodies, |r| r.bodies)
        ),
    }
    if let Some((p, g)) = &overload {
        println!(
            "overload ({} bodies, 5 s): without the governor {} misses (p99 {:.2}); with it {} misses (p99 {:.2}), level {}, {} voices stolen",
            p.bodies, p.clock.misses, p.clock.p99_share, g.clock.misses, g.clock.p99_share, g.degradation, g.steals
        );
    }
    match main.measured_latency_samples {
        Some(l) => println!(
            "contact-to-sound latency: {l} samples ({:.2} ms) measured on the output (bound: one block + one physics step = {bound} samples), plus the device's buffering",
            1e3 * l as f64 / 48_000.0
        ),
        None => println!("contact-to-sound latency: no sound to measure it on"),
    }
    Ok(())
}

fn run_estimate(a: EstimateBenchArgs) -> Result<()> {
    use crate::recovery::{recovery_case, recovery_case_between, table_cases};
    use resound::estimate::{ImageRoute, ModalSide};
    let (mesh, ceramic) = bench_mesh("spot")?;
    let side_at = |voxels: usize| -> Result<ModalSide> {
        let p = ModalParams {
            n_modes: Some(40),
            max_freq_hz: None,
            target_voxels: voxels,
            ..Default::default()
        };
        let model = ModalBuilder::surface(&mesh, &ceramic)
            .params(p)
            .solve()?
            .model;
        let sp = model.locate_hit([-0.0706, 0.1061, -0.0301], 0.02)?;
        Ok(ModalSide {
            eigenvalues0: model.eigenvalues.clone(),
            gains0: model.gains(&sp),
            gamma0: ceramic.stiffness_density_ratio(),
        })
    };
    let side = side_at(2500)?;
    let mut runs = vec![(None, ImageRoute::Auto), (Some(40.0), ImageRoute::Auto)];
    if !a.no_synthesized {
        runs.push((None, ImageRoute::Analytic));
        runs.push((None, ImageRoute::Synthesized));
    }
    let mut rows = Vec::new();
    for (name, truth) in table_cases() {
        for &(snr, route) in &runs {
            if !a.json {
                eprintln!("bench estimate: {name}, {route:?}, SNR {snr:?} ...");
            }
            let r = recovery_case(&side, name, truth, snr, route, 1).map_err(anyhow::Error::msg)?;
            if !a.json {
                println!(
                    "{:<13} {:<11} {:>6} err alpha {:.2e} beta {:.2e} gamma {:.2e} sigma {:.2e}  {:>3} starts {:>5} evals {:>6.2} s",
                    r.name,
                    r.route,
                    snr.map_or("clean".to_string(), |s| format!("{s} dB")),
                    r.rel_error[0],
                    r.rel_error[1],
                    r.rel_error[2],
                    r.rel_error[3],
                    r.starts,
                    r.evaluations,
                    r.elapsed_s
                );
            }
            rows.push(r);
        }
    }
    // The sound from a finer mesh of the same object, estimated on the coarse one.
    let fine_voxels = 12_000;
    let fine = side_at(fine_voxels)?;
    let mut bias_rows = Vec::new();
    for (name, truth) in table_cases() {
        let r = recovery_case_between(&fine, &side, name, truth, None, ImageRoute::Auto, 1)
            .map_err(anyhow::Error::msg)?;
        if !a.json {
            println!(
                "{:<13} sound from {fine_voxels} voxels, estimated on 2500: gamma bias {:+.2}%, err alpha {:.2e} beta {:.2e}  {:>6.2} s",
                r.name,
                100.0 * r.gamma_bias,
                r.rel_error[0],
                r.rel_error[1],
                r.elapsed_s
            );
        }
        bias_rows.push(r);
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&EstimateDoc {
                benchmark: "estimate",
                mesh: "spot (CC0), 0.15 scale, 40 modes, ~2500 voxels",
                cases: &rows,
                finer_source_voxels: fine_voxels,
                finer_source_cases: &bias_rows,
            })?
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct EstimateDoc<'a> {
    benchmark: &'static str,
    mesh: &'static str,
    cases: &'a [crate::recovery::RecoveryReport],
    finer_source_voxels: usize,
    finer_source_cases: &'a [crate::recovery::RecoveryReport],
}

/// `bench synth` figures.
#[derive(Serialize)]
struct SynthDoc {
    benchmark: &'static str,
    modes: usize,
    mode_samples_per_s: f64,
    modes_realtime_48k: f64,
    portable_modes_realtime_48k: f64,
    scalar_modes_realtime_48k: f64,
    ratio_vs_scalar: f64,
    residual_transfer_p50_ms: f64,
    residual_transfer_p99_ms: f64,
    residual_events: usize,
}

fn run_synth(a: SynthBenchArgs) -> Result<()> {
    use crate::throughput::{
        bank_mode_samples_per_s, residual_transfer_latencies_ms, scalar_loop_mode_samples_per_s,
    };
    if a.modes == 0 || !(a.seconds > 0.0) || a.events == 0 {
        bail!("--modes, --seconds and --events must be positive");
    }
    // Best of three runs each: the machine is shared; the best run is the least disturbed.
    let best = |f: &dyn Fn() -> f64| (0..3).map(|_| f()).fold(0.0, f64::max);
    let simd = best(&|| bank_mode_samples_per_s(a.modes, a.seconds, false));
    let portable = best(&|| bank_mode_samples_per_s(a.modes, a.seconds, true));
    let scalar = best(&|| scalar_loop_mode_samples_per_s(a.modes, a.seconds));
    let lat = residual_transfer_latencies_ms(a.events, 1);
    let pct = |q: f64| lat[((lat.len() - 1) as f64 * q).round() as usize];
    let v = SynthDoc {
        benchmark: "synth",
        modes: a.modes,
        mode_samples_per_s: simd,
        modes_realtime_48k: simd / 48_000.0,
        portable_modes_realtime_48k: portable / 48_000.0,
        scalar_modes_realtime_48k: scalar / 48_000.0,
        ratio_vs_scalar: simd / scalar,
        residual_transfer_p50_ms: pct(0.5),
        residual_transfer_p99_ms: pct(0.99),
        residual_events: a.events,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "bank ({} modes): {:.3e} mode-samples/s = {:.0} modes in real time at 48 kHz (portable path {:.0}; plain scalar loop {:.0}; ratio {:.1}x)",
            a.modes,
            simd,
            simd / 48_000.0,
            portable / 48_000.0,
            scalar / 48_000.0,
            simd / scalar
        );
        println!(
            "residual transfer (1 s, 10 fast Griffin-Lim iterations, {} events): p50 {:.2} ms, p99 {:.2} ms",
            a.events,
            pct(0.5),
            pct(0.99)
        );
    }
    Ok(())
}

/// A scene of `n` bodies dropped into a 1 m wooden box, physics at `steps_per_second`.
pub fn box_scene(n: usize, seconds: f64, steps_per_second: f64) -> String {
    let mut t = format!("duration = {seconds}\nseed = 3\nsteps_per_second = {steps_per_second}\n[listener]\nposition = [0.0, 0.5, 1.2]\n");
    let wall = |t: &mut String, name: &str, size: [f64; 3], pos: [f64; 3]| {
        t.push_str(&format!(
            "[[body]]\nname = \"{name}\"\nfixed = true\nshape = {{ box = [{}, {}, {}] }}\nmaterial = \"preset:wood\"\ndensity = 700\nposition = [{}, {}, {}]\nmodes = 24\n",
            size[0], size[1], size[2], pos[0], pos[1], pos[2]
        ));
    };
    wall(&mut t, "floor", [1.0, 0.04, 1.0], [0.0, -0.02, 0.0]);
    wall(&mut t, "wall-x0", [0.04, 0.4, 1.0], [-0.52, 0.2, 0.0]);
    wall(&mut t, "wall-x1", [0.04, 0.4, 1.0], [0.52, 0.2, 0.0]);
    wall(&mut t, "wall-z0", [1.0, 0.4, 0.04], [0.0, 0.2, -0.52]);
    wall(&mut t, "wall-z1", [1.0, 0.4, 0.04], [0.0, 0.2, 0.52]);
    let per_layer = 25;
    for i in 0..n {
        let layer = i / per_layer;
        let k = i % per_layer;
        let (x, z) = (-0.36 + 0.18 * (k % 5) as f64, -0.36 + 0.18 * (k / 5) as f64);
        let y = 0.15 + 0.12 * layer as f64;
        let (shape, material, density) = match i % 3 {
            0 => (
                format!("{{ sphere = {} }}", 0.02 + 0.005 * (i % 2) as f64),
                "preset:steel",
                7850,
            ),
            1 => (
                "{ box = [0.05, 0.03, 0.04] }".to_string(),
                "preset:ceramic",
                2400,
            ),
            _ => (
                "{ cylinder = [0.025, 0.06] }".to_string(),
                "preset:wood",
                700,
            ),
        };
        let v = [
            0.3 * ((i * 7 % 5) as f64 - 2.0) / 2.0,
            0.0,
            0.3 * ((i * 3 % 5) as f64 - 2.0) / 2.0,
        ];
        t.push_str(&format!(
            "[[body]]\nname = \"b{i}\"\nshape = {shape}\nmaterial = \"{material}\"\ndensity = {density}\nposition = [{x}, {y}, {z}]\nvelocity = [{}, 0.0, {}]\nrotation = [{}, {}, 0.0]\nmodes = 16\n",
            v[0], v[2], (i * 37 % 90) as f64, (i * 53 % 90) as f64
        ));
    }
    t
}

fn run_scene(a: SceneBenchArgs) -> Result<()> {
    let exe = std::env::current_exe().context("locating the resound binary")?;
    let tmp = tempfile::tempdir()?;
    let base = match &a.dir {
        Some(d) => {
            std::fs::create_dir_all(d)?;
            d.clone()
        }
        None => tmp.path().to_path_buf(),
    };
    let dir = &base;
    let counts = a.bodies.clone();
    if counts.is_empty() || counts.iter().any(|&c| c == 0 || c > 2000) || !(a.seconds > 0.0) {
        bail!("--bodies must list counts in 1..=2000 and --seconds must be > 0");
    }
    /// What `resound scene --json` prints.
    #[derive(Serialize, Deserialize)]
    struct SceneJson {
        output: String,
        #[serde(flatten)]
        summary: resound::scene::SceneSummary,
    }
    #[derive(Serialize)]
    struct Case {
        bodies: usize,
        summary: SceneJson,
    }
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        seconds: f64,
        steps_per_second: f64,
        #[serde(flatten)]
        realtime_factors: std::collections::BTreeMap<String, f64>,
        peak_rss_mb: f64,
        cases: Vec<Case>,
    }
    let mut realtime_factors = std::collections::BTreeMap::new();
    let mut cases = Vec::new();
    let mut peak = 0.0f64;
    for &n in &counts {
        let scene = dir.join(format!("box{n}.toml"));
        std::fs::write(&scene, box_scene(n, a.seconds, a.steps_per_second))?;
        if !a.json {
            eprintln!("bench scene: {n} bodies, {} s ...", a.seconds);
        }
        let o = Command::new(&exe)
            .args(["scene", "--json", "--library"])
            .arg(dir.join("lib.sqlite"))
            .arg("--cache")
            .arg(dir.join("cache"))
            .arg("-o")
            .arg(dir.join(format!("box{n}.wav")))
            .arg(&scene)
            .output()
            .context("running resound scene")?;
        if !o.status.success() {
            bail!(
                "scene with {n} bodies failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        let v: SceneJson =
            serde_json::from_slice(&o.stdout).context("parsing the scene summary")?;
        let s = &v.summary;
        let (rtf, rss) = (s.realtime_factor, s.peak_rss_mb);
        peak = peak.max(rss);
        realtime_factors.insert(format!("realtime_factor_{n}"), rtf);
        if !a.json {
            println!(
                "{n:>4} bodies: {rtf:>6.1}x real time (wall {:.2} s: physics {:.2} s beside sound {:.2} s, for {} s), {} impacts, {} voices at most, build {:.1} s, peak {rss:.0} MB",
                s.simulate_s,
                s.physics_s,
                s.audio_s,
                a.seconds,
                s.impacts,
                s.max_voices,
                s.build_s,
            );
        }
        cases.push(Case {
            bodies: n,
            summary: v,
        });
    }
    let out = Doc {
        benchmark: "scene",
        seconds: a.seconds,
        steps_per_second: a.steps_per_second,
        realtime_factors,
        peak_rss_mb: peak,
        cases,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    }
    Ok(())
}

/// The PyImpact metal_3 table (BSD-2-Clause; see tests/fixtures/pyimpact/README.md).
const METAL_3: &str = include_str!("../../resound-cli/tests/fixtures/pyimpact/metal_3_mm.json");

fn run_batch_bench(a: BatchBenchArgs) -> Result<()> {
    use resound::batch::BatchInfo;
    if a.meshes == 0 || a.hits == 0 {
        bail!("--meshes and --hits must be positive");
    }
    let exe = std::env::current_exe().context("locating the resound binary")?;
    let dir = tempfile::tempdir()?;
    let d = dir.path();
    let names = ["wood", "plastic", "metal", "glass", "porcelain"];
    let mut jobs = String::new();
    for m in 0..a.meshes {
        let (x, y, z) = (
            0.06 + 0.01 * m as f64,
            0.05 + 0.004 * (m % 7) as f64,
            0.03 + 0.003 * (m % 5) as f64,
        );
        let mesh = primitive::bar([x, y, z]);
        resound::io::save_surface(&d.join(format!("m{m}.obj")), &mesh)?;
        for h in 0..a.hits {
            // Points across the top face (z = z/2), away from its centre lines.
            let u = (h as f64 + 0.5) / a.hits as f64;
            let hit = [x * (0.45 * u - 0.2), y * (0.17 - 0.3 * u), z / 2.0];
            jobs.push_str(&serde_json::to_string(&serde_json::json!({
                "mesh": format!("m{m}.obj"),
                "material": names[(m + h) % names.len()],
                "hits": [hit],
                "modes": a.modes,
                "duration_s": a.duration_s,
            }))?);
            jobs.push('\n');
        }
    }
    std::fs::write(d.join("jobs.jsonl"), jobs)?;
    let n_jobs = a.meshes * a.hits;
    // Each worker gets its share of the cores for the modal solve's threads (as a cluster
    // recipe gives each task its CPUs), else two workers fight over every core.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let start = |out: &str, shard: &str, threads: usize| -> Result<std::process::Child> {
        Command::new(&exe)
            .args([
                "batch",
                "jobs.jsonl",
                "--out",
                out,
                "--shard",
                shard,
                "--json",
            ])
            .env("RAYON_NUM_THREADS", threads.to_string())
            .current_dir(d)
            .stdout(std::process::Stdio::piped())
            // Drained with stdout by wait_with_output; shown when a worker fails.
            .stderr(std::process::Stdio::piped())
            .spawn()
            .context("starting resound batch")
    };
    let finish = |c: std::process::Child| -> Result<BatchInfo> {
        let o = c.wait_with_output()?;
        let stderr = String::from_utf8_lossy(&o.stderr);
        let tail: String = {
            let lines: Vec<&str> = stderr.lines().collect();
            lines[lines.len().saturating_sub(20)..].join("\n")
        };
        let v: serde_json::Value = match serde_json::from_slice(&o.stdout) {
            Ok(v) => v,
            Err(e) => bail!(
                "resound batch ({}) printed no figures ({e}); its stderr:\n{tail}",
                o.status
            ),
        };
        let info = BatchInfo {
            rendered: v["rendered"].as_u64().unwrap_or(0) as usize,
            models_solved: v["models_solved"].as_u64().unwrap_or(0) as usize,
            first_output_s: v["first_output_s"].as_f64(),
            failures: Vec::new(),
            ..Default::default()
        };
        if !o.status.success() {
            bail!("resound batch failed ({}): {v}\n{tail}", o.status);
        }
        Ok(info)
    };
    if !a.json {
        eprintln!("bench batch: {n_jobs} jobs, 1 worker ...");
    }
    let t0 = std::time::Instant::now();
    let one = finish(start("one", "0/1", cores)?)?;
    let one_s = t0.elapsed().as_secs_f64();
    if !a.json {
        eprintln!("bench batch: {n_jobs} jobs, 2 workers ...");
    }
    let t1 = std::time::Instant::now();
    let half = (cores / 2).max(1);
    let (c0, c1) = (start("two", "0/2", half)?, start("two", "1/2", half)?);
    let (s0, s1) = (finish(c0)?, finish(c1)?);
    let two_s = t1.elapsed().as_secs_f64();
    if one.rendered != n_jobs || s0.rendered + s1.rendered != n_jobs {
        bail!(
            "rendered {} (1 worker) and {} + {} (2 workers) of {n_jobs} strikes",
            one.rendered,
            s0.rendered,
            s1.rendered
        );
    }
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        jobs: usize,
        meshes: usize,
        modes: usize,
        strike_s: f64,
        one_worker_s: f64,
        one_worker_jobs_per_min: f64,
        two_workers_s: f64,
        two_workers_jobs_per_min: f64,
        speedup: f64,
        first_output_s: Option<f64>,
        first_output_two_workers_s: Option<f64>,
        models_solved: usize,
        models_solved_two_workers: usize,
        shard_jobs_two_workers: [usize; 2],
        cores: usize,
    }
    let first2 = match (s0.first_output_s, s1.first_output_s) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let v = Doc {
        benchmark: "batch",
        jobs: n_jobs,
        meshes: a.meshes,
        modes: a.modes,
        strike_s: a.duration_s,
        one_worker_s: one_s,
        one_worker_jobs_per_min: 60.0 * n_jobs as f64 / one_s,
        two_workers_s: two_s,
        two_workers_jobs_per_min: 60.0 * n_jobs as f64 / two_s,
        speedup: one_s / two_s,
        first_output_s: one.first_output_s,
        first_output_two_workers_s: first2,
        models_solved: one.models_solved,
        models_solved_two_workers: s0.models_solved + s1.models_solved,
        shard_jobs_two_workers: [s0.rendered, s1.rendered],
        cores,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "{} jobs ({} meshes, {} modes, {} s strikes): 1 worker {:.1} s ({:.0} jobs/min), 2 workers {:.1} s ({:.0} jobs/min, {:.2}x; shards {} + {}); first output after {:.2} s; {} models solved",
            v.jobs, v.meshes, v.modes, v.strike_s, v.one_worker_s, v.one_worker_jobs_per_min,
            v.two_workers_s, v.two_workers_jobs_per_min, v.speedup,
            v.shard_jobs_two_workers[0], v.shard_jobs_two_workers[1],
            v.first_output_s.unwrap_or(f64::NAN), v.models_solved
        );
    }
    Ok(())
}

fn run_stats(a: StatsBenchArgs) -> Result<()> {
    use resound::synth::excitation::{ContactModel, Elastic, Impact};
    use resound::synth::render::{bank_modes, render_strike, REFERENCE_IMPULSE_N_S};
    use resound::synth::scrape::{scrape, scrape_force, ScrapeParams, Surface};
    let stats = resound::stats::ModeStatistics::from_pyimpact_json("metal_3", METAL_3)?;
    let fs = 44_100.0;
    let steel = Elastic {
        youngs_modulus: 200e9,
        poisson_ratio: 0.3,
    };
    let best = |f: &dyn Fn() -> Result<f64>| -> Result<f64> {
        let mut b = f64::INFINITY;
        for _ in 0..3 {
            b = b.min(f()?);
        }
        Ok(b)
    };
    let impacts = best(&|| {
        let t0 = std::time::Instant::now();
        let ir = stats.sample(1)?;
        let mut sink = 0.0f32;
        for k in 0..100u64 {
            let modes = resound::stats::perturb(&ir, k + 2);
            let mut bm = bank_modes(&modes);
            bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
            let imp = Impact {
                impactor_mass_kg: 0.01,
                impactor_radius_m: 0.005,
                impactor: steel,
                object: steel,
                object_mass_kg: None,
                speed_m_s: 0.5 + 0.01 * k as f64,
            };
            let f = imp.force_pulse(ContactModel::Hertz, fs, 0.0)?;
            let x = render_strike(&bm, &f, fs, 44_100)?;
            sink += x[100];
        }
        std::hint::black_box(sink);
        Ok(t0.elapsed().as_secs_f64())
    })?;
    // The same 100 impacts through the library call the Python package makes
    // (`resound.render_impact` → `render_strike(Struck::Stats)`): the baseline of the Python
    // call overhead (`crates/resound-py/bench/impacts.py`).
    let library = best(&|| {
        let t0 = std::time::Instant::now();
        let mut sink = 0.0f32;
        for k in 0..100u64 {
            let p = resound::strike::StrikeParams {
                speed_m_s: 0.5 + 0.01 * k as f64,
                impactor_mass_kg: Some(0.01),
                residual: false,
                duration_s: 1.0,
                sample_rate_hz: 44_100,
                ..Default::default()
            };
            let x = resound::strike::render_strike(
                resound::strike::Struck::Stats {
                    stats: &stats,
                    seed: k,
                },
                &p,
            )?;
            sink += x.samples[100];
        }
        std::hint::black_box(sink);
        Ok(t0.elapsed().as_secs_f64())
    })?;
    let scrape10 = best(&|| {
        let t0 = std::time::Instant::now();
        let surface = Surface::fractal(1 << 20, 1e-5, 2.0, 5e-6, 1)?;
        let n = 441_000;
        let x: Vec<f64> = (0..n).map(|i| 0.3 * i as f64 / fs).collect();
        let f = scrape_force(&surface, &x, fs, &ScrapeParams::default());
        let mut bm = bank_modes(&stats.sample(1)?);
        bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
        let y = scrape(&bm, &f, &x, fs, 8, 1)?;
        std::hint::black_box(&y);
        Ok(t0.elapsed().as_secs_f64())
    })?;
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        impacts100_s: f64,
        impacts100_render_strike_s: f64,
        scrape10s_s: f64,
        impact_audio_s: f64,
        modes: usize,
    }
    let v = Doc {
        benchmark: "stats",
        impacts100_s: impacts,
        impacts100_render_strike_s: library,
        scrape10s_s: scrape10,
        impact_audio_s: 1.0,
        modes: stats.modes,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "100 impacts (sample + Hertz pulse + 1 s render each, {} modes): {:.4} s ({:.4} s through render_strike, as Python calls it); 10 s scrape (8 location IRs): {:.3} s (best of 3)",
            stats.modes, impacts, library, scrape10
        );
    }
    Ok(())
}

/// Picard et al. 2009 §5.1: 94 recordings, 14.6 MB of 16-bit 44.1 kHz audio, 5171 grains;
/// MATLAB analysis 11 min (grains) + 4 h (patterns).
const PICARD_AUDIO_S: f64 = 14.6e6 / 2.0 / 44_100.0;
const PICARD_GRAINS: f64 = 5171.0;
const PICARD_MATLAB_S: f64 = 11.0 * 60.0 + 4.0 * 3600.0;

fn run_grains(a: GrainsBenchArgs) -> Result<()> {
    let root = match a.data {
        Some(d) => d,
        None => ["../shared/data/recordings", "/work/shared/data/recordings"]
            .iter()
            .map(std::path::PathBuf::from)
            .find(|p| p.is_dir())
            .context("no shared recordings found; pass --data DIR")?,
    };
    let mut files: Vec<String> = Vec::new();
    for (sub, ext) in [("spatialaudio-ramp", "wav"), ("minetest-game", "ogg")] {
        let mut f: Vec<String> = std::fs::read_dir(root.join(sub))
            .with_context(|| format!("reading {}", root.join(sub).display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == ext))
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        f.sort();
        files.extend(f);
    }
    let (recs, fs, file_bytes) = resound::grain_files::load_recordings(
        &files,
        resound::grain_files::KindRule::Auto,
        Some(44_100),
    )?;
    let audio_s: f64 = recs.iter().map(|r| r.samples.len() as f64 / fs).sum();
    let t0 = std::time::Instant::now();
    let (dict, info) = resound::grains::analyze(
        &recs,
        fs,
        &resound::grains::AnalyzeParams::default(),
        &|_, _| {},
    )?;
    let analysis_s = t0.elapsed().as_secs_f64();
    // Quality after the 16-bit round trip of the file.
    let bytes = resound::io::grains_file::encode(&dict);
    let saved = resound::io::grains_file::decode(&bytes, std::path::Path::new("bench.grains"))?;
    let summary = resound::grain_files::summary(&saved, Some(&recs))?;
    // The pruned dictionary (grains that others stand in for at correlation 0.8 dropped).
    let pruned = resound::grains::prune::prune(&dict, 0.8);
    let pruned_bytes = resound::io::grains_file::encode(&pruned);
    let pruned = resound::io::grains_file::decode(&pruned_bytes, std::path::Path::new("p.grains"))?;
    let pruned_summary = resound::grain_files::summary(&pruned, Some(&recs))?;
    let pruned_sc: Vec<f64> = pruned_summary
        .recordings
        .iter()
        .filter_map(|r| r.spectral_convergence_db)
        .collect();
    let scale = PICARD_AUDIO_S / audio_s;
    let scaled = (info.sms_s + info.grains_s) * scale
        + info.patterns_s * scale * (PICARD_GRAINS / dict.grains.len().max(1) as f64);
    let sc: Vec<f64> = summary
        .recordings
        .iter()
        .filter_map(|r| r.spectral_convergence_db)
        .collect();
    // Compression by kind of recording (own grains and peaks against mono 16-bit originals).
    let class_ratio = |continuous: bool| {
        let (mut orig, mut stored) = (0.0, 0.0);
        for r in &summary.recordings {
            if (r.contact != resound::grains::Contact::Impact) == continuous {
                let ratio = r.compression_ratio;
                let o = r.duration_s * fs * 2.0;
                orig += o;
                stored += o / ratio.max(1e-12);
            }
        }
        orig / stored.max(1e-12)
    };
    let median = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let median_sc = median(&sc);
    #[derive(Serialize)]
    struct Pruned {
        grains: usize,
        compression_ratio: f64,
        spectral_convergence_db_median: f64,
        spectral_convergence_db_worst: f64,
        per_recording_db: Vec<f64>,
    }
    #[derive(Serialize)]
    struct Doc<'a> {
        benchmark: &'static str,
        recordings: usize,
        audio_s: f64,
        analysis_s: f64,
        sms_s: f64,
        grains_s: f64,
        patterns_s: f64,
        pairs: usize,
        grains: usize,
        analysis_s_scaled_94: f64,
        analysis_s_scaled_94_linear: f64,
        picard_matlab_s: f64,
        compression_ratio: f64,
        compression_ratio_impulsive: f64,
        compression_ratio_continuous: f64,
        compression_ratio_vs_files: f64,
        file_bytes: usize,
        source_file_bytes: usize,
        spectral_convergence_db_worst: f64,
        spectral_convergence_db_median: f64,
        per_recording: &'a [resound::grain_files::RecordingSummary],
        pruned_0_8: Pruned,
    }
    let worst = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let v = Doc {
        benchmark: "grains",
        recordings: recs.len(),
        audio_s,
        analysis_s,
        sms_s: info.sms_s,
        grains_s: info.grains_s,
        patterns_s: info.patterns_s,
        pairs: info.pairs,
        grains: dict.grains.len(),
        analysis_s_scaled_94: scaled,
        analysis_s_scaled_94_linear: analysis_s * scale,
        picard_matlab_s: PICARD_MATLAB_S,
        compression_ratio: summary.compression_ratio,
        compression_ratio_impulsive: class_ratio(false),
        compression_ratio_continuous: class_ratio(true),
        compression_ratio_vs_files: file_bytes as f64 / bytes.len().max(1) as f64,
        file_bytes: bytes.len(),
        source_file_bytes: file_bytes,
        spectral_convergence_db_worst: worst(&sc),
        spectral_convergence_db_median: median_sc,
        per_recording: &summary.recordings,
        pruned_0_8: Pruned {
            grains: pruned.grains.len(),
            compression_ratio: pruned_summary.compression_ratio,
            spectral_convergence_db_median: median(&pruned_sc),
            spectral_convergence_db_worst: worst(&pruned_sc),
            per_recording_db: pruned_sc.clone(),
        },
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "{} recordings, {:.1} s of audio: analysis {:.2} s (SMS {:.2}, grains {:.2}, patterns {:.2}); {} grains; scaled to Picard's 94 recordings: {:.1} s (MATLAB: {:.0} s); compression {:.2}:1 (impulsive {:.2}:1, continuous {:.2}:1); rebuild spectral convergence median {:.1} dB, worst {:.1} dB",
            recs.len(),
            audio_s,
            analysis_s,
            info.sms_s,
            info.grains_s,
            info.patterns_s,
            dict.grains.len(),
            scaled,
            PICARD_MATLAB_S,
            v.compression_ratio,
            v.compression_ratio_impulsive,
            v.compression_ratio_continuous,
            v.spectral_convergence_db_median,
            v.spectral_convergence_db_worst,
        );
        let p = &v.pruned_0_8;
        println!(
            "pruned at correlation 0.8: {} grains, compression {:.2}:1, rebuild median {:.1} dB, worst {:.1} dB",
            p.grains, p.compression_ratio, p.spectral_convergence_db_median, p.spectral_convergence_db_worst,
        );
    }
    Ok(())
}

fn run_radiation(a: RadiationBenchArgs) -> Result<()> {
    use resound::core::radiation::FieldScratch;
    let (mesh, material) = bench_mesh("spot")?;
    let t0 = std::time::Instant::now();
    let solved = resound::modal::ModalBuilder::surface(&mesh, &material)
        .modes(a.modes)
        .solve()?;
    let solve_s = t0.elapsed().as_secs_f64();
    let rss_solve = peak_rss_mib();
    let mut model = solved.model;
    let t1 = std::time::Instant::now();
    let info = resound::radiation::add_transfer(
        &mut model,
        &resound::modal::TransferParams {
            max_sources: a.sources,
            ..Default::default()
        },
    )?;
    let fit_s = t1.elapsed().as_secs_f64();
    let rss_fit = peak_rss_mib();
    let t = model.transfer.as_ref().context("no transfer")?;
    let freqs = model.freqs_hz();
    // Run time: every mode's factor at 200 listener positions on a circle 1 m away.
    let mut scratch = FieldScratch::new(t.max_order());
    let positions: Vec<[f64; 3]> = (0..200)
        .map(|i| {
            let a = i as f64 * 0.0314;
            [a.cos(), 0.3, a.sin()]
        })
        .collect();
    let mut eval = f64::INFINITY;
    let mut one_by_one = f64::INFINITY;
    let mut batch = resound::core::radiation::BatchScratch::for_transfer(t);
    let mut out = vec![0.0; freqs.len()];
    let mut worst_rel = 0.0f64;
    for _ in 0..3 {
        let t2 = std::time::Instant::now();
        let mut sink = 0.0;
        for x in &positions {
            t.factors_into(&freqs, *x, &mut batch, &mut out);
            sink += out.iter().sum::<f64>();
        }
        std::hint::black_box(sink);
        eval = eval.min(t2.elapsed().as_secs_f64());
        let t3 = std::time::Instant::now();
        for x in &positions[..20] {
            for (j, &f) in freqs.iter().enumerate() {
                let one = t.factor(j, f, *x, &mut scratch).unwrap_or(0.0);
                sink += one;
            }
        }
        std::hint::black_box(sink);
        one_by_one = one_by_one.min(t3.elapsed().as_secs_f64() * positions.len() as f64 / 20.0);
    }
    // The batch and the one-mode path agree.
    for x in &positions[..5] {
        t.factors_into(&freqs, *x, &mut batch, &mut out);
        for (j, &f) in freqs.iter().enumerate() {
            let one = t.factor(j, f, *x, &mut scratch).unwrap_or(0.0);
            worst_rel = worst_rel.max((one - out[j]).abs() / one.abs().max(1e-300));
        }
    }
    if worst_rel > 1e-9 {
        bail!("batched radiation factors differ from the one-mode path by {worst_rel:e}");
    }
    let one_by_one_us = one_by_one / (positions.len() * freqs.len()) as f64 * 1e6;
    let per_mode_us = eval / (positions.len() * freqs.len()) as f64 * 1e6;
    // Baseline in the same run: the bank's cost of one mode for one 256-sample block.
    let rate = (0..3)
        .map(|_| crate::throughput::bank_mode_samples_per_s(64, 1.0, false))
        .fold(0.0, f64::max);
    let block_us = 256.0 / rate * 1e6;
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        modes: usize,
        surface_vertices: usize,
        solve_s: f64,
        transfer_fit_s: f64,
        transfer_bytes: usize,
        sources: usize,
        grid_points: usize,
        worst_misfit: f64,
        poorly_fitted: usize,
        peak_rss_after_solve_mib: Option<f64>,
        peak_rss_after_fit_mib: Option<f64>,
        factor_per_mode_us: f64,
        factor_one_mode_at_a_time_us: f64,
        bank_block256_per_mode_us: f64,
        factor_over_block: f64,
    }
    let v = Doc {
        benchmark: "radiation",
        modes: model.n_modes(),
        surface_vertices: model.n_vertices(),
        solve_s,
        transfer_fit_s: fit_s,
        transfer_bytes: info.bytes,
        sources: info.sources,
        grid_points: info.grid_points,
        worst_misfit: info.worst_residual,
        poorly_fitted: info.poorly_fitted,
        peak_rss_after_solve_mib: rss_solve,
        peak_rss_after_fit_mib: rss_fit,
        factor_per_mode_us: per_mode_us,
        factor_one_mode_at_a_time_us: one_by_one_us,
        bank_block256_per_mode_us: block_us,
        factor_over_block: per_mode_us / block_us,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "Spot, {} modes, {} vertices: solve {:.2} s; transfer fit {:.2} s ({} sources, {} grid frequencies, {:.1} MB of coefficients, worst misfit {:.2}, {} modes above 0.9); peak RSS {:.0} MiB after the solve, {:.0} MiB after the fit",
            v.modes, v.surface_vertices, solve_s, fit_s, v.sources, v.grid_points,
            v.transfer_bytes as f64 / 1e6, v.worst_misfit, v.poorly_fitted,
            rss_solve.unwrap_or(f64::NAN), rss_fit.unwrap_or(f64::NAN)
        );
        println!(
            "run time: {per_mode_us:.3} µs per mode per listener position (all modes at once; {one_by_one_us:.2} µs one mode at a time) = {:.2}× the bank's cost of rendering that mode for one 256-sample block ({block_us:.3} µs)",
            v.factor_over_block
        );
    }
    Ok(())
}
