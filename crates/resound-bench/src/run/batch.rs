//! `bench batch`: dataset generation through `resound batch`.

use super::*;

/// Runs `bench batch` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_batch_bench(a: BatchBenchArgs) -> Result<()> {
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
