//! Physical-law and reference tests of modal analysis (one test binary, STYLE.md §6).
// Test helpers may unwrap: a panic is a failed test (clippy's allow-unwrap-in-tests only
// covers #[test] functions themselves).
#![allow(clippy::unwrap_used)]

mod bad_input;
mod bar;
mod timoshenko;
