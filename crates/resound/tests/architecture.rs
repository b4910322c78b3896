//! The workspace's shape, read from `cargo metadata`: dependencies point down the stage list
//! (ARCHITECTURE.md), and the file-format crate does not drag the runtime or the estimator in.
#![allow(clippy::unwrap_used)]

use std::collections::{BTreeMap, BTreeSet};

/// The stage list, bottom first. A crate may depend only on crates before it.
const ORDER: &[&str] = &[
    "resound-core",
    "resound-fem",
    "resound-modal",
    "resound-signal",
    "resound-grains",
    "resound-synth",
    "resound-estimate",
    "resound-stats",
    "resound-physics",
    "resound-io",
    "resound-plot",
    "resound",
    "resound-bench",
    "resound-bevy",
    "resound-studio",
    "resound-cli",
    "resound-py",
];

/// Normal (not dev or build) dependencies of each workspace crate on workspace crates.
fn workspace_edges() -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let names: BTreeSet<String> = v["packages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    let mut edges = BTreeMap::new();
    for p in v["packages"].as_array().unwrap() {
        let deps: BTreeSet<String> = p["dependencies"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| d["kind"].is_null())
            .map(|d| d["name"].as_str().unwrap().to_string())
            .filter(|n| names.contains(n))
            .collect();
        edges.insert(p["name"].as_str().unwrap().to_string(), deps);
    }
    edges
}

#[test]
fn dependencies_point_down_the_stage_list() {
    let edges = workspace_edges();
    let rank = |n: &str| ORDER.iter().position(|o| *o == n);
    for name in edges.keys() {
        assert!(
            rank(name).is_some(),
            "{name} is not in the stage list (ARCHITECTURE.md, this test)"
        );
    }
    let mut upward = Vec::new();
    for (from, deps) in &edges {
        for to in deps {
            if rank(to) >= rank(from) {
                upward.push(format!("{from} → {to}"));
            }
        }
    }
    assert!(
        upward.is_empty(),
        "dependencies pointing up the stage list: {upward:?}"
    );
}

#[test]
fn the_file_crate_does_not_pull_in_synthesis_or_estimation() {
    let edges = workspace_edges();
    let mut seen = BTreeSet::new();
    let mut stack = vec!["resound-io".to_string()];
    while let Some(n) = stack.pop() {
        for d in &edges[&n] {
            if seen.insert(d.clone()) {
                stack.push(d.clone());
            }
        }
    }
    for banned in [
        "resound-synth",
        "resound-estimate",
        "resound-physics",
        "resound-modal",
    ] {
        assert!(
            !seen.contains(banned),
            "resound-io depends on {banned} (through {seen:?})"
        );
    }
}

#[test]
fn numeric_crates_do_no_io() {
    // STYLE.md §1: the numeric crates take slices and return values.
    let edges = workspace_edges();
    for n in [
        "resound-fem",
        "resound-modal",
        "resound-signal",
        "resound-estimate",
        "resound-synth",
    ] {
        assert!(
            !edges[n].contains("resound-io"),
            "{n} depends on resound-io"
        );
    }
}
