//! `resound batch`: sharding, resuming, failures by line, and the cluster recipes run as local
//! processes.
#![allow(clippy::unwrap_used)]

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_resound")
}

fn resound(args: &[&str], dir: &Path) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(dir)
        .env("RESOUND_LIBRARY", dir.join(".test-library.sqlite"))
        .env("XDG_CACHE_HOME", dir.join(".test-cache"))
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Three small meshes in `dir`.
fn meshes(dir: &Path) {
    for (kind, size, file) in [
        ("plate", "0.2,0.15,0.004", "plate.obj"),
        ("bar", "0.3,0.02,0.02", "bar.obj"),
        ("box", "0.08,0.06,0.05", "box.obj"),
    ] {
        ok(&resound(
            &["mesh", "primitive", kind, "--size", size, "-o", file],
            dir,
        ));
    }
}

/// Eight jobs over the three meshes: materials, hit points, speeds, a listener, both outputs,
/// and one strike listed twice.
const JOBS: &str = r#"# a comment, then a blank line

{"name":"plate-wood","mesh":"plate.obj","material":"wood","hits":[[0.05,0.03,0.002],[0.0,0.0,0.002]],"speeds_m_s":[0.5,2],"modes":16,"duration_s":0.3}
{"name":"plate-metal","mesh":"plate.obj","material":"metal","hits":[[0.05,0.03,0.002]],"modes":16,"duration_s":0.3,"outputs":["wav","json"]}
{"name":"bar-glass","mesh":"bar.obj","material":"glass","hits":[[0.1,0,0.01]],"modes":16,"duration_s":0.3,"listener":[0,0,1]}
{"name":"bar-wood","mesh":"bar.obj","material":"wood","hits":[[0.1,0,0.01],[-0.12,0,0.01]],"modes":16,"duration_s":0.3,"outputs":["json"]}
{"name":"box-plastic","mesh":"box.obj","material":"plastic","hits":[[0.04,0.013,0.011]],"speeds_m_s":[1,3],"modes":16,"duration_s":0.3}
{"name":"box-porcelain","mesh":"box.obj","material":"porcelain","hits":[[0.017,0.03,0.009]],"modes":16,"duration_s":0.3}
{"name":"bar-20","mesh":"bar.obj","material":"metal","hits":[[0.1,0,0.01]],"modes":20,"duration_s":0.3}
{"name":"again","mesh":"plate.obj","material":"wood","hits":[[0.0,0.0,0.002]],"speeds_m_s":[2],"modes":16,"duration_s":0.3}
"#;

/// The output files under `out` (manifests and the model cache left out) with their bytes.
fn outputs(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    for d in std::fs::read_dir(out).unwrap() {
        let d = d.unwrap().path();
        if !d.is_dir() || d.file_name().unwrap() == "models" {
            continue;
        }
        for f in std::fs::read_dir(&d).unwrap() {
            let f = f.unwrap().path();
            let name = f.strip_prefix(out).unwrap().to_string_lossy().into_owned();
            assert!(!name.contains(".tmp"), "a temporary file was left: {name}");
            files.insert(name, std::fs::read(&f).unwrap());
        }
    }
    files
}

/// Every manifest entry under `out`, from every shard's manifest.
fn entries(out: &Path) -> Vec<Value> {
    let mut all = Vec::new();
    for f in std::fs::read_dir(out).unwrap() {
        let f = f.unwrap().path();
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("manifest-") && name.ends_with(".jsonl") {
            for line in std::fs::read_to_string(&f).unwrap().lines() {
                all.push(serde_json::from_str(line).unwrap());
            }
        }
    }
    all
}

fn keys(entries: &[Value]) -> BTreeSet<String> {
    entries
        .iter()
        .map(|e| e["key"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn shards_of_the_slurm_and_kubernetes_recipes_make_exactly_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    meshes(d);
    std::fs::write(d.join("jobs.jsonl"), JOBS).unwrap();

    // The recipes give each task one thread (RAYON_NUM_THREADS=1), and a modal solve's
    // parallel sums round differently with another thread count: the reference runs with one
    // thread too, so the files must agree to the bit.
    let reference_run = Command::new(bin())
        .args(["batch", "jobs.jsonl", "--out", "one", "--json"])
        .current_dir(d)
        .env("RESOUND_LIBRARY", d.join(".test-library.sqlite"))
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    let one: Value = serde_json::from_str(&ok(&reference_run)).unwrap();
    assert_eq!(one["jobs"], 8);
    assert_eq!(one["shard_jobs"], 8);
    // 4 + 1 + 1 + 2 + 2 + 1 + 1 strikes; the last job repeats one of the first.
    assert_eq!(one["rendered"], 12, "{one}");
    assert_eq!(one["skipped"], 1, "{one}");
    // plate, bar at 16 and 20 modes, box.
    assert_eq!(one["models_solved"], 4, "{one}");
    // Every strike audible (a hit on a nodal point would be warned about).
    assert_eq!(one["warnings"].as_array().unwrap().len(), 0, "{one}");
    let reference = outputs(&d.join("one"));
    let ref_entries = entries(&d.join("one"));
    assert_eq!(ref_entries.len(), 12);
    assert_eq!(keys(&ref_entries).len(), 12);
    // wav for 10 strikes, json for 3 (one of them with a wav too).
    assert_eq!(reference.len(), 10 + 3);
    for e in &ref_entries {
        for f in e["files"].as_array().unwrap() {
            assert!(reference.contains_key(f.as_str().unwrap()), "{e}");
        }
    }
    // What the files hold: a WAV the reader reads, labels that name the modes.
    let wav = reference.keys().find(|k| k.ends_with(".wav")).unwrap();
    let clip = resound::io::load_audio(&d.join("one").join(wav)).unwrap();
    assert_eq!(clip.sample_rate_hz, 48_000);
    assert_eq!(clip.channels.len(), 1);
    assert_eq!(clip.frames(), 14_400);
    assert!(clip.channels[0].iter().any(|s| s.abs() > 1e-4));
    let json = reference.keys().find(|k| k.ends_with(".json")).unwrap();
    let labels: Value = serde_json::from_slice(&reference[json]).unwrap();
    assert!(
        !labels["bank_modes"].as_array().unwrap().is_empty(),
        "{labels}"
    );

    // Slurm: the array script, its four tasks run as local processes at once.
    let script = repo().join("recipes/slurm/batch.sbatch");
    let tasks: Vec<_> = (0..4)
        .map(|i| {
            Command::new("bash")
                .arg(&script)
                .args(["jobs.jsonl", "slurm"])
                .current_dir(d)
                .env("RESOUND", bin())
                .env("RESOUND_LIBRARY", d.join(".test-library.sqlite"))
                .env("SLURM_ARRAY_TASK_ID", i.to_string())
                .env("SLURM_ARRAY_TASK_COUNT", "4")
                .spawn()
                .unwrap()
        })
        .collect();
    for mut t in tasks {
        assert!(t.wait().unwrap().success());
    }
    // Kubernetes: the Indexed Job's container command, with JOB_COMPLETION_INDEX per pod.
    let yaml = std::fs::read_to_string(repo().join("recipes/kubernetes/batch-job.yaml")).unwrap();
    let docs = yaml_rust2::YamlLoader::load_from_str(&yaml).unwrap();
    assert_eq!(docs.len(), 1);
    let job = &docs[0];
    assert_eq!(job["apiVersion"].as_str(), Some("batch/v1"));
    assert_eq!(job["kind"].as_str(), Some("Job"));
    let spec = &job["spec"];
    assert_eq!(spec["completionMode"].as_str(), Some("Indexed"));
    let n = spec["completions"].as_i64().unwrap();
    assert_eq!(spec["parallelism"].as_i64(), Some(n));
    let pod = &spec["template"]["spec"];
    assert_eq!(pod["restartPolicy"].as_str(), Some("Never"));
    let container = &pod["containers"][0];
    let mount = container["volumeMounts"][0]["mountPath"].as_str().unwrap();
    let claim = pod["volumes"][0]["persistentVolumeClaim"]["claimName"].as_str();
    assert_eq!(
        pod["volumes"][0]["name"].as_str(),
        container["volumeMounts"][0]["name"].as_str()
    );
    assert!(claim.is_some());
    let shell = container["command"][0].as_str().unwrap();
    assert_eq!(container["command"][1].as_str(), Some("-c"));
    let args = container["args"][0].as_str().unwrap();
    assert!(
        args.contains(&format!("--shard \"$JOB_COMPLETION_INDEX/{n}\"")),
        "the shard count in the command must equal completions ({n}): {args}"
    );
    std::fs::create_dir_all(d.join("k8s")).unwrap();
    let data = d.join("k8s");
    for f in ["plate.obj", "bar.obj", "box.obj", "jobs.jsonl"] {
        std::fs::copy(d.join(f), data.join(f)).unwrap();
    }
    let local = args.replace(mount, &data.to_string_lossy()).replacen(
        "exec resound",
        &format!("exec {}", bin()),
        1,
    );
    // The container's environment, as the pod would have it.
    let env: Vec<(String, String)> = container["env"]
        .as_vec()
        .map(|v| {
            v.iter()
                .map(|e| {
                    (
                        e["name"].as_str().unwrap().to_string(),
                        e["value"].as_str().unwrap().to_string(),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    assert!(
        env.iter()
            .any(|(k, v)| k == "RAYON_NUM_THREADS" && v == "1"),
        "{env:?}"
    );
    let pods: Vec<_> = (0..n)
        .map(|k| {
            Command::new(shell)
                .args(["-c", &local])
                .envs(env.iter().map(|(k, v)| (k.as_str(), v.as_str())))
                .current_dir(d)
                .env("RESOUND_LIBRARY", d.join(".test-library.sqlite"))
                .env("JOB_COMPLETION_INDEX", k.to_string())
                .spawn()
                .unwrap()
        })
        .collect();
    for mut p in pods {
        assert!(p.wait().unwrap().success());
    }

    for (name, out) in [("slurm", d.join("slurm")), ("kubernetes", data.join("out"))] {
        assert_eq!(
            outputs(&out),
            reference,
            "{name}: the shards' files differ from the unsharded run's"
        );
        let sharded = entries(&out);
        // No strike in two shards, none missing.
        assert_eq!(sharded.len(), 12, "{name}");
        assert_eq!(keys(&sharded), keys(&ref_entries), "{name}");
        let mut a: Vec<String> = sharded.iter().map(Value::to_string).collect();
        let mut b: Vec<String> = ref_entries.iter().map(Value::to_string).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b, "{name}: manifest entries differ");
        // Each shard did part of the work (4 models over 4 shards need not be one each, but
        // more than one shard must have had some).
        let manifests = std::fs::read_dir(&out)
            .unwrap()
            .filter(|f| {
                let f = f.as_ref().unwrap().path();
                f.to_string_lossy().contains("manifest-") && f.metadata().unwrap().len() > 0
            })
            .count();
        assert!(
            manifests >= 2,
            "{name}: {manifests} shard(s) did all the work"
        );
        // The shared model cache holds each model once.
        let cached = std::fs::read_dir(out.join("models")).unwrap().count();
        assert_eq!(cached, 4, "{name}");
    }
}

#[test]
fn a_killed_shard_resumes_without_redoing_what_it_finished() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    meshes(d);
    // 40 strikes of 4 s each: about a second of rendering after the model is solved.
    let hits: Vec<String> = (0..10)
        .map(|k| format!("[{:.3},0.02,0.002]", -0.08 + 0.016 * f64::from(k)))
        .collect();
    let line = format!(
        r#"{{"mesh":"plate.obj","material":"wood","hits":[{}],"speeds_m_s":[0.5,1,2,4],"modes":40,"duration_s":4}}"#,
        hits.join(",")
    );
    std::fs::write(d.join("jobs.jsonl"), format!("{line}\n")).unwrap();
    let manifest = d.join("out/manifest-0-of-1.jsonl");
    let mut child = Command::new(bin())
        .args(["batch", "jobs.jsonl", "--out", "out"])
        .current_dir(d)
        .env("RESOUND_LIBRARY", d.join(".test-library.sqlite"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    loop {
        let listed = std::fs::read_to_string(&manifest)
            .map(|t| t.lines().count())
            .unwrap_or(0);
        if listed >= 1 {
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the batch ended before it could be killed"
        );
        assert!(t0.elapsed().as_secs() < 300, "no strike in 300 s");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap(); // SIGKILL: no chance to tidy up
    child.wait().unwrap();
    let before = entries(&d.join("out"));
    assert!(
        !before.is_empty() && before.len() < 40,
        "killed after {} of 40 strikes: the test needs it killed midway",
        before.len()
    );
    let files_before = outputs(&d.join("out"));
    for e in &before {
        let f = e["files"][0].as_str().unwrap();
        assert!(files_before.contains_key(f), "listed but missing: {f}");
    }

    let rerun: Value = serde_json::from_str(&ok(&resound(
        &["batch", "jobs.jsonl", "--out", "out", "--json"],
        d,
    )))
    .unwrap();
    assert_eq!(rerun["skipped"].as_u64().unwrap() as usize, before.len());
    assert_eq!(
        rerun["rendered"].as_u64().unwrap() as usize,
        40 - before.len()
    );
    let after = entries(&d.join("out"));
    assert_eq!(after.len(), 40);
    assert_eq!(keys(&after).len(), 40, "a strike was listed twice");
    // The strikes finished before the kill were not rewritten.
    let files_after = outputs(&d.join("out"));
    assert_eq!(files_after.len(), 40);
    for (name, bytes) in &files_before {
        if before.iter().any(|e| e["files"][0] == name.as_str()) {
            assert_eq!(&files_after[name], bytes);
        }
    }
    // A third run has nothing left to do.
    let third: Value = serde_json::from_str(&ok(&resound(
        &["batch", "jobs.jsonl", "--out", "out", "--json"],
        d,
    )))
    .unwrap();
    assert_eq!(third["rendered"], 0);
    assert_eq!(third["skipped"], 40);

    // A manifest line cut short (the kill between write and newline) is dropped and its strike
    // rendered again; a listed file that has gone is rendered again.
    let text = std::fs::read_to_string(&manifest).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let last = lines.pop().unwrap();
    let gone = serde_json::from_str::<Value>(lines[0]).unwrap()["files"][0]
        .as_str()
        .unwrap()
        .to_string();
    std::fs::remove_file(d.join("out").join(&gone)).unwrap();
    let cut = format!("{}\n{}", lines.join("\n"), &last[..last.len() / 2]);
    std::fs::write(&manifest, cut).unwrap();
    let fourth: Value = serde_json::from_str(&ok(&resound(
        &["batch", "jobs.jsonl", "--out", "out", "--json"],
        d,
    )))
    .unwrap();
    assert_eq!(fourth["rendered"], 2, "{fourth}");
    assert!(d.join("out").join(&gone).is_file());
    let fifth = entries(&d.join("out"));
    assert_eq!(keys(&fifth).len(), 40);
}

#[test]
fn bad_job_lines_fail_by_line_number_and_the_others_finish() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    meshes(d);
    let jobs = [
        r#"{"mesh":"bar.obj","material":"wood","hits":[[0.1,0,0.01]],"modes":12,"duration_s":0.2}"#,
        r#"{"mesh":"bar.obj","material":"wood","hits":[[0.1,0,0.01]"#,
        r#"{"mesh":"nowhere.obj","material":"wood","hits":[[0.1,0,0.01]]}"#,
        r#"{"mesh":"bar.obj","material":"unobtainium","hits":[[0.1,0,0.01]]}"#,
        r#"{"mesh":"bar.obj","material":"wood","hits":[[0.1,0,0.01]],"speed":2}"#,
        r#"{"mesh":"bar.obj","material":"wood","hits":[],"modes":12}"#,
        r#"{"mesh":"plate.obj","material":"metal","hits":[[0,0,0.002]],"modes":12,"duration_s":0.2,"listener":[0,0,0.002]}"#,
        r#"{"mesh":"box.obj","material":"glass","hits":[[0.04,0.013,0.011]],"modes":12,"duration_s":0.2}"#,
    ];
    std::fs::write(d.join("jobs.jsonl"), jobs.join("\n")).unwrap();
    let out = resound(&["batch", "jobs.jsonl", "--out", "out"], d);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    for (line, needle) in [
        (2, "not a job"),
        (3, "nowhere.obj"),
        (4, "unobtainium"),
        (5, "unknown field `speed`"),
        (6, "must not be empty"),
        (7, "from the hit point"),
    ] {
        assert!(
            err.contains(&format!("line {line}: ")) && err.contains(needle),
            "line {line} ({needle}) not reported: {err}"
        );
    }
    assert!(err.contains("6 of 8 jobs"), "{err}");
    assert!(
        !err.contains("jobs.jsonl: line 1:") && !err.contains("jobs.jsonl: line 8:"),
        "{err}"
    );
    // Lines 1 and 8 were rendered and listed.
    let listed = entries(&d.join("out"));
    let lines: BTreeSet<u64> = listed.iter().map(|e| e["line"].as_u64().unwrap()).collect();
    assert_eq!(lines, BTreeSet::from([1, 8]));
    assert_eq!(outputs(&d.join("out")).len(), 2);

    // Bad shards and an unreadable jobs file are errors of the whole run.
    for shard in ["4/4", "1", "a/b", "0/0"] {
        let o = resound(&["batch", "jobs.jsonl", "--out", "o2", "--shard", shard], d);
        assert_eq!(o.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&o.stderr).contains("shard must be i/N"));
    }
    let o = resound(&["batch", "missing.jsonl", "--out", "o3"], d);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.jsonl"));
}

/// Issue 38: an empty jobs file (or one of blank lines and comments) exited 0 with "0 of 0
/// jobs" and an output folder. It is an error that says why, and nothing is made.
#[test]
fn a_jobs_file_without_jobs_is_an_error_not_an_empty_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, text) in [
        ("empty.jsonl", ""),
        ("blank.jsonl", "\n  \n# only a comment\n"),
    ] {
        std::fs::write(d.join(name), text).unwrap();
        let out = resound(&["batch", name, "--out", "made"], d);
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("no jobs (one JSON object per line"), "{err}");
        assert!(!d.join("made").exists());
    }
}

/// Issue 38: 100 000 identical job lines ran at ~300 lines/s after the first (5.5 min of
/// reading and hashing for one strike). A line that repeats a job (spacing and key order
/// aside) is skipped before any file is read, counted, and renders nothing twice; 20 000
/// copies make exactly the files of one.
#[test]
fn repeated_job_lines_cost_nothing_and_make_the_files_of_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    meshes(d);
    let a = r#"{"name":"a","mesh":"box.obj","material":"metal","hits":[[0.04,0.013,0.011]],"modes":8,"duration_s":0.2}"#;
    let a2 = r#"{ "modes": 8, "name": "a", "material": "metal", "mesh": "box.obj", "hits": [[0.04, 0.013, 0.011]], "duration_s": 0.2 }"#;
    let mut text = String::new();
    for k in 0..20_000 {
        text += if k % 2 == 0 { a } else { a2 };
        text.push('\n');
    }
    std::fs::write(d.join("dup.jsonl"), &text).unwrap();
    std::fs::write(d.join("one.jsonl"), format!("{a}\n")).unwrap();
    let dup = ok(&resound(
        &["batch", "dup.jsonl", "--out", "dup", "--json"],
        d,
    ));
    let v: Value = serde_json::from_str(&dup).unwrap();
    assert_eq!(v["jobs"], 20_000, "{v}");
    assert_eq!(v["duplicate_lines"], 19_999, "{v}");
    assert_eq!(v["rendered"], 1, "{v}");
    ok(&resound(&["batch", "one.jsonl", "--out", "one"], d));
    assert_eq!(outputs(&d.join("dup")), outputs(&d.join("one")));
}
