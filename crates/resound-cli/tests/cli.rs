//! End-to-end tests of the `resound` binary.
// Test helpers may unwrap: a panic is a failed test (clippy's allow-unwrap-in-tests only
// covers #[test] functions themselves).
#![allow(clippy::unwrap_used)]

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn resound(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_resound"))
        .args(args)
        .current_dir(dir)
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
    for cmd in ["modal", "mesh", "model", "bench"] {
        assert!(
            h.lines()
                .any(|l| l.trim_start().starts_with(cmd) && l.len() > cmd.len() + 20),
            "{cmd}: {h}"
        );
    }
}
