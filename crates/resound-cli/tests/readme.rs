//! Issue 37: every line of the README's examples block runs as written, from the top of a
//! checkout, in order (each line may use what an earlier one wrote), so a README line can
//! never silently rot. The benchmarks and the studio are the only lines not run (listed in
//! `not_run` with the reason).
// Test helpers may unwrap: a panic is a failed test.
#![allow(clippy::unwrap_used)]
#![cfg(unix)]

use std::path::Path;
use std::process::Command;

/// Why a line is not run, or `None` when it is.
fn not_run(line: &str) -> Option<&'static str> {
    if line.starts_with("resound bench ") {
        Some("a benchmark: minutes of work on a quiet machine")
    } else if line.starts_with("resound studio") {
        Some("serves until stopped: crates/resound-studio/browser/run.sh drives the studio")
    } else {
        None
    }
}

/// The text between the first fence that opens with `open` after `heading` and its close.
fn block<'a>(text: &'a str, heading: &str, open: &str) -> &'a str {
    let from = text
        .find(heading)
        .unwrap_or_else(|| panic!("no '{heading}' in README.md"));
    let start = text[from..].find(open).unwrap() + from + open.len();
    let end = text[start..].find("```").unwrap() + start;
    &text[start..end]
}

#[test]
fn every_readme_example_runs_as_written() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let examples = block(&readme, "## Examples", "```sh\n");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The top of a checkout: its assets.
    std::os::unix::fs::symlink(root.join("assets"), d.join("assets")).unwrap();
    // `path/to/material_data` stands for the user's PyImpact tables: the tests' copy of one.
    std::fs::create_dir_all(d.join("path/to")).unwrap();
    std::os::unix::fs::symlink(
        root.join("crates/resound-cli/tests/fixtures/pyimpact"),
        d.join("path/to/material_data"),
    )
    .unwrap();
    // jobs.jsonl: the README's own jobs line (its JSON block, shown wrapped, on one line).
    let job = block(&readme, "### Datasets", "```json\n").replace('\n', "");
    std::fs::write(d.join("jobs.jsonl"), format!("{job}\n")).unwrap();
    let mut ran = 0;
    for line in examples.lines() {
        let command = line.split("  #").next().unwrap().trim();
        if command.is_empty() || not_run(command).is_some() {
            continue;
        }
        let words: Vec<&str> = command.split_whitespace().collect();
        match words[0] {
            "cp" => {
                assert_eq!(words.len(), 3, "{line}");
                std::fs::copy(d.join(words[1]), d.join(words[2])).unwrap();
            }
            "resound" => {
                let out = Command::new(env!("CARGO_BIN_EXE_resound"))
                    .args(&words[1..])
                    .current_dir(d)
                    .env("RESOUND_LIBRARY", d.join("library.sqlite"))
                    .env("XDG_CACHE_HOME", d.join(".cache"))
                    .output()
                    .unwrap();
                let err = String::from_utf8_lossy(&out.stderr);
                assert!(
                    out.status.success() && !err.contains("panicked"),
                    "README line failed: {line}\n{err}"
                );
                // What a line writes is there (and the later lines read it).
                if let Some(i) = words.iter().position(|w| *w == "-o") {
                    let path = d.join(words[i + 1]);
                    assert!(path.exists(), "{line}: wrote no {}", path.display());
                }
            }
            other => panic!("README line starts with '{other}': the test runs resound and cp"),
        }
        ran += 1;
    }
    let skipped = examples
        .lines()
        .filter(|l| not_run(l.trim()).is_some())
        .count();
    assert!(ran >= 30 && skipped <= 12, "{ran} lines run, {skipped} not");
}
