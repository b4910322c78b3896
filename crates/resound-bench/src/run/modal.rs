//! `bench modal`: modal analysis against faer's single-vector Lanczos.

use super::*;

/// `bench modal`: each case in a child process (`resound bench-case`), with the faer
/// baseline on cases up to `compare_up_to` DOFs.
pub fn run_modal(a: ModalBenchArgs) -> Result<()> {
    let exe = std::env::current_exe().context("locating the resound binary")?;
    if a.dofs.contains(&0) {
        bail!("--dofs: every count must be positive");
    }
    let dofs = a.dofs.clone();
    let peer_dir = tempfile::tempdir()?;
    let peer = if a.peer {
        peer_ready(peer_dir.path())?
    } else {
        None
    };
    let mut rows: Vec<ModalCase> = Vec::new();
    for mesh in a.meshes.split(',').map(str::trim) {
        for &d in &dofs {
            if !a.json {
                eprintln!("bench modal: {mesh} ~{d} DOFs, {} modes ...", a.modes);
            }
            let export = peer.as_ref().map(|_| peer_dir.path().join("matrices"));
            let mut v = run_child(&exe, mesh, d, a.modes, a.sturm, false, export.as_deref())?;
            if let (Some(script), Some(dir)) = (&peer, &export) {
                if !a.json {
                    eprintln!(
                        "bench modal: {mesh} ~{d} DOFs with the scipy peer on the same K, M ..."
                    );
                }
                v.peer = Some(run_peer(script, dir, &v)?);
                v.freqs_hz.clear();
                std::fs::remove_dir_all(dir)?;
            }
            if d <= a.compare_up_to {
                if !a.json {
                    eprintln!("bench modal: {mesh} ~{d} DOFs with faer's single-vector Lanczos (baseline) ...");
                }
                let base = run_child(&exe, mesh, d, a.modes, a.sturm, true, None)?;
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
        if rows.iter().any(|r| r.peer.is_some()) {
            println!(
                "\npeer on the same K, M (ratio: peer's factor + eigsh time over our whole run, assembly included):"
            );
            println!(
                "{:<5} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10}  solver",
                "mesh", "dofs", "ours_s", "peer_fac", "peer_s", "peer_MiB", "ratio", "max_df/f"
            );
            for r in &rows {
                let Some(p) = &r.peer else { continue };
                println!(
                    "{:<5} {:>8} {:>9.2} {:>9.2} {:>9.2} {:>9.0} {:>8.1}x {:>10.1e}  {}",
                    r.mesh,
                    r.dofs,
                    r.total_s,
                    p.factor_s,
                    p.total_s,
                    p.peak_rss_mib,
                    p.speedup,
                    p.max_rel_freq_diff,
                    p.solver
                );
            }
        }
    }
    Ok(())
}

/// The peer script, written into `dir`, when `python3` imports scipy; `None` (with a
/// message) when it does not.
fn peer_ready(dir: &std::path::Path) -> Result<Option<std::path::PathBuf>> {
    let ok = Command::new("python3")
        .args(["-c", "import scipy.sparse.linalg, scipy.io"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!(
            "bench modal: the peer needs python3 with scipy (pip install scipy; scikit-sparse for CHOLMOD): skipped"
        );
        return Ok(None);
    }
    let script = dir.join("modal_peer.py");
    std::fs::write(&script, PEER_SCRIPT)?;
    Ok(Some(script))
}

/// The peer's source, shipped in the binary.
const PEER_SCRIPT: &str = include_str!("../../peer/modal_peer.py");

/// Runs the peer on the matrices in `dir` for the elastic modes of `ours` (plus six rigid
/// ones, at our own shift) and compares the frequencies.
fn run_peer(script: &std::path::Path, dir: &std::path::Path, ours: &ModalCase) -> Result<PeerRow> {
    let rigid = 6;
    let f1 = ours
        .freqs_hz
        .first()
        .copied()
        .context("the case found no modes")?;
    let sigma = -(std::f64::consts::TAU * 0.1 * f1).powi(2);
    let out = Command::new("python3")
        .arg(script)
        .arg(dir)
        .arg((ours.freqs_hz.len() + rigid).to_string())
        .arg(sigma.to_string())
        .output()
        .context("running python3 for the peer")?;
    if !out.status.success() {
        bail!(
            "the scipy peer failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let mut p: PeerRow =
        serde_json::from_slice(&out.stdout).context("parsing the peer's output")?;
    let elastic = p.freqs_hz.get(rigid..).unwrap_or_default();
    if elastic.len() != ours.freqs_hz.len() {
        bail!(
            "the peer found {} elastic modes, ours {}",
            elastic.len(),
            ours.freqs_hz.len()
        );
    }
    p.max_rel_freq_diff = elastic
        .iter()
        .zip(&ours.freqs_hz)
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max);
    p.speedup = p.total_s / ours.total_s;
    Ok(p)
}
