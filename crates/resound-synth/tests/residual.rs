//! Ren §6 residual: computation, transfer, Griffin–Lim.
#![allow(clippy::unwrap_used)]

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use resound_core::damped::synthesize;
use resound_core::{DampedMode, Residual};
use resound_estimate::image::{image_of_signal, ImageGrid};
use resound_estimate::residual::compute_residual;
use resound_estimate::{estimate, forward_modes, EstimateParams, ModalSide, RayleighParams};
use resound_signal::sine_stft::{griffin_lim, spectral_error, window_len_for, Stft};
use resound_synth::render::{bank_modes, render_strike};
use resound_synth::residual::{GriffinLim, Pairing, ResidualSource};

const FS: f64 = 48_000.0;

/// A decaying noise burst, low-passed by a one-pole (a strike's "thud" and click).
fn burst(n: usize, decay_per_s: f64, level: f64, seed: u64) -> Vec<f64> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut y = 0.0;
    (0..n)
        .map(|i| {
            let w: f64 = rng.random::<f64>() * 2.0 - 1.0;
            y = 0.7 * y + 0.3 * w;
            level * y * (-decay_per_s * i as f64 / FS).exp()
        })
        .collect()
}

fn magnitudes(stft: &mut Stft, x: &[f32]) -> Vec<f32> {
    let mut s = Vec::new();
    stft.forward(x, &mut s);
    s.iter().map(|c| c.norm()).collect()
}

#[test]
fn plain_griffin_lim_never_gets_worse_and_the_fast_one_gets_further() {
    let mut x: Vec<f32> = burst(24_000, 20.0, 0.3, 3)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let tone = synthesize(&[DampedMode::new(1234.0, 8.0, 0.2)], FS, 24_000);
    x.iter_mut().zip(&tone).for_each(|(a, b)| *a += *b as f32);
    let mut stft = Stft::new(window_len_for(FS));
    let s = magnitudes(&mut stft, &x);
    let budget = 30;
    let mut plain = Vec::new();
    griffin_lim(
        &mut stft,
        &s,
        None,
        x.len(),
        &GriffinLim {
            iterations: budget,
            momentum: 0.0,
        },
        Some(&mut plain),
    );
    for w in plain.windows(2) {
        assert!(w[1] <= w[0] * (1.0 + 1e-4), "plain GL got worse: {plain:?}");
    }
    assert!(plain[budget - 1] < plain[0]);
    let mut fast = Vec::new();
    griffin_lim(
        &mut stft,
        &s,
        None,
        x.len(),
        &GriffinLim {
            iterations: budget,
            momentum: 0.99,
        },
        Some(&mut fast),
    );
    eprintln!(
        "spectral error after {budget}: plain {:.4}, fast {:.4}",
        plain[budget - 1],
        fast[budget - 1]
    );
    assert!(
        fast[budget - 1] < plain[budget - 1],
        "fast {} vs plain {}",
        fast[budget - 1],
        plain[budget - 1]
    );
}

/// Noise bands around each source mode (what a residual near modes looks like), decaying.
fn source_residual() -> Residual {
    let modes = vec![
        DampedMode::new(800.0, 20.0, 0.3),
        DampedMode::new(2100.0, 35.0, 0.2),
        DampedMode::new(5200.0, 80.0, 0.1),
    ];
    let n = 9600;
    let mut samples = vec![0.0f32; n];
    for (i, m) in modes.iter().enumerate() {
        let mut rng = SmallRng::seed_from_u64(7 + i as u64);
        let mut y = 0.0;
        for (k, s) in samples.iter_mut().enumerate() {
            let t = k as f64 / FS;
            y = 0.97 * y + 0.03 * (rng.random::<f64>() * 2.0 - 1.0);
            *s += (m.amplitude
                * y
                * (-60.0 * t).exp()
                * (std::f64::consts::TAU * m.freq_hz * t).sin()) as f32;
        }
    }
    Residual {
        sample_rate_hz: FS,
        samples,
        source_modes: modes,
    }
}

#[test]
fn identity_transfer_reproduces_the_source_residual() {
    let r = source_residual();
    let mut src = ResidualSource::new(&r);
    let out = src.transfer(&r.source_modes, Pairing::Natural, &GriffinLim::default());
    let mut stft = Stft::new(window_len_for(FS));
    let want = magnitudes(&mut stft, &r.samples);
    let err = spectral_error(&mut stft, &out, &want);
    let sc_db = -20.0 * err.log10();
    eprintln!("identity transfer: spectral convergence {sc_db:.1} dB");
    assert!(sc_db >= 20.0, "spectral convergence {sc_db:.1} dB");
    // Dominant pairing of the same modes is the identity too.
    let out = src.transfer(
        &r.source_modes,
        Pairing::Dominant(8),
        &GriffinLim::default(),
    );
    let sc_db = -20.0 * spectral_error(&mut stft, &out, &want).log10();
    assert!(sc_db >= 20.0, "spectral convergence {sc_db:.1} dB");
}

#[test]
fn transfer_follows_the_modes_in_frequency_level_and_decay() {
    let r = source_residual();
    let mut src = ResidualSource::new(&r);
    let energy = |x: &[f32]| x.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>();
    let base = energy(&src.transfer(&r.source_modes, Pairing::Natural, &GriffinLim::default()));
    // Every target mode twice as loud: four times the residual energy.
    let louder: Vec<DampedMode> = r
        .source_modes
        .iter()
        .map(|m| DampedMode {
            amplitude: 2.0 * m.amplitude,
            ..*m
        })
        .collect();
    let e = energy(&src.transfer(&louder, Pairing::Natural, &GriffinLim::default()));
    assert!((e / base / 4.0 - 1.0).abs() < 0.05, "{}", e / base);
    // Twice the damping everywhere: half as long, about half the energy.
    let faster: Vec<DampedMode> = r
        .source_modes
        .iter()
        .map(|m| DampedMode {
            damping_per_s: 2.0 * m.damping_per_s,
            ..*m
        })
        .collect();
    let out = src.transfer(&faster, Pairing::Natural, &GriffinLim::default());
    assert!(
        out.len() * 2 <= r.samples.len() + 2048,
        "{} vs {}",
        out.len(),
        r.samples.len()
    );
    let e = energy(&out);
    assert!(e < 0.65 * base && e > 0.35 * base, "{}", e / base);
    // All modes up an octave: the residual's spectral centroid rises.
    let centroid = |x: &[f32]| {
        let mut stft = Stft::new(window_len_for(FS));
        let s = magnitudes(&mut stft, x);
        let bins = stft.bins();
        let (mut num, mut den) = (0.0, 0.0);
        for (i, v) in s.iter().enumerate() {
            let p = f64::from(*v).powi(2);
            num += p * (i % bins) as f64;
            den += p;
        }
        num / den * FS / stft.window_len() as f64
    };
    let up: Vec<DampedMode> = r
        .source_modes
        .iter()
        .map(|m| DampedMode {
            freq_hz: 2.0 * m.freq_hz,
            ..*m
        })
        .collect();
    let c0 = centroid(&r.samples);
    let c1 = centroid(&src.transfer(&up, Pairing::Natural, &GriffinLim::default()));
    assert!(c1 > 1.5 * c0, "centroid {c0} → {c1}");
}

/// A "recording" = an object's modes + what modes cannot make (a noise-band transient) + room
/// noise. Estimate its material, compute the residual, resynthesize with and without it: the
/// psychoacoustic distance to the recording must shrink when the residual is added.
#[test]
fn adding_the_residual_brings_the_resynthesis_closer_to_the_recording() {
    let gamma0 = 1.0e7;
    let eigenvalues0: Vec<f64> = (0..30)
        .map(|n| (std::f64::consts::TAU * 400.0 * (1.0 + n as f64).powf(1.3)).powi(2))
        .collect();
    let gains0: Vec<f64> = (0..30).map(|n| 1e-5 / (1.0 + n as f64)).collect();
    let side = ModalSide {
        eigenvalues0,
        gains0,
        gamma0,
    };
    let truth = RayleighParams {
        alpha: 5.0,
        beta: 4e-7,
        gamma: 1.6e7,
        sigma: 3.0e3,
    };
    let n = 24_000;
    let modal = synthesize(
        &forward_modes(
            &side.eigenvalues0,
            &side.gains0,
            side.gamma0,
            &truth,
            0.5 * FS,
        ),
        FS,
        n,
    );
    let thud = burst(n, 120.0, 0.08, 11);
    let mut rng = SmallRng::seed_from_u64(5);
    let rec: Vec<f64> = modal
        .iter()
        .zip(&thud)
        .map(|(a, b)| a + b + 1e-4 * (rng.random::<f64>() - 0.5))
        .collect();
    let analysis =
        resound_signal::analyze(&rec, FS, &resound_signal::AnalyzeParams::default()).unwrap();
    let onset = (analysis.onset_s * FS).round() as usize;
    let seg = &rec[onset..onset + analysis.samples];
    let est = estimate(
        &side,
        seg,
        FS,
        &analysis.modes,
        &EstimateParams::default(),
        &|| {},
    )
    .unwrap();
    let estimated = forward_modes(
        &side.eigenvalues0,
        &side.gains0,
        side.gamma0,
        &est.params,
        0.5 * FS,
    );
    let residual = compute_residual(seg, FS, &analysis.modes, &estimated);
    assert!(!residual.samples.is_empty());
    // Resynthesis: the modes struck by a unit impulse, plus the residual transferred to the
    // same object and hit (natural pairing).
    let mut impulse = vec![0.0f32; 1];
    impulse[0] = FS as f32;
    let dry = render_strike(&bank_modes(&estimated), &impulse, FS, seg.len()).unwrap();
    let mut src = ResidualSource::new(&residual);
    let res = src.transfer(&estimated, Pairing::Natural, &GriffinLim::default());
    let mut wet = dry.clone();
    for (w, r) in wet.iter_mut().zip(&res) {
        *w += r;
    }
    let grid = ImageGrid::new(FS, seg.len()).unwrap();
    let reference = image_of_signal(seg, &grid);
    let grid = grid.with_floor_below(&reference, 50.0);
    let reference = image_of_signal(seg, &grid);
    let to64 = |x: &[f32]| x.iter().map(|&v| f64::from(v)).collect::<Vec<f64>>();
    let d_dry = image_of_signal(&to64(&dry), &grid).distance(&reference);
    let d_wet = image_of_signal(&to64(&wet), &grid).distance(&reference);
    eprintln!(
        "loudness-image distance to the recording: modes {d_dry:.1}, modes + residual {d_wet:.1}"
    );
    assert!(
        d_wet < 0.7 * d_dry,
        "with residual {d_wet} vs without {d_dry}"
    );
}
