//! The standing sanity suite on real recordings nobody here made (issue 15): physical
//! properties that need no ground truth, end to end through the library.
//!
//! - Bundled in `assets/recordings/` (CC BY 4.0 and CC0, licence notes beside them): always run.
//! - From `../shared/data` (the RealImpact strikes come from a GPL-3.0 repository and stay out
//!   of ours): run when present, skipped with a message when absent. `RESOUND_SHARED_DATA`
//!   points elsewhere.
#![allow(clippy::unwrap_used)]

use resound::recording::{analyze_file, RecordingParams};
use resound::signal::AnalyzeParams;
use resound::strike::{render_strike, StrikeParams, Struck};
use std::path::{Path, PathBuf};

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/recordings")
}

/// `../shared/data` when it exists.
fn shared_data() -> Option<PathBuf> {
    let candidates = [
        std::env::var_os("RESOUND_SHARED_DATA").map(PathBuf::from),
        Some(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")),
        Some(PathBuf::from("/work/shared/data")),
    ];
    candidates.into_iter().flatten().find(|p| p.is_dir())
}

/// The bundled real recordings (all of them impacts or impact-like).
const BUNDLED: [&str; 4] = [
    "steel_nut_M4_2.wav",
    "default_dig_choppy.1.ogg",
    "default_dug_metal.1.ogg",
    "default_place_node_metal.1.ogg",
];

fn highpassed() -> AnalyzeParams {
    AnalyzeParams {
        highpass_hz: Some(60.0),
        ..Default::default()
    }
}

fn peak(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |p, v| p.max(v.abs()))
}

#[test]
fn every_bundled_recording_gives_physical_modes_at_a_plausible_level() {
    for name in BUNDLED {
        let path = assets().join(name);
        let (rec, a) = analyze_file(&path, &RecordingParams::default(), &highpassed()).unwrap();
        let fs = a.sample_rate_hz;
        assert!(!a.modes.is_empty(), "{name}: no modes");
        for m in &a.modes {
            assert!(
                m.freq_hz > 20.0 && m.freq_hz < 0.5 * fs,
                "{name}: {} Hz",
                m.freq_hz
            );
            assert!(
                m.damping_per_s.is_finite() && m.damping_per_s >= 0.0 && m.damping_per_s < 2e4,
                "{name}: d = {}",
                m.damping_per_s
            );
            // No fitted sinusoid is louder than the whole recording (allowing for beating
            // modes that partly cancel): a mode above it is a fit gone wrong.
            assert!(
                m.amplitude <= 4.0 * peak(&rec.samples),
                "{name}: amplitude {} vs peak {}",
                m.amplitude,
                peak(&rec.samples)
            );
        }
        // The noise floor lies below the strike (the ramp recording's "noise" is the rolling).
        let snr_db = 20.0 * (peak(&a.segment) / a.noise_rms.max(1e-12)).log10();
        assert!(snr_db > 10.0, "{name}: SNR {snr_db:.1} dB");
    }
}

#[test]
fn resynthesized_modes_sound_at_the_recorded_pitch_and_level() {
    for name in BUNDLED {
        let path = assets().join(name);
        let (_, a) = analyze_file(&path, &RecordingParams::default(), &highpassed()).unwrap();
        let fs = a.sample_rate_hz;
        let p = StrikeParams {
            duration_s: a.segment.len() as f64 / fs,
            sample_rate_hz: fs as u32,
            // The reference impact: the modes are rendered at the recording's own level.
            speed_m_s: 1.0,
            ..Default::default()
        };
        let s = render_strike(Struck::Modes(&a.modes), &p).unwrap();
        let y: Vec<f64> = s.samples.iter().map(|&v| f64::from(v)).collect();
        // Level: the modes hold most of a measured strike's peak (the transient adds the
        // rest). Not asserted on the game sounds: the metal clank analyses into one 13 kHz mode
        // at −20 dB re its peak (recall on real recordings is issue 16).
        let ratio_db = 20.0 * (peak(&y) / peak(&a.segment)).log10();
        assert!(ratio_db < 3.0, "{name}: {ratio_db:.1} dB");
        if name.ends_with(".wav") {
            assert!(ratio_db > -12.0, "{name}: {ratio_db:.1} dB");
        }
        // Pitch: analysing the rendering finds the recording's strongest well-resolved modes
        // again. (Modes closer than twice their summed −3 dB bandwidths, (d + d')/π, overlap:
        // the ramp recording's 4284/4309 Hz pair is re-fitted as one or the other — issue 16.)
        let again = resound::signal::analyze(&y, fs, &AnalyzeParams::default()).unwrap();
        let resolved = |m: &&resound::core::DampedMode| {
            a.modes.iter().all(|o| {
                o == *m
                    || (o.freq_hz - m.freq_hz).abs()
                        > 2.0 * (o.damping_per_s + m.damping_per_s) / std::f64::consts::PI
            })
        };
        let mut by_level: Vec<_> = a.modes.iter().filter(resolved).collect();
        by_level.sort_by(|x, y| y.amplitude.total_cmp(&x.amplitude));
        assert!(!by_level.is_empty(), "{name}: no resolved modes");
        for m0 in by_level.iter().take(4) {
            // Within 0.2 %, or a fifth of the mode's bandwidth d/π for the heavily damped ones
            // (the wood chop's modes decay at 85–1400 1/s: 30–450 Hz wide).
            let near = again
                .modes
                .iter()
                .map(|m| (m.freq_hz - m0.freq_hz).abs())
                .fold(f64::INFINITY, f64::min);
            let tol = (2e-3 * m0.freq_hz).max(0.2 * m0.damping_per_s / std::f64::consts::PI);
            assert!(
                near < tol,
                "{name}: {} Hz not found again ({near:.1} Hz off)",
                m0.freq_hz
            );
        }
    }
}

#[test]
fn issue_15_stats_fitted_to_real_ceramic_strikes_put_the_transient_where_the_modes_are() {
    let Some(data) = shared_data() else {
        eprintln!("skipped: ../shared/data is absent (RealImpact strikes are not bundled: GPL)");
        return;
    };
    let dir = data.join("recordings/realimpact-mesheditor");
    let files: Vec<PathBuf> = [
        "CeramicKoiBowlImpact.wav",
        "PitcherCeramicImpact.wav",
        "CupImpact.wav",
    ]
    .iter()
    .map(|f| dir.join(f))
    .collect();
    if !files.iter().all(|f| f.is_file()) {
        eprintln!("skipped: {} lacks the RealImpact strikes", dir.display());
        return;
    }
    let stats = resound::files::fit_stats(&files, "ceramic", 15, Some(100.0), &|_| {}).unwrap();
    let t = stats.transient.as_ref().unwrap();
    // Band levels are RMS re full scale: none above the recordings' peaks (they peak at −1.4
    // to 0 dBFS); the issue saw +99 to +149 dB.
    assert!(
        t.onset_db_mean.iter().all(|&v| v <= 0.0),
        "{:?}",
        t.onset_db_mean
    );
    // The modes are 3–23 kHz: the synthesized strike's energy is there too, not below 500 Hz
    // (the issue saw all of it there).
    let p = StrikeParams {
        duration_s: 1.0,
        ..Default::default()
    };
    for seed in 0..4 {
        let s = render_strike(
            Struck::Stats {
                stats: &stats,
                seed,
            },
            &p,
        )
        .unwrap();
        let x: Vec<f64> = s.samples.iter().map(|&v| f64::from(v)).collect();
        let mut high = x.clone();
        resound::signal::filter::highpass_zero_phase(&mut high, 500.0, 48_000.0);
        let e = |v: &[f64]| v.iter().map(|s| s * s).sum::<f64>();
        let below = 1.0 - e(&high) / e(&x);
        assert!(
            below < 0.05,
            "seed {seed}: {:.1} % below 500 Hz",
            100.0 * below
        );
    }
}
