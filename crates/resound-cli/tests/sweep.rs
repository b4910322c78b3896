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
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break Some(s);
            }
            if t0.elapsed() > Duration::from_secs(60) {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let mut err = String::new();
        if let Some(mut e) = child.stderr.take() {
            use std::io::Read;
            let _ = e.read_to_string(&mut err);
        }
        let case = format!("resound {}", args.join(" "));
        match status {
            None => self.failures.push(format!("{case}: hang (> 60 s)")),
            Some(_) if err.contains("panicked") => {
                self.failures.push(format!("{case}: panic: {err}"))
            }
            Some(s) if s.code() == Some(2) && err.contains("error:") => self.errors += 1,
            Some(s) if s.success() && may_succeed => self.ok += 1,
            Some(s) => self.failures.push(format!(
                "{case}: exit {:?} (expected an error){}: {err}",
                s.code(),
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
