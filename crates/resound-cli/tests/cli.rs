//! End-to-end tests of the `resound` binary.
// Test helpers may unwrap: a panic is a failed test (clippy's allow-unwrap-in-tests only
// covers #[test] functions themselves).
#![allow(clippy::unwrap_used)]

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

/// Runs the binary in `dir` with its own default library and model cache there (tests never
/// touch the user's).
fn resound(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_resound"))
        .args(args)
        .current_dir(dir)
        .env("RESOUND_LIBRARY", dir.join(".test-library.sqlite"))
        .env("XDG_CACHE_HOME", dir.join(".test-cache"))
        .output()
        .expect("run resound")
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn fails_with(out: &Output, needle: &str) {
    assert_eq!(
        out.status.code(),
        Some(2),
        "stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(needle), "expected '{needle}' in: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Issue 19: `modal --transfer` stores each mode's acoustic transfer, `model` shows it and
/// `synth --mic` weights the modes by what they radiate there (a microphone inside the object is
/// refused); a strike without `--mic` is unchanged by it.
#[test]
fn a_transfer_is_fitted_stored_and_heard_by_a_microphone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "sphere",
            "--size",
            "0.15",
            "--segments",
            "32",
            "-o",
            "s.obj",
        ],
        d,
    ));
    let out = ok(&resound(
        &[
            "modal",
            "s.obj",
            "-m",
            "plastic",
            "--modes",
            "6",
            "--resolution",
            "20",
            "--transfer",
            "-o",
            "s.rmodal",
            "--json",
        ],
        d,
    ));
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["has_transfer"], true);
    assert!(
        v["transfer"]["grid_points"].as_u64().unwrap() >= 6,
        "{}",
        v["transfer"]
    );
    assert!(v["transfer"]["bytes"].as_u64().unwrap() > 0);
    let info = ok(&resound(&["model", "s.rmodal"], d));
    assert!(info.contains("acoustic transfer"), "{info}");
    let strike = |mic: Option<&str>, out: &str| {
        let mut args = vec![
            "synth",
            "--material",
            "plastic",
            "--mesh",
            "s.rmodal",
            "--hit",
            "0.15,0,0",
            "-o",
            out,
            "--json",
            "--no-residual",
            "--format",
            "float",
        ];
        if let Some(m) = mic {
            args.extend(["--mic", m]);
        }
        resound(&args, d)
    };
    let plain = strike(None, "plain.wav");
    let pv: Value = serde_json::from_str(&ok(&plain)).unwrap();
    let heard = strike(Some("0.6,0.4,0.2"), "heard.wav");
    let h: Value = serde_json::from_str(&ok(&heard)).unwrap();
    assert_eq!(h["mic"], serde_json::json!([0.6, 0.4, 0.2]));
    // No word about the microphone (a built-in plastic's level may be called faint).
    assert!(
        h["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .all(|w| w["kind"] == "quiet"),
        "{}",
        h["warnings"]
    );
    assert!(pv["mic"].is_null());
    // Another direction hears the (quadrupole-like) modes at another level (before the
    // normalisation to −1 dBFS): the sphere's lowest modes are not omnidirectional.
    let above: Value = serde_json::from_str(&ok(&strike(Some("0,0,0.7"), "above.wav"))).unwrap();
    let (p0, p1) = (h["peak"].as_f64().unwrap(), above["peak"].as_f64().unwrap());
    assert!(
        (20.0 * (p1 / p0).log10()).abs() > 3.0,
        "two microphones hear the same: {p0} {p1}"
    );
    let read = |p: &str| {
        resound::io::load_audio(&d.join(p))
            .unwrap()
            .channels
            .remove(0)
    };
    assert_eq!(read("heard.wav").len(), read("plain.wav").len());
    // Inside the solid: refused (issue 38; it used to render with a warning).
    fails_with(
        &strike(Some("0,0,0"), "inside.wav"),
        "the microphone at [0.0, 0.0, 0.0] m is inside the object",
    );
    assert!(!d.join("inside.wav").exists());
    fails_with(&strike(Some("1,nan,0"), "bad.wav"), "finite");
}

#[test]
fn primitive_then_modal_then_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.3,0.02,0.01",
            "-o",
            "bar.obj",
        ],
        d,
    ));
    let out = ok(&resound(
        &[
            "modal",
            "bar.obj",
            "--material",
            "steel",
            "--modes",
            "4",
            "--resolution",
            "40",
            "--json",
            "--hit",
            "0.15,0,0.005",
            "-o",
            "bar.rmodal",
            "--export-matrices",
            "mats",
        ],
        d,
    ));
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(v["dofs"].as_u64().unwrap() > 900);
    assert!(v["elements"].as_u64().unwrap() >= 120);
    assert!(v["solve_s"].as_f64().unwrap() > 0.0);
    let modes = v["modes"].as_array().unwrap();
    assert_eq!(modes.len(), 4);
    let f: Vec<f64> = modes
        .iter()
        .map(|m| m["freq_hz"].as_f64().unwrap())
        .collect();
    assert!(f.windows(2).all(|w| w[0] <= w[1]), "{f:?}");
    assert!((f[0] / 574.0 - 1.0).abs() < 0.02, "{f:?}");
    assert!(modes[0]["gain"].as_f64().unwrap().abs() > 0.0);
    // Matrix Market files of the same DOF count.
    let k = std::fs::read_to_string(d.join("mats/K.mtx")).unwrap();
    assert!(k.starts_with("%%MatrixMarket matrix coordinate real symmetric"));
    let dims = k.lines().find(|l| !l.starts_with('%')).unwrap();
    assert!(dims.starts_with(&format!("{0} {0} ", v["dofs"])), "{dims}");
    assert!(d.join("mats/M.mtx").exists());
    // Reload, rescale to E/2 (same ν): frequencies scale by √½.
    let out = ok(&resound(
        &[
            "model",
            "bar.rmodal",
            "--json",
            "--material",
            "100e9,0.3,7850",
        ],
        d,
    ));
    let w: Value = serde_json::from_str(&out).unwrap();
    let g: Vec<f64> = w["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["freq_hz"].as_f64().unwrap())
        .collect();
    for (a, b) in f.iter().zip(&g) {
        assert!((b / a - 0.5f64.sqrt()).abs() < 1e-9);
    }
    // Table output by default.
    let table = ok(&resound(
        &[
            "modal",
            "bar.obj",
            "-m",
            "steel",
            "--modes",
            "2",
            "--resolution",
            "30",
        ],
        d,
    ));
    assert!(table.contains("freq_hz") && table.contains("DOFs"));
}

#[test]
fn bad_input_exits_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fails_with(
        &resound(&["modal", "missing.obj", "-m", "steel"], d),
        "missing.obj",
    );
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "sphere",
            "--size",
            "0.05",
            "-o",
            "s.obj",
        ],
        d,
    ));
    fails_with(
        &resound(&["modal", "s.obj", "-m", "unobtainium"], d),
        "unknown material preset",
    );
    fails_with(
        &resound(&["modal", "s.obj", "-m", "200e9,0.3,-5"], d),
        "density",
    );
    fails_with(
        &resound(
            &[
                "modal",
                "s.obj",
                "-m",
                "steel",
                "--modes",
                "2",
                "--resolution",
                "12",
                "--hit",
                "5,5,5",
            ],
            d,
        ),
        "from the surface",
    );
    // A holed mesh: drop the last face line.
    let text = std::fs::read_to_string(d.join("s.obj")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.pop();
    std::fs::write(d.join("holed.obj"), lines.join("\n")).unwrap();
    fails_with(
        &resound(&["modal", "holed.obj", "-m", "steel"], d),
        "not closed",
    );
    // ...which a hole-filling allowance repairs.
    ok(&resound(
        &[
            "modal",
            "holed.obj",
            "-m",
            "steel",
            "--modes",
            "2",
            "--resolution",
            "12",
            "--max-hole-edges",
            "8",
        ],
        d,
    ));
    std::fs::write(d.join("empty.stl"), b"").unwrap();
    fails_with(&resound(&["modal", "empty.stl", "-m", "steel"], d), "empty");
    std::fs::write(d.join("junk.rmodal"), b"RSMODAL\0garbage").unwrap();
    fails_with(&resound(&["model", "junk.rmodal"], d), "modal model file");
    // No half-written output: a failed run leaves no output file.
    fails_with(
        &resound(
            &["modal", "holed.obj", "-m", "steel", "-o", "never.rmodal"],
            d,
        ),
        "not closed",
    );
    assert!(!d.join("never.rmodal").exists());
}

#[test]
fn help_explains_each_subcommand() {
    let dir = tempfile::tempdir().unwrap();
    let h = ok(&resound(&["--help"], dir.path()));
    for cmd in [
        "modal",
        "mesh",
        "model",
        "analyze",
        "estimate",
        "materials",
        "studio",
        "bench",
    ] {
        assert!(
            h.lines()
                .any(|l| l.trim_start().starts_with(cmd) && l.len() > cmd.len() + 20),
            "{cmd}: {h}"
        );
    }
}

/// Three modes after 20 ms of silence, written as 24-bit WAV at 48 kHz.
fn strike_wav(path: &Path, lead_s: f64, n: usize) -> Vec<resound::core::DampedMode> {
    use resound::core::DampedMode;
    let modes = vec![
        DampedMode {
            freq_hz: 523.25,
            damping_per_s: 6.0,
            amplitude: 0.3,
            phase_rad: 0.4,
        },
        DampedMode {
            freq_hz: 1811.0,
            damping_per_s: 35.0,
            amplitude: 0.2,
            phase_rad: -1.2,
        },
        DampedMode {
            freq_hz: 7340.0,
            damping_per_s: 120.0,
            amplitude: 0.25,
            phase_rad: 2.0,
        },
    ];
    let lead = (lead_s * 48000.0) as usize;
    let mut x = vec![0.0f32; lead];
    x.extend(
        resound::core::damped::synthesize(&modes, 48000.0, n)
            .iter()
            .map(|&v| v as f32),
    );
    resound::io::write_wav(path, &x, 48000, resound::io::WavFormat::Pcm24).unwrap();
    modes
}

#[test]
fn analyze_round_trip_json_table_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = strike_wav(&d.join("hit.wav"), 0.02, 48000);
    let table = ok(&resound(
        &[
            "analyze", "hit.wav", "--json", "hit.json", "--plot", "hit.png",
        ],
        d,
    ));
    assert_eq!(
        table
            .lines()
            .filter(|l| l.trim_start().starts_with(char::is_numeric))
            .count(),
        3,
        "{table}"
    );
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("hit.json")).unwrap()).unwrap();
    assert_eq!(v["sample_rate"], 48000.0);
    assert!(
        (v["onset_s"].as_f64().unwrap() - 0.02).abs() < 2.0 / 48000.0,
        "{}",
        v["onset_s"]
    );
    let modes = v["modes"].as_array().unwrap();
    assert_eq!(modes.len(), 3, "{v}");
    for (m, t) in modes.iter().zip(&truth) {
        let f = m["freq_hz"].as_f64().unwrap();
        let dmp = m["damping_per_s"].as_f64().unwrap();
        let a = m["amplitude"].as_f64().unwrap();
        assert!((f - t.freq_hz).abs() < 1e-3, "{f} vs {}", t.freq_hz);
        assert!(
            (dmp / t.damping_per_s - 1.0).abs() < 1e-3,
            "{dmp} vs {}",
            t.damping_per_s
        );
        assert!(
            (a / t.amplitude - 1.0).abs() < 1e-3,
            "{a} vs {}",
            t.amplitude
        );
        assert!(m["phase_rad"].is_number());
    }
    let png = std::fs::read(d.join("hit.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // JSON on stdout with "-"; resampling keeps the frequencies.
    let out = ok(&resound(
        &[
            "analyze",
            "hit.wav",
            "--json",
            "-",
            "--resample-hz",
            "44100",
        ],
        d,
    ));
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["sample_rate"], 44100.0);
    let f0 = v["modes"][0]["freq_hz"].as_f64().unwrap();
    assert!((f0 - 523.25).abs() < 0.01, "{f0}");
}

#[test]
fn analyze_bad_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("junk.wav"), b"RIFF\x10\x00\x00\x00WAVEjunkjunkjunk").unwrap();
    fails_with(
        &resound(&["analyze", "junk.wav", "--json", "o.json"], d),
        "junk.wav",
    );
    assert!(!d.join("o.json").exists());
    resound::io::write_wav(
        &d.join("silent.wav"),
        &vec![0.0f32; 48000],
        48000,
        resound::io::WavFormat::Pcm16,
    )
    .unwrap();
    fails_with(&resound(&["analyze", "silent.wav"], d), "silent");
    strike_wav(&d.join("short.wav"), 0.1, 480);
    fails_with(&resound(&["analyze", "short.wav"], d), "at least 20 ms");
    strike_wav(&d.join("hit.wav"), 0.0, 9600);
    fails_with(
        &resound(&["analyze", "hit.wav", "--strike", "2"], d),
        "only 1 strike",
    );
    fails_with(
        &resound(&["analyze", "hit.wav", "--channel", "3"], d),
        "channel 3 requested but the file has 1 channel(s) (channels count from 1)",
    );
    // Channels count from 1, like strikes (issue 37: they counted from 0 and 1).
    fails_with(
        &resound(&["analyze", "hit.wav", "--channel", "0"], d),
        "channels count from 1 (1 is the first), not 0",
    );
    fails_with(
        &resound(&["analyze", "hit.wav", "--strike", "0"], d),
        "strikes count from 1 (1 is the first), not 0",
    );
    ok(&resound(&["analyze", "hit.wav", "--channel", "1"], d));
    fails_with(
        &resound(&["analyze", "hit.wav", "--min-db=-5"], d),
        "min_db",
    );
    fails_with(&resound(&["analyze", "missing.flac"], d), "missing.flac");
}

#[test]
fn bench_analyze_reports_the_protocols() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&resound(
        &[
            "bench",
            "analyze",
            "--json",
            "--trials",
            "3",
            "--mixtures",
            "2",
            "--snr-db",
            "40",
            "--wide",
            "3",
            "--wide-snr-db",
            "60",
        ],
        dir.path(),
    ));
    let v: Value = serde_json::from_str(&out).unwrap();
    // The wide protocol and its textbook-ESPRIT baseline run the same cases.
    let (ours, esprit) = (&v["refined"]["wide"][0], &v["esprit"][0]);
    assert_eq!(ours["trials"], 3, "{v}");
    assert_eq!(esprit["trials"], 3, "{v}");
    assert_eq!(ours["reference_modes"], esprit["reference_modes"], "{v}");
    assert!(esprit["recall"].as_f64().unwrap() > 0.0, "{v}");
    for method in ["refined", "stage1"] {
        let single = &v[method]["single"];
        assert_eq!(single["trials"], 3);
        assert!(
            single["mean_freq_error_pct"].as_f64().unwrap() < 0.01,
            "{v}"
        );
        let mix = &v[method]["mixtures"][0];
        assert_eq!(mix["snr_db"], 40.0);
        for key in [
            "recall",
            "spurious",
            "median_freq_error_over_crb",
            "seconds_per_audio_second",
        ] {
            assert!(mix[key].is_number(), "{key}: {v}");
        }
    }
    assert!(
        v["refined"]["single"]["mean_freq_error_pct"]
            .as_f64()
            .unwrap()
            < 1e-6
    );
}

#[test]
fn estimate_recovers_a_known_material_and_fills_the_library() {
    use resound::core::{damped::synthesize, Material};
    use resound::estimate::{forward_modes, RayleighParams};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.3,0.02,0.01",
            "-o",
            "bar.obj",
        ],
        d,
    ));
    ok(&resound(
        &[
            "modal",
            "bar.obj",
            "--material",
            "steel",
            "--modes",
            "30",
            "-o",
            "bar.rmodal",
        ],
        d,
    ));
    let model = resound::io::model_file::load(&d.join("bar.rmodal")).unwrap();
    let sp = model.locate_hit([0.1, 0.0, 0.005], 0.01).unwrap();
    let steel = Material::preset("steel").unwrap();
    let gamma0 = steel.youngs_modulus / steel.density;
    let truth = RayleighParams {
        alpha: 4.0,
        beta: 4e-8,
        gamma: 0.8 * gamma0,
        sigma: 500.0,
    };
    let modes = forward_modes(
        &model.eigenvalues,
        &model.gains(&sp),
        gamma0,
        &truth,
        22050.0,
    );
    let x: Vec<f32> = synthesize(&modes, 44100.0, 44100)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let peak = x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(peak > 0.01 && peak < 1.0, "peak {peak}");
    resound::io::write_wav(
        &d.join("hit.wav"),
        &x,
        44100,
        resound::io::WavFormat::Float32,
    )
    .unwrap();
    let out = ok(&resound(
        &[
            "estimate",
            "hit.wav",
            "--mesh",
            "bar.rmodal",
            "--hit",
            "0.1,0,0.005",
            "--json",
            "--name",
            "barsteel",
            "-o",
            "barsteel.json",
            "--plot",
            "barsteel.png",
            "--library",
            "lib.sqlite",
        ],
        d,
    ));
    let png = std::fs::read(d.join("barsteel.png")).unwrap();
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 10_000,
        "{} bytes",
        png.len()
    );
    let v: Value = serde_json::from_str(&out).unwrap();
    for (key, want) in [
        ("alpha", truth.alpha),
        ("beta", truth.beta),
        ("gamma", truth.gamma),
        ("sigma", truth.sigma),
    ] {
        let got = v[key].as_f64().unwrap();
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "{key}: {got} vs {want}: {v}"
        );
    }
    assert!(v["starts"].as_u64().unwrap() >= 1 && v["elapsed_s"].is_number());
    assert!(d.join("barsteel.json").exists());
    // The estimate carries its residual; synthesis with the reference impact (default
    // impactor at 1 m/s) as an impulse reproduces the recording's level and modes.
    let saved: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("barsteel.json")).unwrap()).unwrap();
    assert!(
        saved["residual"]["samples"].is_array(),
        "no residual stored"
    );
    let synth = |v: &str, hit: &str, out: &str| -> Value {
        serde_json::from_str(&ok(&resound(
            &[
                "synth",
                "--material",
                "barsteel",
                "--library",
                "lib.sqlite",
                "--mesh",
                "bar.rmodal",
                "--hit",
                hit,
                "--contact",
                "impulse",
                "--velocity",
                v,
                "--duration",
                "1",
                "--sample-rate",
                "44100",
                "--format",
                "float",
                "--json",
                "-o",
                out,
            ],
            d,
        )))
        .unwrap()
    };
    let s1 = synth("0.25", "0.1,0,0.005", "s1.wav");
    assert_eq!(s1["residual"], "natural", "{s1}");
    let s2 = synth("0.5", "0.1,0,0.005", "s2.wav");
    let p1 = s1["peak"].as_f64().unwrap();
    let p2 = s2["peak"].as_f64().unwrap();
    assert!(
        (p2 / p1 - 2.0).abs() < 0.02,
        "twice the speed, twice the level: {p1} {p2}"
    );
    let other = synth("0.25", "-0.12,0,0.005", "s3.wav");
    assert_eq!(other["residual"], "dominant", "{other}");
    let analyse = |f: &str| -> Vec<Value> {
        let v: Value =
            serde_json::from_str(&ok(&resound(&["analyze", f, "--json", "-"], d))).unwrap();
        v["modes"].as_array().unwrap().clone()
    };
    let strongest = |m: &[Value]| {
        m.iter()
            .max_by(|a, b| {
                a["amplitude"]
                    .as_f64()
                    .unwrap()
                    .total_cmp(&b["amplitude"].as_f64().unwrap())
            })
            .unwrap()
            .clone()
    };
    let rec = strongest(&analyse("hit.wav"));
    let one = synth("1", "0.1,0,0.005", "s4.wav");
    assert!(one["gain_db"].as_f64().unwrap() == 0.0, "{one}");
    let syn = strongest(&analyse("s4.wav"));
    for key in ["freq_hz", "amplitude"] {
        let (a, b) = (rec[key].as_f64().unwrap(), syn[key].as_f64().unwrap());
        assert!(
            (a / b - 1.0).abs() < 0.03,
            "{key}: recording {a} vs synthesis {b}"
        );
    }
    // Analysed modes render back to themselves.
    ok(&resound(&["analyze", "hit.wav", "--json", "modes.json"], d));
    ok(&resound(
        &[
            "synth",
            "--modes",
            "modes.json",
            "--duration",
            "1",
            "--sample-rate",
            "44100",
            "-o",
            "m.wav",
        ],
        d,
    ));
    let back = strongest(&analyse("m.wav"));
    assert!(
        (back["freq_hz"].as_f64().unwrap() / rec["freq_hz"].as_f64().unwrap() - 1.0).abs() < 1e-4
    );
    fails_with(
        &resound(
            &[
                "synth",
                "--modes",
                "modes.json",
                "--velocity",
                "-1",
                "-o",
                "x.wav",
            ],
            d,
        ),
        "--velocity",
    );
    fails_with(
        &resound(
            &[
                "synth",
                "--material",
                "nosuch",
                "--library",
                "lib.sqlite",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0,0,0",
                "-o",
                "x.wav",
            ],
            d,
        ),
        "no material",
    );
    assert!(!d.join("x.wav").exists());
    let list = ok(&resound(
        &["materials", "list", "--library", "lib.sqlite"],
        d,
    ));
    for name in ["barsteel", "glass", "metal", "plastic", "porcelain", "wood"] {
        assert!(list.contains(name), "{list}");
    }
    let shown: Value = serde_json::from_str(&ok(&resound(
        &["materials", "show", "barsteel", "--library", "lib.sqlite"],
        d,
    )))
    .unwrap();
    assert_eq!(shown["provenance"]["mesh"], "bar.rmodal");
    ok(&resound(
        &[
            "materials",
            "export",
            "wood",
            "wood.json",
            "--library",
            "lib.sqlite",
        ],
        d,
    ));
    ok(&resound(
        &["materials", "remove", "wood", "--library", "lib.sqlite"],
        d,
    ));
    fails_with(
        &resound(
            &["materials", "remove", "wood", "--library", "lib.sqlite"],
            d,
        ),
        "no material",
    );
    // Removed from the library, the name still reaches the built-in.
    let list = ok(&resound(
        &["materials", "list", "--library", "lib.sqlite"],
        d,
    ));
    let wood = list.lines().find(|l| l.starts_with("wood ")).unwrap();
    assert!(wood.ends_with("(built-in)"), "{list}");
    ok(&resound(
        &[
            "materials",
            "import",
            "wood.json",
            "--library",
            "lib.sqlite",
        ],
        d,
    ));
    fails_with(
        &resound(
            &["materials", "import", "bar.obj", "--library", "lib.sqlite"],
            d,
        ),
        "not a material file",
    );
    fails_with(
        &resound(
            &[
                "estimate",
                "hit.wav",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0.1,0",
                "--library",
                "lib.sqlite",
            ],
            d,
        ),
        "x,y,z",
    );
}

#[test]
fn scene_renders_a_dropped_ball_and_names_bad_fields() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = r#"
duration = 1.0
[listener]
position = [0.0, 0.3, 0.5]

[[body]]
name = "table"
fixed = true
shape = { box = [0.6, 0.04, 0.4] }
material = "preset:wood"
density = 700
position = [0.0, -0.02, 0.0]
modes = 12

[[body]]
name = "ball"
shape = { sphere = 0.02 }
material = "preset:steel"
density = 7850
position = [0.0, 0.22, 0.0]
modes = 8
"#;
    std::fs::write(d.join("s.toml"), scene).unwrap();
    let args = [
        "scene",
        "s.toml",
        "-o",
        "s.wav",
        "--events",
        "ev.jsonl",
        "--library",
        "lib.sqlite",
        "--cache",
        "cache",
        "--json",
    ];
    let v: Value = serde_json::from_str(&ok(&resound(&args, d))).unwrap();
    assert!(v["impacts"].as_u64().unwrap() >= 1, "{v}");
    let clip = resound::io::load_audio(&d.join("s.wav")).unwrap();
    assert_eq!(clip.channels.len(), 2);
    let first: Value = serde_json::from_str(
        std::fs::read_to_string(d.join("ev.jsonl"))
            .unwrap()
            .lines()
            .next()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(first["kind"], "impact");
    let t = first["time_s"].as_f64().unwrap();
    assert!((t - (2.0f64 * 0.2 / 9.81).sqrt()).abs() < 3e-3, "{first}");
    // The modal models are cached: a second run finds them.
    assert!(std::fs::read_dir(d.join("cache")).unwrap().count() == 2);
    // The live path against a simulated device plays the same, one physics step late.
    let live: Value = serde_json::from_str(&ok(&resound(
        &[
            "scene",
            "s.toml",
            "-o",
            "live.wav",
            "--cache",
            "cache",
            "--simulate-device",
            "--block",
            "256",
            "--json",
        ],
        d,
    )))
    .unwrap();
    assert_eq!(live["live"]["latency_samples"], 200, "{live}");
    assert_eq!(live["live"]["late_steps"], 0, "{live}");
    assert_eq!(live["live"]["dropped_cues"], 0, "{live}");
    let played = resound::io::load_audio(&d.join("live.wav")).unwrap();
    for (a, b) in clip.channels.iter().zip(&played.channels) {
        assert_eq!(b.len(), a.len() + 200);
        let diff = a
            .iter()
            .zip(&b[200..])
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        // Both are levelled to −1 dBFS and written at 24 bits.
        assert!(diff < 1e-4, "live differs from offline by {diff}");
    }
    if !cfg!(feature = "live") {
        fails_with(&resound(&["scene", "s.toml", "--live"], d), "no live audio");
    }
    // A bad value names its line and field; nothing is written.
    std::fs::write(
        d.join("bad.toml"),
        scene.replace("density = 7850", "density = 0"),
    )
    .unwrap();
    let mut bad = args;
    bad[1] = "bad.toml";
    bad[3] = "bad.wav";
    fails_with(&resound(&bad, d), "line 19: body \"ball\".density");
    assert!(!d.join("bad.wav").exists());
    std::fs::write(
        d.join("bad.toml"),
        scene.replace("modes = 8", "modes = 8\ncolour = 3"),
    )
    .unwrap();
    fails_with(&resound(&bad, d), "colour");
}

#[test]
fn demo_runs_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = ok(&resound(
        &[
            "demo",
            "--out-dir",
            "out",
            "--library",
            "lib.sqlite",
            "--no-cache",
        ],
        d,
    ));
    assert!(out.contains("estimated the material"), "{out}");
    for f in [
        "recording.png",
        "estimate.png",
        "scene.png",
        "scene.wav",
        "strike.wav",
        "material.json",
        "events.jsonl",
        "summary.txt",
    ] {
        assert!(d.join("out").join(f).exists(), "{f} missing");
    }
    let list = ok(&resound(
        &["materials", "list", "--library", "lib.sqlite"],
        d,
    ));
    assert!(list.contains("demo-ramp"), "{list}");
    // Issue 19: the objects come to rest on the table and fall quiet there (contact
    // damping): 1 s after the last logged motion the scene is ≥ 40 dB below its level then.
    let clip = resound::io::load_audio(&d.join("out/scene.wav")).unwrap();
    let fs = f64::from(clip.sample_rate_hz);
    let last = std::fs::read_to_string(d.join("out/events.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            serde_json::from_str::<Value>(l).unwrap()["time_s"]
                .as_f64()
                .unwrap()
        })
        .fold(0.0f64, f64::max);
    let level = |t: f64| {
        let (a, b) = ((t * fs) as usize, ((t + 0.1) * fs) as usize);
        let e: f64 = clip
            .channels
            .iter()
            .flat_map(|c| &c[a..b.min(c.len())])
            .map(|&v| f64::from(v).powi(2))
            .sum();
        10.0 * (e / (b - a) as f64 + 1e-30).log10()
    };
    let drop_db = level(last) - level(last + 1.0);
    assert!(
        last + 1.1 < clip.frames() as f64 / fs && drop_db >= 40.0,
        "last motion at {last:.2} s; the tail fell {drop_db:.1} dB in 1 s"
    );
}

#[test]
fn pyimpact_tables_import_and_render_their_own_frequencies() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pyimpact");
    ok(&resound(
        &[
            "stats",
            "import-pyimpact",
            fixtures.to_str().unwrap(),
            "-o",
            "st",
        ],
        d,
    ));
    let stats = d.join("st/metal_3.stats.json");
    assert!(stats.exists());
    ok(&resound(
        &[
            "synth",
            "--stats",
            stats.to_str().unwrap(),
            "--duration",
            "1",
            "-o",
            "m.wav",
        ],
        d,
    ));
    let table: Value =
        serde_json::from_str(&std::fs::read_to_string(fixtures.join("metal_3_mm.json")).unwrap())
            .unwrap();
    let v: Value =
        serde_json::from_str(&ok(&resound(&["analyze", "m.wav", "--json", "-"], d))).unwrap();
    let found: Vec<f64> = v["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["freq_hz"].as_f64().unwrap())
        .collect();
    for cf in table["cf"].as_array().unwrap() {
        let cf = cf.as_f64().unwrap();
        assert!(
            found.iter().any(|f| (f - cf).abs() < 0.5),
            "{cf} not in {found:?}"
        );
    }
    // Fitting needs recordings with enough modes; a statistics file must be consistent.
    fails_with(
        &resound(
            &[
                "stats",
                "fit",
                "m.wav",
                "--material",
                "metal",
                "-o",
                "x.json",
            ],
            d,
        ),
        "at least 2 recordings",
    );
    // Scraping the same object: a faster trajectory is louder.
    std::fs::write(d.join("slow.csv"), "time_s,position_m\n0,0\n1,0.1\n").unwrap();
    std::fs::write(d.join("fast.csv"), "time_s,position_m\n0,0\n1,0.4\n").unwrap();
    let peak = |traj: &str| {
        let v: Value = serde_json::from_str(&ok(&resound(
            &[
                "scrape",
                "--stats",
                stats.to_str().unwrap(),
                "--trajectory",
                traj,
                "--duration",
                "1",
                "--json",
                "-o",
                "s.wav",
            ],
            d,
        )))
        .unwrap();
        v["peak"].as_f64().unwrap()
    };
    let (slow, fast) = (peak("slow.csv"), peak("fast.csv"));
    assert!(fast > 1.2 * slow, "{slow} {fast}");
    std::fs::write(d.join("bad.csv"), "time_s,position_m\n0,0\n1,x\n").unwrap();
    fails_with(
        &resound(
            &[
                "scrape",
                "--stats",
                stats.to_str().unwrap(),
                "--trajectory",
                "bad.csv",
                "-o",
                "z.wav",
            ],
            d,
        ),
        "line 3",
    );
    assert!(!d.join("z.wav").exists());
    // A scene body can sound from the statistics instead of a modal model.
    let scene = "duration = 0.6\n[[body]]\nname = \"floor\"\nfixed = true\nsound = false\nshape = { box = [0.5, 0.04, 0.5] }\nmaterial = \"preset:wood\"\ndensity = 700\nposition = [0, -0.02, 0]\n[[body]]\nname = \"can\"\nshape = { sphere = 0.03 }\nmaterial = \"preset:steel\"\nsound = { stats = \"st/metal_3.stats.json\" }\ndensity = 7850\nposition = [0, 0.2, 0]\n";
    std::fs::write(d.join("st.toml"), scene).unwrap();
    let v: Value = serde_json::from_str(&ok(&resound(
        &[
            "scene",
            "st.toml",
            "-o",
            "st.wav",
            "--library",
            "lib.sqlite",
            "--no-cache",
            "--keep-level",
            "--json",
        ],
        d,
    )))
    .unwrap();
    assert!(
        v["impacts"].as_u64().unwrap() >= 1 && v["peak"].as_f64().unwrap() > 0.0,
        "{v}"
    );
    std::fs::write(d.join("bad.stats.json"), "{\"material\": \"x\"}").unwrap();
    fails_with(
        &resound(&["synth", "--stats", "bad.stats.json", "-o", "y.wav"], d),
        "not a statistics file",
    );
}

/// Issue 37: no shell expands `impact:hit*.ogg` (the prefix is part of the word): the tool
/// does, keeping the kind on every match, and a pattern that matches nothing is an error.
#[test]
fn grains_expand_wildcards_behind_a_kind_prefix() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/recordings");
    for (src, dst) in [
        ("default_dug_metal.1.ogg", "hit1.ogg"),
        ("default_place_node_metal.1.ogg", "hit2.ogg"),
        ("default_dig_choppy.1.ogg", "other.ogg"),
    ] {
        std::fs::copy(assets.join(src), d.join(dst)).unwrap();
    }
    let v: Value = serde_json::from_str(&ok(&resound(
        &[
            "grains",
            "analyze",
            "impact:hit*.ogg",
            "-o",
            "g.grains",
            "--json",
        ],
        d,
    )))
    .unwrap();
    let recs = v["recordings"].as_array().unwrap();
    let names: Vec<&str> = recs.iter().map(|r| r["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["hit1", "hit2"], "{v}");
    assert!(recs.iter().all(|r| r["contact"] == "impact"), "{v}");
    fails_with(
        &resound(
            &["grains", "analyze", "impact:nohit*.ogg", "-o", "n.grains"],
            d,
        ),
        "matches no file",
    );
    assert!(!d.join("n.grains").exists());
}

#[test]
fn grains_analyze_resynth_and_drive_a_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/recordings");
    let files = [
        "steel_nut_M4_2.wav",
        "default_dig_choppy.1.ogg",
        "default_place_node_metal.1.ogg",
        "default_dug_metal.1.ogg",
    ];
    let mut args: Vec<String> = vec!["grains".into(), "analyze".into()];
    args.extend(
        files
            .iter()
            .map(|f| assets.join(f).to_string_lossy().into_owned()),
    );
    args.extend(["-o", "set.grains", "--json"].map(String::from));
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let v: Value = serde_json::from_str(&ok(&resound(&argv, d))).unwrap();
    // The ramp recording is continuous (rolling and sliding nuts): split in two parts.
    let recs = v["recordings"].as_array().unwrap();
    assert_eq!(recs.len(), 4);
    assert_eq!(recs[0]["contact"], "continuous");
    assert!(
        v["sinusoidal"].as_u64().unwrap() > 10 && v["impulsive"].as_u64().unwrap() > 10,
        "{v}"
    );
    // Every real recording is rebuilt from its grains and pattern (16-bit grains) to within
    // −35 dB spectral convergence.
    for r in recs {
        let sc = r["spectral_convergence_db"].as_f64().unwrap();
        assert!(sc < -35.0, "{r}");
    }
    assert!(v["compression_ratio"].as_f64().unwrap() > 0.0);
    // Time-scaling by 2 doubles the length within one grain (70 ms).
    let r1: Value = serde_json::from_str(&ok(&resound(
        &[
            "grains",
            "resynth",
            "set.grains",
            "--recording",
            "default_dug_metal.1",
            "-o",
            "x1.wav",
            "--json",
        ],
        d,
    )))
    .unwrap();
    ok(&resound(
        &[
            "grains",
            "resynth",
            "set.grains",
            "--recording",
            "3",
            "--time-scale",
            "2",
            "-o",
            "x2.wav",
        ],
        d,
    ));
    let x1 = resound::io::load_audio(&d.join("x1.wav")).unwrap();
    // One default for every file written (issue 37: grains wrote 32-bit float at 44.1 kHz,
    // everything else 24-bit PCM at 48 kHz); the dictionary keeps its recordings' 44.1 kHz.
    assert_eq!(
        (x1.sample_rate_hz, x1.codec.as_str()),
        (48_000, "pcm_s24le")
    );
    let n1 = x1.frames() as f64;
    // The report describes the file written.
    let fs1 = r1["sample_rate_hz"].as_f64().unwrap();
    assert!(
        (r1["duration_s"].as_f64().unwrap() * fs1 - n1).abs() < 1.0,
        "{r1} vs {n1} frames"
    );
    let n2 = resound::io::load_audio(&d.join("x2.wav")).unwrap().frames() as f64;
    assert!((n2 - 2.0 * n1).abs() <= 0.07 * 48_000.0, "{n1} → {n2}");
    fails_with(
        &resound(
            &[
                "grains",
                "resynth",
                "set.grains",
                "--recording",
                "nope",
                "-o",
                "y.wav",
            ],
            d,
        ),
        "no recording 'nope'",
    );
    assert!(!d.join("y.wav").exists());
    std::fs::write(d.join("junk.grains"), b"RSGRAIN\0 not really").unwrap();
    fails_with(
        &resound(&["grains", "info", "junk.grains"], d),
        "grain dictionary",
    );
    // A scene body sounding from the grains: silent until it lands, then heard.
    let scene = r#"
duration = 0.6
stereo = false
[listener]
position = [0.0, 0.3, 0.5]

[[body]]
name = "floor"
fixed = true
shape = { box = [1.0, 0.04, 1.0] }
material = "preset:wood"
density = 700
position = [0.0, -0.02, 0.0]
sound = false

[[body]]
name = "nut"
shape = { sphere = 0.01 }
material = "preset:steel"
density = 7850
position = [0.0, 0.3, 0.0]
sound = { grains = "set.grains" }
"#;
    std::fs::write(d.join("g.toml"), scene).unwrap();
    let v: Value = serde_json::from_str(&ok(&resound(
        &["scene", "g.toml", "-o", "g.wav", "--json"],
        d,
    )))
    .unwrap();
    assert!(v["impacts"].as_u64().unwrap() >= 1, "{v}");
    let clip = resound::io::load_audio(&d.join("g.wav")).unwrap();
    let x = &clip.channels[0];
    let t_hit = (2.0f64 * 0.29 / 9.81).sqrt();
    let hit = (t_hit * f64::from(clip.sample_rate_hz)) as usize;
    assert!(x[..hit - 500].iter().all(|&s| s == 0.0));
    assert!(x[hit..hit + 4800].iter().any(|&s| s.abs() > 0.01));
}

/// Regression tests named after the findings of issue 15 (ripgrep's `tests/regression.rs`).
mod regression {
    use super::*;
    use std::process::Stdio;

    /// The 300 × 20 × 10 mm bar as `bar.obj` in `d`.
    fn bar_obj(d: &Path) {
        ok(&resound(
            &[
                "mesh",
                "primitive",
                "bar",
                "--size",
                "0.3,0.02,0.01",
                "-o",
                "bar.obj",
            ],
            d,
        ));
    }

    #[test]
    fn issue_15_a_closed_pipe_ends_quietly_with_exit_0() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_obj(d);
        let mut child = Command::new(env!("CARGO_BIN_EXE_resound"))
            .args([
                "modal",
                "bar.obj",
                "-m",
                "steel",
                "--modes",
                "30",
                "--resolution",
                "30",
            ])
            .current_dir(d)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end before the table is printed (`| head -0`).
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(out.status.code(), Some(0), "{err}");
    }

    #[test]
    fn issue_15_an_output_never_overwrites_an_input_and_outputs_are_checked_first() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        strike_wav(&d.join("x.wav"), 0.05, 24_000);
        let before = std::fs::read(d.join("x.wav")).unwrap();
        fails_with(
            &resound(&["analyze", "x.wav", "--plot", "x.wav"], d),
            "both an input and an output",
        );
        assert_eq!(std::fs::read(d.join("x.wav")).unwrap(), before);
        fails_with(
            &resound(
                &["analyze", "x.wav", "--json", "m.json", "--plot", "m.json"],
                d,
            ),
            "two different outputs",
        );
        // A bad second output is found before anything is written.
        fails_with(
            &resound(
                &[
                    "analyze",
                    "x.wav",
                    "--json",
                    "m.json",
                    "--plot",
                    "no/such/dir/p.png",
                ],
                d,
            ),
            "does not exist",
        );
        assert!(!d.join("m.json").exists());
    }

    #[test]
    fn issue_15_library_entries_are_replaced_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let m = r#"{"name": "tin", "alpha": 2.0, "beta": 1e-7, "gamma": 2e7, "sigma": 1.0,
                    "damping_model": "rayleigh", "provenance": null}"#;
        std::fs::write(d.join("tin.json"), m).unwrap();
        let import = |extra: &[&str]| {
            let mut args = vec!["materials", "import", "tin.json", "--library", "lib.sqlite"];
            args.extend_from_slice(extra);
            resound(&args, d)
        };
        ok(&import(&[]));
        fails_with(&import(&[]), "--force");
        ok(&import(&["--force"]));
    }

    #[test]
    fn issue_15_read_only_commands_never_create_or_change_a_library() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        ok(&resound(
            &["materials", "list", "--library", "typo.sqlite"],
            d,
        ));
        assert!(!d.join("typo.sqlite").exists());
        // Without a library a name still reaches the built-ins; an unknown one is an error.
        ok(&resound(
            &["materials", "show", "wood", "--library", "typo.sqlite"],
            d,
        ));
        fails_with(
            &resound(&["materials", "show", "oak", "--library", "typo.sqlite"], d),
            "no material",
        );
        assert!(!d.join("typo.sqlite").exists());
        std::fs::write(d.join("notes.txt"), "not a database").unwrap();
        let out = resound(&["materials", "list", "--library", "notes.txt"], d);
        assert_eq!(out.status.code(), Some(2));
        assert_eq!(
            std::fs::read_to_string(d.join("notes.txt")).unwrap(),
            "not a database"
        );
    }

    #[test]
    fn issue_15_strikes_count_from_1_durations_need_a_sample_and_scales_are_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        strike_wav(&d.join("x.wav"), 0.05, 24_000);
        fails_with(
            &resound(&["analyze", "x.wav", "--strike", "10"], d),
            "strike 10 requested",
        );
        ok(&resound(&["analyze", "x.wav", "--json", "modes.json"], d));
        fails_with(
            &resound(
                &[
                    "synth",
                    "--modes",
                    "modes.json",
                    "--duration",
                    "1e-6",
                    "-o",
                    "s.wav",
                ],
                d,
            ),
            "one sample",
        );
        assert!(!d.join("s.wav").exists());
        bar_obj(d);
        fails_with(
            &resound(&["modal", "bar.obj", "-m", "steel", "--scale", "1e30"], d),
            "scale must be within",
        );
    }

    #[test]
    fn issue_15_an_os_error_is_reported_once() {
        let dir = tempfile::tempdir().unwrap();
        let out = resound(&["analyze", "missing.wav"], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2));
        assert_eq!(err.matches("No such file").count(), 1, "{err}");
    }

    #[test]
    fn issue_15_long_steps_print_plain_progress_lines_in_a_log() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_obj(d);
        // stderr is a pipe here, as in a log: indicatif draws nothing, so plain lines must come.
        let out = resound(&["modal", "bar.obj", "-m", "steel", "--modes", "5"], d);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(err.lines().any(|l| l.starts_with("modal: ")), "{err}");
    }

    #[test]
    fn issue_15_model_json_shows_no_placeholder_solve_figures() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_obj(d);
        let solved: Value = serde_json::from_str(&ok(&resound(
            &[
                "modal",
                "bar.obj",
                "-m",
                "steel",
                "--modes",
                "4",
                "--resolution",
                "30",
                "--json",
                "-o",
                "bar.rmodal",
            ],
            d,
        )))
        .unwrap();
        assert_eq!(solved["element"], "hex8i");
        assert!(solved["max_rel_residual"].as_f64().unwrap() > 0.0);
        let loaded: Value =
            serde_json::from_str(&ok(&resound(&["model", "bar.rmodal", "--json"], d))).unwrap();
        // A loaded model was not solved here: no element "", nnz 0 or residual 0.0.
        for key in ["element", "nnz", "max_rel_residual", "solve_s"] {
            assert!(loaded.get(key).is_none(), "{key}: {loaded}");
        }
        assert_eq!(loaded["dofs"], solved["dofs"]);
        assert!(loaded["load_ms"].as_f64().is_some());
    }

    /// `bar.rmodal`: the bar's first modes (wood reference), coarse.
    fn bar_model(d: &Path, resolution: &str) {
        bar_obj(d);
        ok(&resound(
            &[
                "modal",
                "bar.obj",
                "-m",
                "wood",
                "--modes",
                "3",
                "--resolution",
                resolution,
                "-o",
                "bar.rmodal",
            ],
            d,
        ));
    }

    fn peak_dbfs(path: &Path) -> f64 {
        let a = resound::io::load_audio(path).unwrap();
        let peak = a.channels[0].iter().fold(0.0f32, |p, v| p.max(v.abs()));
        20.0 * f64::from(peak).log10()
    }

    #[test]
    fn issue_15_built_in_materials_are_si_and_render_audibly_at_the_beam_pitch() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_model(d, "60");
        // Free–free Euler–Bernoulli bar bending through its 10 mm thickness:
        // f1 = 4.730² h / (2π L² √12) · √(E/ρ), with the built-ins' γ = E/ρ.
        let beam = |gamma: f64| {
            4.730f64.powi(2) * 0.01 / (std::f64::consts::TAU * 0.09 * 12f64.sqrt()) * gamma.sqrt()
        };
        for (name, gamma) in [("metal", 200e9 / 7850.0), ("wood", 11e9 / 750.0)] {
            // No library at all: built-ins are reachable by name.
            ok(&resound(
                &[
                    "synth",
                    "--material",
                    name,
                    "--library",
                    "none.sqlite",
                    "--mesh",
                    "bar.rmodal",
                    "--hit",
                    "0.05,0,0.005",
                    "-o",
                    "s.wav",
                ],
                d,
            ));
            assert!(!d.join("none.sqlite").exists());
            let level = peak_dbfs(&d.join("s.wav"));
            assert!((-30.0..-3.0).contains(&level), "{name}: {level} dBFS");
            ok(&resound(&["analyze", "s.wav", "--json", "a.json"], d));
            let a: Value =
                serde_json::from_str(&std::fs::read_to_string(d.join("a.json")).unwrap()).unwrap();
            let f1 = a["modes"][0]["freq_hz"].as_f64().unwrap();
            assert!(
                (f1 / beam(gamma) - 1.0).abs() < 0.03,
                "{name}: {f1} Hz vs {}",
                beam(gamma)
            );
        }
    }

    #[test]
    fn issue_15_a_legacy_mesh_unit_table_i_entry_is_an_error_that_says_how_to_fix_it() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_model(d, "30");
        // Ren's "metal" row as printed, as libraries were seeded before.
        let legacy = serde_json::json!({
            "name": "metal", "alpha": 6.3035, "beta": 2.1160e-8, "gamma": 4.5935e5,
            "sigma": 9.2624e-6, "damping_model": "rayleigh", "provenance": null
        });
        std::fs::write(d.join("metal.json"), legacy.to_string()).unwrap();
        ok(&resound(
            &[
                "materials",
                "import",
                "metal.json",
                "--force",
                "--library",
                "lib.sqlite",
            ],
            d,
        ));
        let list = ok(&resound(
            &["materials", "list", "--library", "lib.sqlite"],
            d,
        ));
        assert!(
            list.lines()
                .any(|l| l.starts_with("metal ") && l.contains("remove it")),
            "{list}"
        );
        let synth = [
            "synth",
            "--material",
            "metal",
            "--library",
            "lib.sqlite",
            "--mesh",
            "bar.rmodal",
            "--hit",
            "0.05,0,0.005",
            "-o",
            "s.wav",
        ];
        fails_with(&resound(&synth, d), "materials remove metal");
        assert!(!d.join("s.wav").exists());
        ok(&resound(
            &["materials", "remove", "metal", "--library", "lib.sqlite"],
            d,
        ));
        ok(&resound(&synth, d));
    }

    #[test]
    fn issue_15_a_render_below_minus_90_dbfs_is_a_warning() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_model(d, "30");
        let out: Value = serde_json::from_str(&ok(&resound(
            &[
                "synth",
                "--material",
                "preset:steel",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0.05,0,0.005",
                "--velocity",
                "1e-5",
                "-o",
                "s.wav",
                "--json",
            ],
            d,
        )))
        .unwrap();
        // A typed warning: its kind for programs, its words for people.
        assert_eq!(out["warnings"][0]["kind"], "quiet", "{out}");
        assert!(
            out["warnings"][0]["message"]
                .as_str()
                .unwrap()
                .contains("below -90 dBFS"),
            "{out}"
        );
        assert!(peak_dbfs(&d.join("s.wav")) < -90.0);
    }

    #[test]
    fn issue_15_a_384_khz_recording_is_resampled_on_request_without_bias() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let fs = 384_000.0;
        let x: Vec<f32> = (0..384_000)
            .map(|i| {
                let t = f64::from(i) / fs;
                (0.5 * (-20.0 * t).exp() * (std::f64::consts::TAU * 3000.0 * t).sin()) as f32
            })
            .collect();
        resound::io::write_wav(
            &d.join("hi.wav"),
            &x,
            384_000,
            resound::io::WavFormat::Float32,
        )
        .unwrap();
        fails_with(&resound(&["analyze", "hi.wav"], d), "--resample-hz 48000");
        ok(&resound(
            &[
                "analyze",
                "hi.wav",
                "--resample-hz",
                "44100",
                "--json",
                "a.json",
            ],
            d,
        ));
        let a: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("a.json")).unwrap()).unwrap();
        assert_eq!(a["sample_rate"], 44_100.0);
        let m = &a["modes"][0];
        assert!(
            (m["freq_hz"].as_f64().unwrap() - 3000.0).abs() < 0.05,
            "{m}"
        );
        assert!(
            (m["damping_per_s"].as_f64().unwrap() / 20.0 - 1.0).abs() < 0.005,
            "{m}"
        );
        assert!(
            (m["amplitude"].as_f64().unwrap() / 0.5 - 1.0).abs() < 0.01,
            "{m}"
        );
        // The noise floor stays far below the strike (the issue saw −64 dBFS after resampling).
        assert!(a["noise_rms"].as_f64().unwrap() < 1e-5, "{a}");
    }

    #[test]
    fn issue_15_grains_refuse_a_one_sample_or_silent_recording() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let f = resound::io::WavFormat::Float32;
        resound::io::write_wav(&d.join("one.wav"), &[0.5], 44_100, f).unwrap();
        resound::io::write_wav(&d.join("zero.wav"), &vec![0.0; 44_100], 44_100, f).unwrap();
        fails_with(
            &resound(
                &["grains", "analyze", "impact:one.wav", "-o", "o.grains"],
                d,
            ),
            "at least 20 ms",
        );
        fails_with(
            &resound(
                &["grains", "analyze", "impact:zero.wav", "-o", "o.grains"],
                d,
            ),
            "silent",
        );
        assert!(!d.join("o.grains").exists());
    }

    #[test]
    fn issue_15_a_mesh_with_too_many_modes_below_the_cutoff_is_refused_at_once() {
        // The teapot in unit scale (2 m) ran > 580 s at 4.3 GB: the modes below the cutoff
        // are now counted first (one factorization) and the solve refused with a hint.
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        ok(&resound(
            &[
                "mesh",
                "primitive",
                "box",
                "--size",
                "2,1.5,1",
                "-o",
                "big.obj",
            ],
            d,
        ));
        let out = resound(
            &[
                "modal",
                "big.obj",
                "-m",
                "steel",
                "--max-modes",
                "40",
                "--resolution",
                "24",
            ],
            d,
        );
        fails_with(&out, "eigenvalues below 20000 Hz, more than the 46 allowed");
        fails_with(&out, "--scale");
        // Asking for a count, or a lower cutoff, works.
        ok(&resound(
            &[
                "modal",
                "big.obj",
                "-m",
                "steel",
                "--modes",
                "5",
                "--resolution",
                "24",
            ],
            d,
        ));
    }

    #[test]
    fn issue_15_grains_refuse_recordings_whose_quadratic_cost_would_run_away() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let x: Vec<f32> = (0..8_000u64 * 121)
            .map(|i| ((i * 7919 % 1000) as f32 / 1000.0 - 0.5) * 0.1)
            .collect();
        resound::io::write_wav(
            &d.join("long.wav"),
            &x,
            8_000,
            resound::io::WavFormat::Float32,
        )
        .unwrap();
        fails_with(
            &resound(
                &["grains", "analyze", "rolling:long.wav", "-o", "o.grains"],
                d,
            ),
            "at most 120 s",
        );
        assert!(!d.join("o.grains").exists());
    }

    #[test]
    fn issue_15_scrape_irs_are_bounded_and_scenes_have_a_body_limit() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("t.csv"), "0,0\n1,0.2\n").unwrap();
        let stats = serde_json::json!({
            "material": "m", "modes": 1, "mean": [7.0, -20.0, 60.0],
            "covariance": [0.01, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], "sources": 2
        });
        std::fs::write(d.join("m.stats.json"), stats.to_string()).unwrap();
        fails_with(
            &resound(
                &[
                    "scrape",
                    "--stats",
                    "m.stats.json",
                    "--surface",
                    "fractal",
                    "--trajectory",
                    "t.csv",
                    "--irs",
                    "1000000000",
                    "-o",
                    "s.wav",
                ],
                d,
            ),
            "1–256",
        );
        let mut scene = String::from("duration = 0.1\nsample_rate = 48000\n");
        for i in 0..4097 {
            scene.push_str(&format!(
                "[[body]]\nname = \"b{i}\"\nshape = {{ sphere = 0.01 }}\nmaterial = \"preset:steel\"\ndensity = 7850\nposition = [0, {}, 0]\n",
                0.05 * f64::from(i)
            ));
        }
        std::fs::write(d.join("many.toml"), scene).unwrap();
        fails_with(
            &resound(&["scene", "many.toml", "-o", "m.wav", "--no-cache"], d),
            "at most 4096",
        );
    }

    #[test]
    fn issue_15_papercuts_get_clear_messages() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        bar_model(d, "20");
        // A negative coordinate is a value, not a flag (no "use '-- -1'" tip).
        let out = ok(&resound(
            &["model", "bar.rmodal", "--hit", "-0.04,0,0.005"],
            d,
        ));
        assert!(out.contains("gain"), "{out}");
        // A missing output directory: said once, naming the user's path, not a temporary one.
        let out = resound(
            &[
                "mesh",
                "primitive",
                "bar",
                "--size",
                "0.1,0.02,0.01",
                "-o",
                "nodir/x.obj",
            ],
            d,
        );
        fails_with(&out, "the directory nodir does not exist");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains(".resound-tmp") && err.matches("nodir/x.obj").count() == 1,
            "{err}"
        );
        // Mesh readers name what is wrong.
        std::fs::write(d.join("badf.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
        fails_with(
            &resound(&["mesh", "check", "badf.obj"], d),
            "line 4: face corner \"7\"",
        );
        std::fs::write(
            d.join("far.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1e30\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n",
        )
        .unwrap();
        fails_with(&resound(&["mesh", "check", "far.obj"], d), "vertex 4");
        ok(&resound(
            &[
                "mesh",
                "primitive",
                "bar",
                "--size",
                "0.1,0.02,0.01",
                "-o",
                "b.stl",
            ],
            d,
        ));
        let stl = std::fs::read(d.join("b.stl")).unwrap();
        std::fs::write(d.join("cut.stl"), &stl[..300]).unwrap();
        fails_with(
            &resound(&["mesh", "check", "cut.stl"], d),
            "truncated: the header promises 12 facets",
        );
        std::fs::write(
            d.join("few.ply"),
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
        )
        .unwrap();
        fails_with(
            &resound(&["mesh", "check", "few.ply"], d),
            "header's counts (vertex 3, face 1)",
        );
        // TOML errors keep toml's lines and caret.
        std::fs::write(
            d.join("bad.toml"),
            "duration = \"x\"\nsample_rate = 48000\n",
        )
        .unwrap();
        let out = resound(&["scene", "bad.toml", "-o", "x.wav"], d);
        fails_with(&out, "line 1, column 12");
        assert!(String::from_utf8_lossy(&out.stderr)
            .lines()
            .any(|l| l.contains("^^^")));
        // A DC-only recording is "constant", not "clipped".
        resound::io::write_wav(
            &d.join("dc.wav"),
            &vec![0.2f32; 4800],
            48_000,
            resound::io::WavFormat::Float32,
        )
        .unwrap();
        let out = resound(&["analyze", "dc.wav"], d);
        fails_with(&out, "constant");
        assert!(!String::from_utf8_lossy(&out.stderr).contains("clipped"));
        // `scene --help` shows the format instead of pointing at itself.
        let help = ok(&resound(&["scene", "--help"], d));
        assert!(
            help.contains("[[body]]") && !help.contains("see `resound scene --help`"),
            "{help}"
        );
        // Rescaling across presets: the ν mismatch says how to proceed, and --keep-nu does it.
        fails_with(
            &resound(&["model", "bar.rmodal", "-m", "steel"], d),
            "--keep-nu",
        );
        ok(&resound(
            &["model", "bar.rmodal", "-m", "steel", "--keep-nu"],
            d,
        ));
    }
}

#[test]
fn estimate_combines_microphones_and_files_into_one_material() {
    use resound::core::{damped::synthesize, Material};
    use resound::estimate::{forward_modes, RayleighParams};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.3,0.02,0.01",
            "-o",
            "bar.obj",
        ],
        d,
    ));
    ok(&resound(
        &[
            "modal",
            "bar.obj",
            "--material",
            "steel",
            "--modes",
            "30",
            "-o",
            "bar.rmodal",
        ],
        d,
    ));
    let model = resound::io::model_file::load(&d.join("bar.rmodal")).unwrap();
    let sp = model.locate_hit([0.1, 0.0, 0.005], 0.01).unwrap();
    let steel = Material::preset("steel").unwrap();
    let gamma0 = steel.youngs_modulus / steel.density;
    let truth = RayleighParams {
        alpha: 4.0,
        beta: 4e-8,
        gamma: 0.8 * gamma0,
        sigma: 500.0,
    };
    let modes = forward_modes(
        &model.eigenvalues,
        &model.gains(&sp),
        gamma0,
        &truth,
        22050.0,
    );
    let clean = synthesize(&modes, 44100.0, 44100);
    // Two microphones at different gains, each with its own noise (≈ 50 dB below the peak),
    // and a second, quieter take in another file.
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut mic = |gain: f64| -> Vec<f32> {
        clean
            .iter()
            .map(|&v| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                (gain * v + 3e-4 * (u - 0.5)) as f32
            })
            .collect()
    };
    let (left, right, other) = (mic(1.0), mic(0.4), mic(0.7));
    resound::io::write_wav_channels(
        &d.join("stereo.wav"),
        &[&left, &right],
        44100,
        resound::io::WavFormat::Float32,
    )
    .unwrap();
    resound::io::write_wav(
        &d.join("other.wav"),
        &other,
        44100,
        resound::io::WavFormat::Float32,
    )
    .unwrap();
    let run = resound(
        &[
            "estimate",
            "stereo.wav",
            "other.wav",
            "--every-channel",
            "--mesh",
            "bar.rmodal",
            "--hit",
            "0.1,0,0.005",
            "--no-residual",
            "--json",
        ],
        d,
    );
    let out = ok(&run);
    // The takes' poles are fitted jointly first (one f, d per mode for all three).
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("fitted jointly"), "{stderr}");
    let v: Value = serde_json::from_str(&out).unwrap();
    let takes = v["takes"].as_array().unwrap();
    assert_eq!(takes.len(), 3, "{v}");
    assert!(takes[1]["label"].as_str().unwrap().contains("channel 2"));
    for (key, want) in [
        ("alpha", truth.alpha),
        ("beta", truth.beta),
        ("gamma", truth.gamma),
    ] {
        let got = v[key].as_f64().unwrap();
        assert!(
            (got / want - 1.0).abs() < 0.03,
            "{key}: {got} vs {want}: {v}"
        );
    }
    // Each recording keeps its own amplitude scale: the microphones' gains come back.
    let sigma: Vec<f64> = takes.iter().map(|t| t["sigma"].as_f64().unwrap()).collect();
    for (k, gain) in [(1, 0.4), (2, 0.7)] {
        let ratio = sigma[k] / sigma[0];
        assert!(
            (ratio / gain - 1.0).abs() < 0.03,
            "σ ratio {ratio} vs {gain}: {v}"
        );
    }
    assert!(v["spread"]["gamma_rel_sd"].as_f64().unwrap() < 0.01, "{v}");
    assert!(v["fit"]["paired_modes"].as_u64().unwrap() >= 6, "{v}");
    // One channel of a stereo file and every strike of it are not both a channel choice.
    let out = resound(
        &[
            "estimate",
            "stereo.wav",
            "--every-channel",
            "--channel",
            "1",
            "--mesh",
            "bar.rmodal",
            "--hit",
            "0.1,0,0.005",
        ],
        d,
    );
    assert!(!out.status.success());
    // `compare` counts channels as `analyze` does: from 1.
    let same = |a: &str, b: &str| -> f64 {
        let out = ok(&resound(
            &[
                "compare",
                "stereo.wav",
                "stereo.wav",
                "--channel-a",
                a,
                "--channel-b",
                b,
                "--json",
            ],
            d,
        ));
        let v: Value = serde_json::from_str(&out).unwrap();
        v["distance"].as_f64().unwrap()
    };
    let (first, second) = (same("1", "1"), same("1", "2"));
    assert!(first < 1e-9, "channel 1 against itself: {first}");
    assert!(second > first, "channel 1 against channel 2: {second}");
    for (flag, k, needle) in [
        ("--channel-a", "0", "count from 1"),
        ("--channel-b", "3", "channels count from 1"),
    ] {
        fails_with(
            &resound(&["compare", "stereo.wav", "other.wav", flag, k], d),
            needle,
        );
    }
}

#[test]
fn bench_live_reports_callback_times_on_the_simulated_clock() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&resound(
        &[
            "bench",
            "live",
            "--json",
            "--bodies",
            "4",
            "--seconds",
            "0.5",
            "--max-bodies",
            "8",
        ],
        dir.path(),
    ));
    let v: Value = serde_json::from_str(&out).unwrap();
    let main = &v["main"];
    assert_eq!(main["bodies"], 4);
    // 0.5 s of 256-sample blocks at 48 kHz; every body struck every 50 ms, one rubbing at
    // every 200-sample physics step the frontend ran (120, one block ahead).
    assert_eq!(main["clock"]["callbacks"], 94);
    let events = main["events"].as_u64().unwrap();
    assert!((4 * 10 + 120..=4 * 11 + 121).contains(&events), "{v}");
    assert_eq!(main["dropped_events"], 0);
    assert_eq!(main["late_steps"], 0);
    // One physics step, plus the sample by which a resonator's output follows its force.
    assert_eq!(main["measured_latency_samples"], 201);
    let (p50, p99) = (
        main["clock"]["p50_share"].as_f64().unwrap(),
        main["clock"]["p99_share"].as_f64().unwrap(),
    );
    assert!(p50 > 0.0 && p50 <= p99, "{v}");
    assert!(!v["search"].as_array().unwrap().is_empty());
}

#[test]
fn issue_19_scenes_write_ambisonics_with_a_floor_and_reject_bad_air() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = r#"
duration = 0.5
ambisonics = true
[listener]
position = [0.0, 0.3, 0.5]
[floor]
height = -0.5
reflection = 0.9
[air]
temperature = 25.0
humidity = 40.0

[[body]]
name = "table"
fixed = true
shape = { box = [0.6, 0.04, 0.4] }
material = "preset:wood"
density = 700
position = [0.0, -0.02, 0.0]
modes = 12

[[body]]
name = "ball"
shape = { sphere = 0.02 }
material = "preset:steel"
density = 7850
position = [0.3, 0.22, 0.0]
modes = 8
"#;
    std::fs::write(d.join("s.toml"), scene).unwrap();
    ok(&resound(
        &["scene", "s.toml", "-o", "s.wav", "--library", "lib.sqlite"],
        d,
    ));
    let clip = resound::io::load_audio(&d.join("s.wav")).unwrap();
    assert_eq!(clip.channels.len(), 4, "W Y Z X");
    let energy = |c: &[f32]| c.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>();
    let e: Vec<f64> = clip.channels.iter().map(|c| energy(c)).collect();
    // The table sounds from below and in front of the listener, the ball from the right: W
    // carries everything, and no first-order channel exceeds it.
    assert!(
        e[0] > 0.0 && e[1..].iter().all(|&x| x <= e[0] * 1.0001),
        "{e:?}"
    );
    for (bad, what) in [
        ("[air]\nhumidity = 120.0\n", "humidity"),
        ("[floor]\nreflection = 1.5\n", "reflection"),
    ] {
        let text = scene
            .replace("[air]\ntemperature = 25.0\nhumidity = 40.0\n", "")
            .replace("[floor]\nheight = -0.5\nreflection = 0.9\n", bad);
        std::fs::write(d.join("bad.toml"), text).unwrap();
        let out = resound(&["scene", "bad.toml", "-o", "b.wav"], d);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(what), "{err}");
        assert!(!d.join("b.wav").exists());
    }
}

/// Issue 19: `estimate --mic` puts the microphone's radiation into the forward model. A steel
/// bar's strike as a microphone hears it (`synth --mic`) is estimated back with the same
/// microphone: the JSON reports it, γ is steel's, and the material file it writes is read by
/// `synth --mic`. A malformed `--mic` fails before any work.
#[test]
fn an_estimate_hears_the_strike_at_its_microphone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.2,0.04,0.02",
            "-o",
            "bar.obj",
        ],
        d,
    ));
    ok(&resound(
        &[
            "modal",
            "bar.obj",
            "-m",
            "steel",
            "--modes",
            "12",
            "--transfer",
            "-o",
            "bar.rmodal",
        ],
        d,
    ));
    let synth = |material: &str, out: &str| {
        ok(&resound(
            &[
                "synth",
                "--material",
                material,
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0.07,0.02,0.01",
                "--mic",
                "0.05,0.35,0.25",
                "--no-residual",
                "--duration",
                "1",
                "-o",
                out,
            ],
            d,
        ))
    };
    synth("steel", "heard.wav");
    let estimate = |mic: &str| {
        resound(
            &[
                "estimate",
                "heard.wav",
                "--mesh",
                "bar.rmodal",
                "--hit",
                "0.07,0.02,0.01",
                "--mic",
                mic,
                "--no-residual",
                "--json",
                "-o",
                "est.json",
            ],
            d,
        )
    };
    let v: Value = serde_json::from_str(&ok(&estimate("0.05,0.35,0.25"))).unwrap();
    assert_eq!(v["mic"], serde_json::json!([0.05, 0.35, 0.25]));
    assert!(v["passes"].as_u64().unwrap() >= 1, "{v}");
    let steel = resound::core::Material::preset("steel").unwrap();
    let gamma = steel.youngs_modulus / steel.density;
    let g = v["gamma"].as_f64().unwrap();
    assert!(
        (g / gamma - 1.0).abs() < 0.01,
        "γ {g:.4e}, steel {gamma:.4e}"
    );
    synth("est.json", "again.wav");
    assert!(d.join("again.wav").is_file());
    fails_with(&estimate("0.05,0.35"), "x,y,z");
    fails_with(&estimate("nan,0,0"), "x,y,z");
}

/// Issue 19: `radiation = true` in a scene fits each modal body's acoustic transfer once and
/// keeps it in the model cache; a thin plate, whose bending modes the equivalent sources cannot
/// fit (its thickness is far below their spacing), is named in a warning on every build, the
/// ball never. The output is what the scene renders.
#[test]
fn a_radiating_scene_warns_of_bodies_whose_transfer_is_uncertain_on_every_build() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = r#"
duration = 0.5
radiation = true
[listener]
position = [0.0, 0.3, 0.4]

[[body]]
name = "plate"
fixed = true
shape = { plate = [0.16, 0.1, 0.004] }
material = "preset:aluminium"
density = 2700
modes = 10

[[body]]
name = "ball"
shape = { sphere = 0.02 }
material = "preset:steel"
density = 7850
position = [0.0, 0.2, 0.0]
modes = 6
"#;
    std::fs::write(d.join("r.toml"), scene).unwrap();
    let run = || {
        let out = resound(
            &[
                "scene", "r.toml", "-o", "r.wav", "--cache", "cache", "--json",
            ],
            d,
        );
        let v: Value = serde_json::from_str(&ok(&out)).unwrap();
        (v, String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (first, err1) = run();
    assert!(first["impacts"].as_u64().unwrap() >= 1, "{first}");
    let (second, err2) = run();
    for err in [&err1, &err2] {
        assert!(
            err.contains("warning: body \"plate\": the acoustic transfer fits"),
            "{err}"
        );
        assert!(!err.contains("body \"ball\": the acoustic"), "{err}");
    }
    for v in [&first, &second] {
        let warnings = v["warnings"].as_array().unwrap();
        assert!(
            warnings.iter().any(|w| w["kind"] == "poor_transfer"
                && w["message"]
                    .as_str()
                    .unwrap()
                    .starts_with("body \"plate\": the acoustic")),
            "{v}"
        );
    }
    // The second build loaded the transfers from the cache: the same sound.
    assert_eq!(first["peak"], second["peak"]);
    assert!(second["build_s"].as_f64().unwrap() < first["build_s"].as_f64().unwrap());
}

#[test]
fn analyze_joint_shares_poles_between_files_and_refuses_mixed_rates() {
    use resound::core::{damped::synthesize, DampedMode};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // One object (a 0.1 % pair and a single mode) heard by two microphones with different
    // gains, one file at 48 kHz, the same at 44.1 kHz.
    let take = |gains: [f64; 3], fs: f64| -> Vec<f32> {
        let modes: Vec<DampedMode> = [(900.0, 4.0), (2000.0, 6.0), (2002.0, 7.0)]
            .iter()
            .zip(gains)
            .map(|(&(f, dmp), g)| DampedMode::new(f, dmp, 0.3 * g))
            .collect();
        let mut x = vec![0.0f32; 2000];
        x.extend(
            synthesize(&modes, fs, fs as usize)
                .iter()
                .map(|&v| v as f32),
        );
        let mut s = 7u64;
        x.iter_mut().for_each(|v| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v += 1e-4 * ((s >> 40) as f32 / (1u64 << 24) as f32 - 0.5);
        });
        x
    };
    let wav = |name: &str, x: &[f32], fs: u32| {
        resound::io::write_wav(&d.join(name), x, fs, resound::io::WavFormat::Float32).unwrap();
    };
    wav("a.wav", &take([1.0, 1.0, 0.3], 48000.0), 48000);
    wav("b.wav", &take([0.6, 0.4, 1.0], 48000.0), 48000);
    wav("c.wav", &take([0.6, 0.4, 1.0], 44100.0), 44100);
    let out = ok(&resound(
        &["analyze", "a.wav", "b.wav", "--joint", "--json", "-"],
        d,
    ));
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["takes"].as_array().unwrap().len(), 2, "{v}");
    let modes = v["modes"].as_array().unwrap();
    for (f, dmp) in [(900.0, 4.0), (2000.0, 6.0), (2002.0, 7.0)] {
        let m = modes
            .iter()
            .find(|m| (m["freq_hz"].as_f64().unwrap() - f).abs() < 0.2)
            .unwrap_or_else(|| panic!("{f} Hz missing: {v}"));
        let got = m["damping_per_s"].as_f64().unwrap();
        assert!((got / dmp - 1.0).abs() < 0.02, "{f} Hz: d {got}: {v}");
        assert_eq!(m["heard_in"], 2, "{m}");
        assert_eq!(m["disagree"], false, "{m}");
    }
    // Takes at two rates are refused with the way out; resampled, they fit.
    let out = resound(&["analyze", "a.wav", "c.wav", "--joint"], d);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--resample-hz"),
        "{err}"
    );
    ok(&resound(
        &[
            "analyze",
            "a.wav",
            "c.wav",
            "--joint",
            "--resample-hz",
            "48000",
        ],
        d,
    ));
    // Several files without --joint, and --joint with --plot, are refused.
    assert!(!resound(&["analyze", "a.wav", "b.wav"], d).status.success());
    assert!(
        !resound(&["analyze", "a.wav", "--joint", "--plot", "p.png"], d)
            .status
            .success()
    );
}

/// Issue 37: a mesh in millimetres read as metres (a 300 m bar, first mode 0.6 Hz) was made and
/// solved without a word. Both say so and name the scale; scaled, neither does.
#[test]
fn a_mesh_in_millimetres_read_as_metres_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let made = resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "300,20,10",
            "-o",
            "mm.stl",
        ],
        d,
    );
    ok(&made);
    let said = String::from_utf8_lossy(&made.stderr).into_owned();
    assert!(
        said.contains("300.000 m across") && said.contains("0.001"),
        "{said}"
    );
    let solved = resound(
        &["modal", "mm.stl", "--material", "glass", "--modes", "3"],
        d,
    );
    ok(&solved);
    let said = String::from_utf8_lossy(&solved.stderr).into_owned();
    assert!(said.contains("millimetres scale it by 0.001"), "{said}");
    // A strike of it says so too (the solve's warnings are the strike's).
    let args = "synth --material metal --mesh mm.stl --hit 150,0,5 -o mm.wav";
    let struck = resound(&args.split(' ').collect::<Vec<_>>(), d);
    ok(&struck);
    let said = String::from_utf8_lossy(&struck.stderr).into_owned();
    assert!(said.contains("300.000 m across"), "{said}");
    let scaled = resound(
        &[
            "modal",
            "mm.stl",
            "--scale",
            "0.001",
            "--material",
            "glass",
            "--modes",
            "3",
        ],
        d,
    );
    ok(&scaled);
    assert!(!String::from_utf8_lossy(&scaled.stderr).contains("across"));
    let small = resound(
        &[
            "mesh",
            "primitive",
            "sphere",
            "--size",
            "0.0005",
            "-o",
            "tiny.obj",
        ],
        d,
    );
    ok(&small);
    assert!(String::from_utf8_lossy(&small.stderr).contains("1.000 mm across"));
}

/// Issue 37: a hit off the object was refused only after the solve (6–12 s). It is refused
/// before any: no assembly or factorization is reported before the error.
#[test]
fn a_hit_off_the_surface_is_refused_before_any_solve() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cup(d);
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/recordings");
    std::fs::copy(assets.join("steel_nut_M4_2.wav"), d.join("strike.wav")).unwrap();
    for args in [
        &[
            "modal",
            "cup.obj",
            "--material",
            "ceramic",
            "--hit",
            "0.04,0,0.09",
        ][..],
        &[
            "synth",
            "--material",
            "preset:steel",
            "--mesh",
            "cup.obj",
            "--hit",
            "0.04,0,0.09",
            "-o",
            "x.wav",
        ],
        &[
            "estimate",
            "strike.wav",
            "--mesh",
            "cup.obj",
            "--hit",
            "0.04,0,0.09",
            "-o",
            "x.json",
        ],
    ] {
        let out = resound(args, d);
        fails_with(&out, "is 0.0450 m from the surface");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains("assembling") && !err.contains("factorizing"),
            "{args:?}: {err}"
        );
    }
    assert!(!d.join("x.wav").exists() && !d.join("x.json").exists());
    // On the surface (the side wall), the same commands run; `modal -o` says what it wrote,
    // as every other writer does.
    let args = "modal cup.obj --material ceramic --modes 4 --hit 0.04,0,0.03 -o cup.rmodal";
    let out = resound(&args.split(' ').collect::<Vec<_>>(), d);
    ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("wrote cup.rmodal (4 modes)"), "{err}");
    // Issue 38: a microphone inside the solid was accepted without a word; it is refused
    // before any solve, for a mesh and for a saved model alike.
    for (mesh, cmd) in [
        ("cup.obj", "synth"),
        ("cup.rmodal", "synth"),
        ("cup.obj", "estimate"),
    ] {
        let mut args: Vec<&str> = if cmd == "synth" {
            vec!["synth", "--material", "metal", "-o", "m.wav"]
        } else {
            vec!["estimate", "strike.wav", "-o", "m.json"]
        };
        args.extend(["--mesh", mesh, "--hit", "0.04,0,0.03", "--mic", "0,0,0.01"]);
        let out = resound(&args, d);
        fails_with(
            &out,
            "the microphone at [0.0, 0.0, 0.01] m is inside the object",
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("assembling"), "{args:?}: {err}");
    }
    assert!(!d.join("m.wav").exists() && !d.join("m.json").exists());
}

/// Issue 38: three inputs that panicked or aborted (exit 101/134) or rendered silence with exit
/// 0 are refused with a message: an impactor of 1e308 or 1e20 kg (a pulse of 33 GB), a scene
/// bowl thicker than its radius, a rotation of 1e300 rad (NaN in f32).
#[test]
fn absurd_impactors_bowls_and_rotations_are_refused_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cup(d);
    for mass in ["1e308", "1e20", "0"] {
        let flag = format!("--impactor-mass={mass}");
        let args = [
            "synth",
            "--material",
            "preset:steel",
            "--mesh",
            "cup.obj",
            "--hit",
            "0.04,0,0.03",
            &flag,
            "-o",
            "x.wav",
        ];
        fails_with(
            &resound(&args, d),
            "impactor mass must be in (0, 10 000] kg",
        );
    }
    assert!(!d.join("x.wav").exists());
    let scene = |body: &str| {
        format!(
            "duration = 0.3\n[listener]\nposition = [0.0, 0.3, 0.5]\n[[body]]\nname = \"floor\"\nfixed = true\nshape = {{ box = [1.0, 0.04, 1.0] }}\nmaterial = \"preset:wood\"\ndensity = 700\n[[body]]\nname = \"b\"\nmaterial = \"preset:ceramic\"\ndensity = 2400\nposition = [0.0, 0.3, 0.0]\n{body}\n"
        )
    };
    std::fs::write(
        d.join("bowl.toml"),
        scene("shape = { bowl = [0.1, 0.2, 0.05] }"),
    )
    .unwrap();
    fails_with(
        &resound(&["scene", "bowl.toml", "-o", "b.wav"], d),
        "bowl thickness 0.2 must be smaller than its radius 0.1",
    );
    std::fs::write(
        d.join("turn.toml"),
        scene("shape = { sphere = 0.03 }\nrotation = [1e300, 0.0, 0.0]"),
    )
    .unwrap();
    fails_with(
        &resound(&["scene", "turn.toml", "-o", "t.wav"], d),
        "rotation (axis × angle) must be at most 100 rad",
    );
    std::fs::write(d.join("huge.toml"), scene("shape = { sphere = 1e6 }")).unwrap();
    fails_with(
        &resound(&["scene", "huge.toml", "-o", "h.wav"], d),
        "the body is 2.000e6 m across, more than 1000 m",
    );
    assert!(!d.join("b.wav").exists() && !d.join("t.wav").exists() && !d.join("h.wav").exists());
}

/// Issue 38: the material library was an output like any file — `materials export x
/// "$RESOUND_LIBRARY"` replaced every entry with one JSON document (exit 0), as did `synth -o`,
/// `analyze --json` and `mesh primitive -o` on it — and `synth --material m.json -o m.json`
/// turned the material into a WAV. Each is refused before any work; both files survive.
#[test]
fn the_library_and_a_material_file_are_never_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lib = d.join(".test-library.sqlite");
    ok(&resound(&["materials", "export", "glass", "g.json"], d));
    let mine =
        std::fs::read_to_string(d.join("g.json"))
            .unwrap()
            .replacen("\"glass\"", "\"mine\"", 1);
    std::fs::write(d.join("m.json"), &mine).unwrap();
    ok(&resound(&["materials", "import", "m.json"], d));
    cup(d);
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/recordings");
    std::fs::copy(assets.join("steel_nut_M4_2.wav"), d.join("strike.wav")).unwrap();
    let lib_s = lib.to_str().unwrap();
    let synth = [
        "synth",
        "--material",
        "preset:steel",
        "--mesh",
        "cup.obj",
        "--hit",
        "0.04,0,0.03",
        "-o",
        lib_s,
    ];
    for args in [
        &["materials", "export", "mine", lib_s][..],
        &synth,
        &["analyze", "strike.wav", "--json", lib_s],
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.1,0.1,0.1",
            "-o",
            lib_s,
        ],
    ] {
        fails_with(&resound(args, d), "is the material library");
    }
    // An explicit library is protected as well, and a material file read is never written.
    let own = [
        "materials",
        "export",
        "mine",
        "own.sqlite",
        "--library",
        "own.sqlite",
    ];
    ok(&resound(
        &["materials", "import", "m.json", "--library", "own.sqlite"],
        d,
    ));
    fails_with(&resound(&own, d), "both an input and an output");
    let args = [
        "synth",
        "--material",
        "m.json",
        "--mesh",
        "cup.obj",
        "--hit",
        "0.04,0,0.03",
        "-o",
        "m.json",
    ];
    fails_with(&resound(&args, d), "both an input and an output");
    assert_eq!(std::fs::read_to_string(d.join("m.json")).unwrap(), mine);
    let listed = ok(&resound(&["materials", "list"], d));
    assert!(listed.contains("mine"), "{listed}");
    let listed = ok(&resound(
        &["materials", "list", "--library", "own.sqlite"],
        d,
    ));
    assert!(listed.contains("mine"), "{listed}");
}

/// Issue 38: messages that pointed at the wrong thing: `--max-modes=0` was "more than the 6
/// allowed" (a count of 27 against 0 + 6 rigid modes), a directory given as the library was
/// SQLite's "disk I/O error".
#[test]
fn a_zero_mode_cap_and_a_directory_library_are_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.3,0.02,0.01",
            "-o",
            "bar.obj",
        ],
        d,
    ));
    let out = resound(&["modal", "bar.obj", "-m", "steel", "--max-modes=0"], d);
    fails_with(&out, "the maximum mode count must be at least 1");
    assert!(!String::from_utf8_lossy(&out.stderr).contains("allowed"));
    // Issue 38: zero equivalent sources asked "is it closed?" of a closed mesh after the
    // solve; the setting is named before any solve now.
    let out = resound(
        &[
            "modal",
            "bar.obj",
            "-m",
            "steel",
            "--transfer",
            "--transfer-sources=0",
        ],
        d,
    );
    fails_with(&out, "0 equivalent sources: between 1 and 5000");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("closed") && !err.contains("assembling"),
        "{err}"
    );
    std::fs::create_dir(d.join("adir")).unwrap();
    let out = resound(&["materials", "list", "--library", "adir"], d);
    fails_with(&out, "is a directory; a material library is a file");
    assert!(!String::from_utf8_lossy(&out.stderr).contains("disk I/O"));
}

/// Issue 37: a strike peaking at −55 dBFS got no word (the warning started at −90). Below
/// −40 dBFS it is called faint, and `--normalize` brings the peak to −1 dBFS instead (no
/// level warning then: the level is chosen).
#[test]
fn a_faint_strike_is_named_and_normalize_brings_it_to_full_scale() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cup(d);
    let peak_dbfs = |p: &Path| {
        let a = resound::io::load_audio(p).unwrap();
        let peak = a.channels[0].iter().fold(0.0f32, |m, v| m.max(v.abs()));
        20.0 * f64::from(peak).log10()
    };
    let base = "synth --material metal --mesh cup.obj --hit 0.04,0,0.03 --json -o";
    let run = |extra: &str| -> Value {
        let args: Vec<&str> = base.split(' ').chain(extra.split(' ')).collect();
        serde_json::from_str(&ok(&resound(&args, d))).unwrap()
    };
    let faint = run("faint.wav");
    let peak = peak_dbfs(&d.join("faint.wav"));
    assert!((-90.0..-40.0).contains(&peak), "{peak} dBFS");
    let w = &faint["warnings"];
    assert!(
        w.as_array().unwrap().iter().any(|w| w["kind"] == "quiet"
            && w["message"]
                .as_str()
                .unwrap()
                .contains("below -40 dBFS: faint")),
        "{w}"
    );
    let loud = run("loud.wav --normalize");
    let peak = peak_dbfs(&d.join("loud.wav"));
    assert!((peak + 1.0).abs() < 0.1, "{peak} dBFS");
    assert!(
        loud["warnings"]
            .as_array()
            .is_none_or(|w| w.iter().all(|w| w["kind"] != "quiet")),
        "{loud}"
    );
}

/// The README's cup: a cylinder of radius 40 mm, 90 mm tall along z, centred on the origin.
fn cup(d: &Path) {
    let args = "mesh primitive cylinder --size 0.04,0.09 -o cup.obj";
    ok(&resound(&args.split(' ').collect::<Vec<_>>(), d));
}

/// Issue 37: three vocabularies (built-ins, `modal` presets, `materials list`) become one: every
/// name `materials list` shows is usable by `synth` and `modal`, and the list shows them all.
#[test]
fn one_material_vocabulary_every_name_listed_and_usable_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    cup(d);
    let list = ok(&resound(
        &["materials", "list", "--library", "lib.sqlite"],
        d,
    ));
    let names = [
        "aluminium",
        "ceramic",
        "glass",
        "metal",
        "plastic",
        "porcelain",
        "steel",
        "wood",
    ];
    for name in names {
        assert!(
            list.lines().any(|l| l.starts_with(&format!("{name} "))),
            "{name} missing from\n{list}"
        );
        let shown: Value = serde_json::from_str(&ok(&resound(
            &["materials", "show", name, "--library", "lib.sqlite"],
            d,
        )))
        .unwrap();
        assert_eq!(shown["name"], name);
        let wav = format!("{name}.wav");
        ok(&resound(
            &[
                "synth",
                "--material",
                name,
                "--mesh",
                "cup.obj",
                "--hit",
                "0.04,0,0.03",
                "--mesh-modes",
                "8",
                "-o",
                &wav,
            ],
            d,
        ));
        let rmodal = format!("{name}.rmodal");
        ok(&resound(
            &[
                "modal", "cup.obj", "-m", name, "--modes", "8", "-o", &rmodal,
            ],
            d,
        ));
    }
    // The names mean one thing everywhere: metal's modes are steel's, porcelain's ceramic's.
    let first_mode = |n: &str| -> f64 {
        let v: Value = serde_json::from_str(&ok(&resound(
            &["model", &format!("{n}.rmodal"), "--json"],
            d,
        )))
        .unwrap();
        v["modes"][0]["freq_hz"]
            .as_f64()
            .unwrap_or_else(|| panic!("{v}"))
    };
    assert_eq!(first_mode("metal"), first_mode("steel"));
    assert_eq!(first_mode("porcelain"), first_mode("ceramic"));
    assert!(first_mode("aluminium") != first_mode("steel"));
}

/// Issue 37: an estimate that pairs 1 of 26 recorded modes was stored with exit 0. Every
/// implausible finding now refuses the material (non-zero exit, nothing stored, no file
/// written) while the report still prints; `--allow-implausible` keeps it.
#[test]
fn an_implausible_estimate_prints_its_report_and_is_not_stored() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A struck wooden plate (13 modes found) …
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "plate",
            "--size",
            "0.2,0.15,0.004",
            "-o",
            "plate.obj",
        ],
        d,
    ));
    ok(&resound(
        &[
            "synth",
            "--material",
            "wood",
            "--mesh",
            "plate.obj",
            "--hit",
            "0.05,0.03,0.002",
            "-o",
            "strike.wav",
        ],
        d,
    ));
    // … estimated as a 0.4 m sphere: the sphere's few (degenerate) modes cannot match them.
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "sphere",
            "--size",
            "0.2",
            "-o",
            "big.obj",
        ],
        d,
    ));
    let args = "estimate strike.wav --mesh big.obj --hit 0.2,0,0 --modes 20 --name wrong \
                --library lib.sqlite -o wrong.json";
    let args: Vec<&str> = args.split_whitespace().collect();
    let out = resound(&args, d);
    fails_with(&out, "the estimate is not credible: only ");
    fails_with(&out, "recorded modes lie within 3 % of an estimated one");
    fails_with(&out, "--allow-implausible");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("recorded modes paired"), "{report}");
    // Nothing paired: no median of no errors (NaN) and no negative zero share.
    assert!(
        !report.contains("NaN") && !report.contains("-0 %"),
        "{report}"
    );
    assert!(!d.join("wrong.json").exists());
    let list = ok(&resound(
        &["materials", "list", "--library", "lib.sqlite"],
        d,
    ));
    assert!(!list.contains("wrong"), "{list}");
    let mut allowed = args.clone();
    allowed.push("--allow-implausible");
    ok(&resound(&allowed, d));
    assert!(d.join("wrong.json").exists());
    let list = ok(&resound(
        &["materials", "list", "--library", "lib.sqlite"],
        d,
    ));
    assert!(list.lines().any(|l| l.starts_with("wrong ")), "{list}");
}

/// Issue 37: a combined estimate warned that a take was left out and then listed it with a
/// σ of 1e25, and its count of recordings did not add up. Left-out takes are counted apart
/// and listed as left out; channels are labelled as `--channel` counts them (from 1).
/// The left-out take is made so: channel 2 only hums (one tone losing 0.3 1/s, 2.6 dB over
/// the second analysed), so no cell of its loudness image stands above its floor (twice the
/// band's tenth percentile), while channel 1 holds a strike.
#[test]
fn a_left_out_take_is_counted_apart_and_listed_as_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Channel 1: the three modes of `strike_wav` after 20 ms of silence.
    let modes = strike_wav(&d.join("mono.wav"), 0.02, 48000);
    let lead = 960;
    let mut left = vec![0.0f32; lead];
    left.extend(
        resound::core::damped::synthesize(&modes, 48000.0, 48000)
            .iter()
            .map(|&v| v as f32),
    );
    let hum: Vec<f32> = (0..left.len())
        .map(|i| {
            let t = i.saturating_sub(lead) as f64 / 48000.0;
            let on = if i >= lead { 1.0 } else { 0.0 };
            (on * 0.27 * (-0.3 * t).exp() * (std::f64::consts::TAU * 1811.0 * t).cos()) as f32
        })
        .collect();
    resound::io::write_wav_channels(
        &d.join("strike.wav"),
        &[&left, &hum],
        48000,
        resound::io::WavFormat::Pcm24,
    )
    .unwrap();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.1,0.03,0.005",
            "-o",
            "ramp.obj",
        ],
        d,
    ));
    let args = "estimate strike.wav --mesh ramp.obj --modes 80 --hit 0.02,0.01,0.0025 \
                --every-strike --every-channel --allow-implausible";
    let out = resound(&args.split_whitespace().collect::<Vec<_>>(), d);
    let report = ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    let warned: Vec<&str> = err.lines().filter(|l| l.contains("was left out")).collect();
    let listed: Vec<&str> = report
        .lines()
        .filter(|l| l.ends_with("left out (nothing above its floor)"))
        .collect();
    assert_eq!(warned.len(), 1, "the humming channel is left out: {err}");
    assert!(warned[0].contains("strike.wav channel 2 strike 1"), "{err}");
    assert_eq!(
        listed,
        ["  strike.wav channel 2 strike 1: left out (nothing above its floor)"]
    );
    assert!(listed.iter().all(|l| !l.contains("sigma")), "{report}");
    let takes = report
        .lines()
        .filter(|l| l.starts_with("  strike.wav"))
        .count();
    assert_eq!(takes, 2, "{report}");
    // One take remains: no spread of one value (it printed NaN %), and the count adds up.
    assert!(
        report.contains(
            "1 recording combined (2 analysed, 1 left out); one take cannot show a spread"
        ),
        "{report}"
    );
    assert!(!report.contains("NaN"), "{report}");
    // Labels and `--channel` count alike: the stereo file's channels are 1 and 2.
    assert!(
        report.contains("strike.wav channel 1 strike 1:"),
        "{report}"
    );
    assert!(!report.contains("channel 0"), "{report}");
    ok(&resound(&["analyze", "strike.wav", "--channel", "2"], d));
    fails_with(
        &resound(&["analyze", "strike.wav", "--channel", "3"], d),
        "has 2 channel(s)",
    );
}

/// Issue 38: `estimate -o`, `materials export`, `mesh primitive -o` and `--export-matrices`
/// created missing directories while `synth`, `analyze` and `modal -o` refused. One rule: an
/// output (file or directory) may be new, its parent directory must exist; nothing is made.
#[test]
fn a_missing_parent_directory_is_refused_by_every_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.1,0.02,0.01",
            "-o",
            "bar.obj",
        ],
        d,
    ));
    std::fs::write(
        d.join("jobs.jsonl"),
        r#"{"name":"a","mesh":"bar.obj","material":"metal","hits":[[0.05,0,0]],"modes":4}"#,
    )
    .unwrap();
    let cases: [&[&str]; 5] = [
        &[
            "mesh",
            "primitive",
            "bar",
            "--size",
            "0.1,0.1,0.1",
            "-o",
            "no/b.obj",
        ],
        &[
            "materials",
            "export",
            "metal",
            "no/m.json",
            "--library",
            "lib.sqlite",
        ],
        &[
            "modal",
            "bar.obj",
            "-m",
            "steel",
            "--modes",
            "4",
            "--export-matrices",
            "no/k",
        ],
        &[
            "modal",
            "bar.obj",
            "-m",
            "steel",
            "--modes",
            "4",
            "-o",
            "no/b.rmodal",
        ],
        &["batch", "jobs.jsonl", "--out", "no/sub"],
    ];
    for args in cases {
        let out = resound(args, d);
        fails_with(&out, "the directory no does not exist");
        assert!(!d.join("no").exists(), "{args:?} made it");
    }
    // The output directory itself may be new.
    ok(&resound(
        &[
            "modal",
            "bar.obj",
            "-m",
            "steel",
            "--modes",
            "4",
            "--export-matrices",
            "k",
        ],
        d,
    ));
    assert!(d.join("k/K.mtx").is_file() && d.join("k/M.mtx").is_file());
}

/// Issue 38: 4000 coincident spheres were still building after a minute at 1.2 GB; a body
/// inside another and a listener inside a body were accepted without a word. Bodies that start
/// deep inside one another and a listener inside a body are refused before any sound model
/// is built, and a scene whose gain tables would pass the memory budget is refused with the
/// estimate.
#[test]
fn overlapping_bodies_a_buried_listener_and_an_oversized_scene_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = |listener: &str, body: &str, n: usize, spread: bool| {
        let mut s = format!(
            "duration = 0.3\nstereo = false\n[listener]\nposition = {listener}\n\n\
             [[body]]\nname = \"floor\"\nfixed = true\nshape = {{ box = [8.0, 0.04, 8.0] }}\n\
             material = \"wood\"\ndensity = 700\nposition = [0.0, -0.02, 0.0]\nsound = false\n"
        );
        for i in 0..n {
            let (x, z) = if spread {
                ((i % 20) as f64 * 0.4 - 4.0, (i / 20) as f64 * 0.05 - 4.0)
            } else {
                (0.0, 0.0)
            };
            s += &format!(
                "\n[[body]]\nname = \"b{i}\"\n{body}\ndensity = 7850\nposition = [{x}, 0.3, {z}]\n"
            );
        }
        s
    };
    let sphere = "shape = { sphere = 0.02 }\nmaterial = \"metal\"";
    std::fs::write(
        d.join("coincident.toml"),
        scene("[0.0, 1.0, 2.0]", sphere, 4000, false),
    )
    .unwrap();
    fails_with(
        &resound(&["scene", "coincident.toml", "-o", "c.wav"], d),
        "body \"b1\": it starts 0.040 m deep inside body \"b0\"",
    );
    assert!(!d.join("c.wav").exists());
    std::fs::write(
        d.join("buried.toml"),
        scene("[0.0, -0.01, 0.0]", sphere, 2, true),
    )
    .unwrap();
    fails_with(
        &resound(&["scene", "buried.toml", "-o", "b.wav"], d),
        "the listener at [0.0, -0.01, 0.0] m is inside body \"floor\"",
    );
    // The same bodies apart, heard from the air: accepted.
    std::fs::write(
        d.join("apart.toml"),
        scene("[0.0, 1.0, 2.0]", sphere, 2, true),
    )
    .unwrap();
    ok(&resound(&["scene", "apart.toml", "-o", "a.wav"], d));
    // 4000 bars of 100 modes at ~1600 vertices: about 2.6 GiB of gains, refused at the first.
    let bar = "shape = { box = [0.3, 0.02, 0.01] }\nmaterial = \"metal\"\nmodes = 100";
    std::fs::write(
        d.join("many.toml"),
        scene("[0.0, 1.0, 2.0]", bar, 4000, true),
    )
    .unwrap();
    fails_with(
        &resound(&["scene", "many.toml", "-o", "m.wav"], d),
        "GiB of gain tables (body \"b0\"",
    );
}

/// Issue 36: `estimate` from a mesh file solves only the band it hears. A coarse solve places
/// the fundamental; the modes below the band's top in the material that puts the lowest
/// recorded mode on it are solved; when the first estimate shows that band fell short (the
/// fundamental was not recorded: here cut by a high-pass), the rest up to the top follow. Each
/// way finds the material the one-pass way finds (200 modes solved first, as a saved model
/// gives them). `synth` solves only what sounds below its Nyquist frequency.
#[test]
fn issue_36_an_estimate_from_a_mesh_file_solves_only_the_band_it_hears() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 3 mm steel ball rings far above hearing: said, not rendered silent.
    ok(&resound(
        &[
            "mesh",
            "primitive",
            "sphere",
            "--size",
            "0.003",
            "-o",
            "tiny.obj",
        ],
        d,
    ));
    fails_with(
        &resound(
            &[
                "synth",
                "--material",
                "steel",
                "--mesh",
                "tiny.obj",
                "--hit",
                "0.003,0,0",
                "-o",
                "t.wav",
            ],
            d,
        ),
        "no mode of this object sounds below 24000 Hz",
    );
    assert!(!d.join("t.wav").exists());
    let cases = [
        ("bar", "0.1,0.03,0.005", "steel", "0.03,0.01,0.0025", None),
        ("plate", "0.2,0.15,0.004", "wood", "0.05,0.03,0.002", None),
        (
            "plate",
            "0.2,0.15,0.004",
            "wood",
            "0.05,0.03,0.002",
            Some("500"),
        ),
    ];
    for (kind, size, material, hit, highpass) in cases {
        let mesh = format!("{kind}.obj");
        let wav = format!("{kind}.wav");
        let rmodal = format!("{kind}.rmodal");
        if !d.join(&wav).exists() {
            ok(&resound(
                &["mesh", "primitive", kind, "--size", size, "-o", &mesh],
                d,
            ));
            ok(&resound(
                &[
                    "synth",
                    "--material",
                    material,
                    "--mesh",
                    &mesh,
                    "--hit",
                    hit,
                    "-o",
                    &wav,
                ],
                d,
            ));
            ok(&resound(
                &[
                    "modal", &mesh, "-m", "ceramic", "--modes", "200", "-o", &rmodal,
                ],
                d,
            ));
        }
        let estimate = |object: &str| {
            let mut args = vec!["estimate", &wav, "--mesh", object, "--hit", hit];
            args.extend(["--no-residual", "--json"]);
            if let Some(hz) = highpass {
                args.extend(["--highpass-hz", hz]);
            }
            let out = resound(&args, d);
            let v: Value = serde_json::from_str(&ok(&out)).unwrap();
            (v, String::from_utf8_lossy(&out.stderr).into_owned())
        };
        let (v, err) = estimate(&mesh);
        let case = format!("{kind} high-pass {highpass:?}");
        let solved: usize = err
            .split("note: solved ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{case}: {err}"));
        assert!(solved < 200, "{case}: {solved} modes");
        let second = err.contains("in the material first estimated (the lowest");
        assert_eq!(second, highpass.is_some(), "{case}: {err}");
        if kind == "plate" {
            assert!(solved >= 30, "{case}: {solved} modes");
        }
        // The one-pass way: 200 modes solved first (a saved model is used as it is).
        let (one, _) = estimate(&rmodal);
        let truth = resound::strike::load_material_spec(material, None)
            .unwrap()
            .gamma;
        let g = v["gamma"].as_f64().unwrap();
        let tolerance = if highpass.is_some() { 0.02 } else { 1e-3 };
        assert!(
            (g / truth - 1.0).abs() < tolerance,
            "{case}: γ {g:.5e}, {material} {truth:.5e}"
        );
        for key in ["alpha", "beta", "gamma"] {
            let (a, b) = (v[key].as_f64().unwrap(), one[key].as_f64().unwrap());
            assert!(
                (a - b).abs() <= 0.02 * b.abs() + 1e-6,
                "{case} {key}: band {a:.5e}, one pass {b:.5e}"
            );
        }
    }
}
