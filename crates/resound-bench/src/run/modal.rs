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
