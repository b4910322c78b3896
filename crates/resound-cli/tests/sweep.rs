//! The standing bad-input sweep (issue 15): every subcommand that reads a file gets every kind
//! of bad file, and numeric flags get values no one should pass. Each case must end within a
//! minute, never panic, and either fail with a clear `error:` and exit 2 or — for a value that is
//! merely unusual — succeed. The counts are printed (`cargo test -p resound-cli --test sweep --
//! --nocapture`).
#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[derive(Default)]
struct Tally {
    cases: usize,
    errors: usize,
    ok: usize,
    failures: Vec<String>,
}

impl Tally {
    /// Runs `args` in `dir`; `may_succeed` allows exit 0.
    fn run(&mut self, dir: &Path, args: &[&str], may_succeed: bool) {
        self.cases += 1;
        let (code, err) = run_timed(dir, args);
        let case = format!("resound {}", args.join(" "));
        match code {
            None => self
                .failures
                .push(format!("{case}: hang (> 60 s) or killed by a signal")),
            Some(_) if err.contains("panicked") => {
                self.failures.push(format!("{case}: panic: {err}"))
            }
            Some(2) if err.contains("error:") => self.errors += 1,
            Some(0) if may_succeed => self.ok += 1,
            Some(c) => self.failures.push(format!(
                "{case}: exit {c} (expected an error){}: {err}",
                if may_succeed { " or success" } else { "" }
            )),
        }
    }
}

/// Bad files, by name: written into `dir`, or (`missing`, `dir/`) not files at all.
fn bad_files(dir: &Path, ext: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut put = |stem: &str, bytes: &[u8]| {
        let n = format!("{stem}.{ext}");
        std::fs::write(dir.join(&n), bytes).unwrap();
        names.push(n);
    };
    put("empty", b"");
    put("text", b"hello, this is not that kind of file\n");
    let noise: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    put("noise", &noise);
    put("zeros", &[0u8; 4096]);
    put("nan", b"NaN nan inf -inf 1e400\n");
    put(
        "json",
        br#"{"name": "x", "alpha": -1, "modes": [{"freq_hz": "NaN"}]}"#,
    );
    put("riff", b"RIFF\xff\xff\xff\xffWAVEfmt \x10\x00\x00\x00");
    names.push(format!("missing.{ext}"));
    std::fs::create_dir_all(dir.join(format!("adir.{ext}"))).unwrap();
    names.push(format!("adir.{ext}"));
    names
}

#[test]
fn bad_input_sweep_has_no_panic_hang_or_silent_success() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut t = Tally::default();
    // Valid companions for the slots not under test.
    let ok = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_resound"))
            .args(args)
            .current_dir(d)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    ok(&[
        "mesh",
        "primitive",
        "bar",
        "--size",
        "0.1,0.02,0.01",
        "-o",
        "bar.obj",
    ]);
    ok(&[
        "modal",
        "bar.obj",
        "-m",
        "steel",
        "--modes",
        "4",
        "--resolution",
        "20",
        "-o",
        "bar.rmodal",
    ]);
    std::fs::write(d.join("t.csv"), "0,0\n1,0.1\n").unwrap();
    let tone: Vec<f32> = (0..8000)
        .map(|i| {
            let t = f64::from(i) / 8000.0;
            (0.5 * (-10.0 * t).exp() * (std::f64::consts::TAU * 440.0 * t).sin()) as f32
        })
        .collect();
    resound::io::write_wav(
        &d.join("ok.wav"),
        &tone,
        8000,
        resound::io::WavFormat::Float32,
    )
    .unwrap();
    ok(&["analyze", "ok.wav", "--json", "modes.json"]);

    // Every file slot × every bad file.
    for ext in ["wav", "ogg", "flac", "mp3"] {
        for f in bad_files(d, ext) {
            t.run(d, &["analyze", &f], false);
            t.run(
                d,
                &["estimate", &f, "--mesh", "bar.rmodal", "--hit", "0,0,0.005"],
                false,
            );
            t.run(
                d,
                &[
                    "grains",
                    "analyze",
                    &format!("impact:{f}"),
                    "-o",
                    "g.grains",
                ],
                false,
            );
            t.run(
                d,
                &[
                    "stats",
                    "fit",
                    "--material",
                    "m",
                    &f,
                    "ok.wav",
                    "-o",
                    "s.json",
                ],
                false,
            );
        }
    }
    for ext in ["obj", "stl", "ply", "msh", "node", "ele", "mesh", "xyz"] {
        for f in bad_files(d, ext) {
            t.run(d, &["modal", &f, "-m", "steel", "--modes", "3"], false);
            t.run(d, &["mesh", "check", &f], false);
            t.run(
                d,
                &["estimate", "ok.wav", "--mesh", &f, "--hit", "0,0,0"],
                false,
            );
            t.run(
                d,
                &[
                    "synth",
                    "--material",
                    "metal",
                    "--mesh",
                    &f,
                    "--hit",
                    "0,0,0",
                    "-o",
                    "x.wav",
                ],
                false,
            );
        }
    }
    for f in bad_files(d, "rmodal") {
        t.run(d, &["model", &f], false);
        t.run(
            d,
            &[
                "synth",
                "--material",
                "metal",
                "--mesh",
                &f,
                "--hit",
                "0,0,0",
                "-o",
                "x.wav",
            ],
            false,
        );
    }
    for f in bad_files(d, "json") {
        t.run(d, &["synth", "--modes", &f, "-o", "x.wav"], false);
        t.run(d, &["synth", "--stats", &f, "-o", "x.wav"], false);
        t.run(d, &["materials", "import", &f], false);
        t.run(
            d,
            &[
                "synth",
                "--material",
                &f,
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0,0,0",
                "-o",
                "x.wav",
            ],
            false,
        );
        t.run(
            d,
            &[
                "scrape",
                "--stats",
                &f,
                "--surface",
                "fractal",
                "--trajectory",
                "t.csv",
                "-o",
                "x.wav",
            ],
            false,
        );
    }
    for f in bad_files(d, "toml") {
        t.run(d, &["scene", &f, "-o", "x.wav"], false);
    }
    for f in bad_files(d, "grains") {
        t.run(d, &["grains", "info", &f], false);
        t.run(d, &["grains", "resynth", &f, "-o", "x.wav"], false);
    }
    for f in bad_files(d, "npy") {
        t.run(
            d,
            &[
                "scrape",
                "--modes",
                "modes.json",
                "--surface",
                &f,
                "--trajectory",
                "t.csv",
                "-o",
                "x.wav",
            ],
            false,
        );
    }
    for f in bad_files(d, "csv") {
        t.run(
            d,
            &[
                "scrape",
                "--modes",
                "modes.json",
                "--surface",
                "fractal",
                "--trajectory",
                &f,
                "-o",
                "x.wav",
            ],
            false,
        );
    }
    for f in bad_files(d, "sqlite") {
        // A missing library lists the built-ins (with a note); anything else is an error.
        t.run(
            d,
            &["materials", "list", "--library", &f],
            f.starts_with("missing"),
        );
    }

    // Numeric flags × values: an error naming the problem, or a result.
    let values = [
        "nan", "inf", "-inf", "-1", "0", "1e308", "-1e-300", "abc", "",
    ];
    for v in values {
        let hit = format!("{v},0,0.005");
        t.run(d, &["analyze", "ok.wav", "--highpass-hz", v], true);
        t.run(d, &["analyze", "ok.wav", "--min-db", v], true);
        t.run(d, &["analyze", "ok.wav", "--max-duration-s", v], true);
        t.run(d, &["analyze", "ok.wav", "--resample-hz", v], true);
        t.run(
            d,
            &[
                "modal", "bar.obj", "-m", "steel", "--modes", "3", "--scale", v,
            ],
            true,
        );
        t.run(
            d,
            &["modal", "bar.obj", "-m", "steel", "--max-freq-hz", v],
            true,
        );
        t.run(
            d,
            &[
                "mesh",
                "primitive",
                "bar",
                "--size",
                &format!("{v},0.1,0.1"),
                "-o",
                "p.obj",
            ],
            true,
        );
        for (flag, val) in [
            ("--velocity", v),
            ("--duration", v),
            ("--hit", hit.as_str()),
        ] {
            t.run(
                d,
                &[
                    "synth",
                    "--material",
                    "metal",
                    "--mesh",
                    "bar.rmodal",
                    "--hit",
                    "0,0,0.005",
                    flag,
                    val,
                    "-o",
                    "x.wav",
                ],
                true,
            );
        }
        t.run(
            d,
            &[
                "scrape",
                "--modes",
                "modes.json",
                "--surface",
                "fractal",
                "--trajectory",
                "t.csv",
                "--friction",
                v,
                "-o",
                "x.wav",
            ],
            true,
        );
    }
    eprintln!(
        "bad-input sweep: {} cases: {} clear errors, {} accepted values, {} failures",
        t.cases,
        t.errors,
        t.ok,
        t.failures.len()
    );
    assert!(t.failures.is_empty(), "{}", t.failures.join("\n"));
    assert!(t.cases > 400);
}

/// Runs `args` in `dir` with the sweep's library and cache: (exit code, stderr); `None` for a
/// run killed after 60 s.
fn run_timed(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_resound"))
        .args(args)
        .current_dir(dir)
        .env("RESOUND_LIBRARY", dir.join("sweep-library.sqlite"))
        .env("XDG_CACHE_HOME", dir.join("cache"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            let _ = child.wait();
            return (None, String::new());
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut err);
    }
    (code, err)
}

/// The files a run of the sweep's commands reads, made valid in `d`.
fn valid_inputs(d: &Path) {
    let run = |args: &[&str]| {
        let (code, err) = run_timed(d, args);
        assert_eq!(code, Some(0), "{args:?}: {err}");
    };
    run(&[
        "mesh",
        "primitive",
        "bar",
        "--size",
        "0.1,0.02,0.01",
        "-o",
        "bar.obj",
    ]);
    run(&[
        "modal",
        "bar.obj",
        "-m",
        "steel",
        "--modes",
        "4",
        "--resolution",
        "20",
        "-o",
        "bar.rmodal",
    ]);
    // Two strikes of twenty modes each (stats need fifteen per recording).
    for (name, shift) in [("ok.wav", 1.0), ("ok2.wav", 1.01)] {
        let tone: Vec<f32> = (0..24_000)
            .map(|i| {
                let t = f64::from(i) / 48_000.0;
                (1..=20)
                    .map(|k| {
                        let f = shift * 330.0 * f64::from(k).powf(1.3);
                        0.04 / f64::from(k).sqrt()
                            * (-(5.0 + f64::from(k)) * t).exp()
                            * (std::f64::consts::TAU * f * t).sin()
                    })
                    .sum::<f64>() as f32
            })
            .collect();
        resound::io::write_wav(
            &d.join(name),
            &tone,
            48_000,
            resound::io::WavFormat::Float32,
        )
        .unwrap();
    }
    run(&["analyze", "ok.wav", "--json", "modes.json"]);
    run(&["materials", "export", "metal", "m.json"]);
    let m = std::fs::read_to_string(d.join("m.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&m).unwrap();
    v["name"] = "mine".into();
    std::fs::write(d.join("m.json"), v.to_string()).unwrap();
    run(&["materials", "import", "m.json"]);
    run(&[
        "stats",
        "fit",
        "--material",
        "metal",
        "ok.wav",
        "ok2.wav",
        "-o",
        "s.json",
    ]);
    std::fs::write(d.join("t.csv"), "0,0\n1,0.1\n").unwrap();
    std::fs::write(
        d.join("scene.toml"),
        "duration = 0.2\nstereo = false\n[listener]\nposition = [0.0, 0.3, 0.5]\n\n\
         [[body]]\nname = \"floor\"\nfixed = true\nshape = { box = [1.0, 0.04, 1.0] }\n\
         material = \"wood\"\ndensity = 700\nposition = [0.0, -0.02, 0.0]\nsound = false\n\n\
         [[body]]\nname = \"ball\"\nshape = { sphere = 0.02 }\nmaterial = \"metal\"\n\
         density = 7850\nposition = [0.0, 0.1, 0.0]\n",
    )
    .unwrap();
}

/// Issue 38: every input of every command given as its output is refused (exit 2) and the
/// input keeps its bytes — the library included, named or default; and concurrent writers of
/// one library name never both win.
#[test]
fn every_input_given_as_an_output_is_refused_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    valid_inputs(d);
    let lib = "sweep-library.sqlite";
    // Each command with its inputs; `OUT` is where each input in turn is given as output.
    let commands: &[(&[&str], &[&str])] = &[
        (&["analyze", "ok.wav", "--json", "OUT"], &["ok.wav", lib]),
        (&["analyze", "ok.wav", "--plot", "OUT"], &["ok.wav"]),
        (
            &[
                "estimate",
                "ok.wav",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0,0,0.005",
                "-o",
                "OUT",
            ],
            &["ok.wav", "bar.rmodal", lib],
        ),
        (
            &[
                "estimate",
                "ok.wav",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0,0,0.005",
                "--plot",
                "OUT",
            ],
            &["ok.wav", "bar.rmodal"],
        ),
        (
            &[
                "synth",
                "--material",
                "m.json",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0,0,0.005",
                "-o",
                "OUT",
            ],
            &["m.json", "bar.rmodal", lib],
        ),
        (
            &[
                "synth",
                "--material",
                "metal",
                "--mesh",
                "bar.obj",
                "--hit",
                "0,0,0.005",
                "-o",
                "OUT",
            ],
            &["bar.obj"],
        ),
        (
            &["synth", "--modes", "modes.json", "-o", "OUT"],
            &["modes.json"],
        ),
        (&["synth", "--stats", "s.json", "-o", "OUT"], &["s.json"]),
        (
            &[
                "modal", "bar.obj", "-m", "steel", "--modes", "3", "-o", "OUT",
            ],
            &["bar.obj"],
        ),
        (&["scene", "scene.toml", "-o", "OUT"], &["scene.toml", lib]),
        (
            &[
                "scrape",
                "--modes",
                "modes.json",
                "--surface",
                "fractal",
                "--trajectory",
                "t.csv",
                "-o",
                "OUT",
            ],
            &["modes.json", "t.csv"],
        ),
        (
            &["grains", "analyze", "impact:ok.wav", "-o", "OUT"],
            &["ok.wav"],
        ),
        (
            &[
                "stats",
                "fit",
                "--material",
                "metal",
                "ok.wav",
                "ok2.wav",
                "-o",
                "OUT",
            ],
            &["ok.wav", "ok2.wav", lib],
        ),
        (&["materials", "export", "metal", "OUT"], &[lib]),
        (
            &["materials", "export", "metal", "OUT", "--library", "m.json"],
            &["m.json"],
        ),
    ];
    let mut cases = 0;
    let mut failures = Vec::new();
    for (args, inputs) in commands {
        for input in *inputs {
            cases += 1;
            let before = std::fs::read(d.join(input)).unwrap();
            let argv: Vec<&str> = args
                .iter()
                .map(|a| if *a == "OUT" { *input } else { a })
                .collect();
            let (code, err) = run_timed(d, &argv);
            let after = std::fs::read(d.join(input)).unwrap_or_default();
            if code != Some(2) || !err.contains("error:") || err.contains("panicked") {
                failures.push(format!("{argv:?}: exit {code:?}: {err}"));
            }
            if after != before {
                failures.push(format!("{argv:?} changed {input}"));
            }
        }
    }
    // Concurrent writers: eight imports of different files under one new name at once.
    let mut kids = Vec::new();
    for k in 0..8 {
        let f = format!("c{k}.json");
        let m = std::fs::read_to_string(d.join("m.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&m).unwrap();
        let mut v = v;
        v["name"] = "shared".into();
        v["sigma"] = (k as f64 + 1.0).into();
        std::fs::write(d.join(&f), v.to_string()).unwrap();
        kids.push(
            Command::new(env!("CARGO_BIN_EXE_resound"))
                .args(["materials", "import", &f, "--library", lib])
                .current_dir(d)
                .stderr(Stdio::piped())
                .spawn()
                .unwrap(),
        );
    }
    let outs: Vec<_> = kids
        .into_iter()
        .map(|c| c.wait_with_output().unwrap())
        .collect();
    let won = outs.iter().filter(|o| o.status.success()).count();
    cases += outs.len();
    if won != 1 {
        failures.push(format!(
            "{won} of 8 concurrent imports of one name succeeded"
        ));
    }
    for o in outs.iter().filter(|o| !o.status.success()) {
        let err = String::from_utf8_lossy(&o.stderr);
        if o.status.code() != Some(2) || !err.contains("already has a material named \"shared\"") {
            failures.push(format!("a losing import: {err}"));
        }
    }
    eprintln!(
        "inputs as outputs and concurrent writers: {cases} cases, {} failures (data loss, \
         panics, hangs or silent success)",
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A TOML or flag spelling of `v` (TOML writes `nan` and `inf`).
fn spell(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v:e}")
    }
}

/// Issue 38: a property test over every numeric flag of the strike, modal, analysis, scrape
/// and mesh commands and every numeric field of a scene, with values from the whole f64 range
/// (any bit pattern, the specials, and magnitudes 1e-12–1e12 of either sign): each run ends
/// within a minute with exit 0, or exit 2 and an `error:` line — never a panic, an abort or a
/// hang. Deterministic (a fixed seed), so CI sees the same cases each time.
#[test]
fn numeric_flags_and_scene_fields_over_the_whole_f64_range() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    valid_inputs(d);
    let synth = |flag: &'static str| -> Vec<&'static str> {
        vec![
            "synth",
            "--material",
            "metal",
            "--mesh",
            "bar.rmodal",
            "--hit",
            "0,0,0.005",
            flag,
        ]
    };
    let mut flags: Vec<Vec<&'static str>> = [
        "--velocity",
        "--duration",
        "--impactor-mass",
        "--impactor-radius",
        "--scale",
    ]
    .iter()
    .map(|f| synth(f))
    .collect();
    flags.extend([
        vec!["analyze", "ok.wav", "--highpass-hz"],
        vec!["analyze", "ok.wav", "--min-db"],
        vec!["analyze", "ok.wav", "--max-duration-s"],
        vec!["modal", "bar.obj", "-m", "steel", "--modes", "3", "--scale"],
        vec!["modal", "bar.obj", "-m", "steel", "--max-freq-hz"],
        vec![
            "scrape",
            "--modes",
            "modes.json",
            "--surface",
            "fractal",
            "--trajectory",
            "t.csv",
            "--friction",
        ],
        vec![
            "scrape",
            "--modes",
            "modes.json",
            "--surface",
            "fractal",
            "--trajectory",
            "t.csv",
            "--roughness-m",
        ],
        vec![
            "scrape",
            "--modes",
            "modes.json",
            "--surface",
            "fractal",
            "--trajectory",
            "t.csv",
            "--probe-mass",
        ],
        vec![
            "scrape",
            "--modes",
            "modes.json",
            "--surface",
            "fractal",
            "--trajectory",
            "t.csv",
            "--gamma",
        ],
        vec![
            "scrape",
            "--modes",
            "modes.json",
            "--surface",
            "fractal",
            "--trajectory",
            "t.csv",
            "--tip-width",
        ],
        vec![
            "scrape",
            "--modes",
            "modes.json",
            "--surface",
            "fractal",
            "--duration",
            "0.2",
            "--speed",
        ],
        vec!["mesh", "primitive", "sphere", "-o", "p.obj", "--size"],
    ]);
    let fields = [
        "duration",
        "listener.position.0",
        "gravity.1",
        "body.position.1",
        "body.rotation.0",
        "body.velocity.1",
        "body.angular_velocity.2",
        "body.density",
        "body.restitution",
        "body.friction",
        "body.shape.sphere",
    ];
    let value = prop_oneof![
        any::<f64>(),
        prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            1e300,
            -1e300,
            1e-300,
        ]),
        (-12.0f64..12.0, any::<bool>()).prop_map(|(e, neg)| {
            let v = 10f64.powf(e);
            if neg {
                -v
            } else {
                v
            }
        }),
    ];
    // Each flag exists and each field is read: a plausible value works (else every case
    // would pass as a clap or TOML error).
    for f in &flags {
        let mut args = f.clone();
        let plausible = if args.contains(&"--min-db") {
            "40"
        } else {
            "0.01"
        };
        args.push(plausible);
        if args[0] == "synth" || args[0] == "scrape" {
            args.extend(["-o", "x.wav"]);
        }
        let (code, err) = run_timed(d, &args);
        assert!(!err.contains("unexpected argument"), "{args:?}: {err}");
        assert!(
            code.is_some() && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
    for field in fields {
        std::fs::write(d.join("p.toml"), scene_with(field, "0.01")).unwrap();
        let (code, err) = run_timed(d, &["scene", "p.toml", "-o", "p.wav"]);
        assert!(!err.contains("unknown field"), "{field}: {err}");
        assert!(
            code.is_some() && !err.contains("panicked"),
            "{field}: {err}"
        );
    }
    std::fs::write(d.join("p.toml"), scene_with("body.density", "7850")).unwrap();
    assert_eq!(run_timed(d, &["scene", "p.toml", "-o", "p.wav"]).0, Some(0));
    let config = Config {
        cases: 192,
        failure_persistence: None,
        ..Config::default()
    };
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[38; 32]);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let flag_count = flags.len();
    let cases = std::cell::Cell::new(0usize);
    let outcome = runner.run(&(0..flag_count + fields.len(), value), |(which, v)| {
        cases.set(cases.get() + 1);
        let s = spell(v);
        let (code, err) = if which < flag_count {
            let mut args = flags[which].clone();
            let with_eq;
            // Negative values after a flag: `--flag=-1`.
            if s.starts_with('-') {
                let flag = args.pop().unwrap();
                with_eq = format!("{flag}={s}");
                args.push(&with_eq);
            } else {
                args.push(&s);
            }
            if args[0] == "synth" || args[0] == "scrape" {
                args.extend(["-o", "x.wav"]);
            }
            run_timed(d, &args)
        } else {
            let field = fields[which - flag_count];
            std::fs::write(d.join("p.toml"), scene_with(field, &s)).unwrap();
            run_timed(d, &["scene", "p.toml", "-o", "p.wav"])
        };
        prop_assert!(code.is_some(), "hang: {which} {s}");
        prop_assert!(!err.contains("panicked"), "panic: {which} {s}: {err}");
        prop_assert!(
            code == Some(0) || (code == Some(2) && err.contains("error:")),
            "exit {code:?} for case {which} = {s}: {err}"
        );
        Ok(())
    });
    eprintln!(
        "property sweep: {} cases over {} flags and {} scene fields",
        cases.get(),
        flag_count,
        fields.len()
    );
    if let Err(e) = outcome {
        panic!("{e}");
    }
}

/// A one-ball scene with `field` (`section.key.index`) set to `v`.
fn scene_with(field: &str, v: &str) -> String {
    let mut duration = "0.2".to_string();
    let mut listener = ["0.0", "0.3", "0.5"].map(String::from);
    let mut gravity = ["0.0", "-9.81", "0.0"].map(String::from);
    let mut position = ["0.0", "0.1", "0.0"].map(String::from);
    let mut rotation = ["0.0", "0.0", "0.0"].map(String::from);
    let mut velocity = ["0.0", "0.0", "0.0"].map(String::from);
    let mut angular = ["0.0", "0.0", "0.0"].map(String::from);
    let (mut density, mut restitution, mut friction, mut radius) = (
        "7850".to_string(),
        "0.5".to_string(),
        "0.5".to_string(),
        "0.02".to_string(),
    );
    let parts: Vec<&str> = field.split('.').collect();
    let i = |k: usize| {
        parts
            .get(k)
            .and_then(|p| p.parse::<usize>().ok())
            .unwrap_or(0)
    };
    match parts.as_slice() {
        ["duration"] => duration = v.into(),
        ["listener", "position", _] => listener[i(2)] = v.into(),
        ["gravity", _] => gravity[i(1)] = v.into(),
        ["body", "position", _] => position[i(2)] = v.into(),
        ["body", "rotation", _] => rotation[i(2)] = v.into(),
        ["body", "velocity", _] => velocity[i(2)] = v.into(),
        ["body", "angular_velocity", _] => angular[i(2)] = v.into(),
        ["body", "density"] => density = v.into(),
        ["body", "restitution"] => restitution = v.into(),
        ["body", "friction"] => friction = v.into(),
        ["body", "shape", "sphere"] => radius = v.into(),
        _ => panic!("unknown field {field}"),
    }
    let list = |a: &[String; 3]| format!("[{}, {}, {}]", a[0], a[1], a[2]);
    format!(
        "duration = {duration}\nstereo = false\ngravity = {}\n[listener]\nposition = {}\n\n\
         [[body]]\nname = \"floor\"\nfixed = true\nshape = {{ box = [1.0, 0.04, 1.0] }}\n\
         material = \"wood\"\ndensity = 700\nposition = [0.0, -0.02, 0.0]\nsound = false\n\n\
         [[body]]\nname = \"ball\"\nshape = {{ sphere = {radius} }}\nmaterial = \"metal\"\n\
         density = {density}\nrestitution = {restitution}\nfriction = {friction}\n\
         position = {}\nrotation = {}\nvelocity = {}\nangular_velocity = {}\n",
        list(&gravity),
        list(&listener),
        list(&position),
        list(&rotation),
        list(&velocity),
        list(&angular)
    )
}
