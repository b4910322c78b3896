//! Throughput measurements shared by `resound bench synth`.

use resound_synth::bank::{BankMode, ModalBank};
use std::time::Instant;

/// `count` modes spread over 40 Hz – 20 kHz with light damping (nothing is culled).
pub fn test_modes(count: usize) -> Vec<BankMode> {
    (0..count)
        .map(|i| {
            let x = (i as f64 + 0.5) / count as f64;
            BankMode {
                freq_hz: 40.0 * (500.0f64).powf(x),
                damping_per_s: 0.5 + 3.0 * x,
                gain: 1e-3,
            }
        })
        .collect()
}

/// Mode-samples per second of the bank (SIMD dispatch, or the portable path when
/// `scalar_only`) rendering `seconds` of audio at 48 kHz with `modes` modes, blocks of 256.
pub fn bank_mode_samples_per_s(modes: usize, seconds: f64, scalar_only: bool) -> f64 {
    let fs = 48_000.0;
    let m = test_modes(modes);
    let Ok(mut bank) = ModalBank::new(fs, &m, 0.0) else {
        return 0.0;
    };
    bank.set_scalar_only(scalar_only);
    let n = (seconds * fs) as usize;
    let mut force = vec![0.0f32; 256];
    let mut out = vec![0.0f32; 256];
    force[0] = 1.0;
    let t0 = Instant::now();
    let mut done = 0;
    while done < n {
        bank.process(&force, &mut out);
        force[0] = 0.0;
        done += 256;
    }
    let s = t0.elapsed().as_secs_f64();
    std::hint::black_box(&out);
    (modes * done) as f64 / s
}

/// The plain scalar loop the bank is compared with: per sample, per mode, a two-pole
/// recurrence `y = a₁y₁ + a₂y₂ + b x` in f32 over an array of structs.
pub fn scalar_loop_mode_samples_per_s(modes: usize, seconds: f64) -> f64 {
    #[derive(Clone, Copy)]
    struct Mode {
        a1: f32,
        a2: f32,
        b: f32,
        y1: f32,
        y2: f32,
    }
    let fs = 48_000.0f64;
    let mut ms: Vec<Mode> = test_modes(modes)
        .iter()
        .map(|m| {
            let r = (-m.damping_per_s / fs).exp();
            let w = std::f64::consts::TAU * m.freq_hz / fs;
            Mode {
                a1: (2.0 * r * w.cos()) as f32,
                a2: (-r * r) as f32,
                b: (m.gain / fs * r * w.sin()) as f32,
                y1: 0.0,
                y2: 0.0,
            }
        })
        .collect();
    let n = (seconds * fs) as usize;
    let mut out = vec![0.0f32; 256];
    let t0 = Instant::now();
    let mut done = 0;
    let mut x0 = 1.0f32;
    while done < n {
        for (k, o) in out.iter_mut().enumerate() {
            let x = if k == 0 { x0 } else { 0.0 };
            let mut acc = 0.0f32;
            for m in ms.iter_mut() {
                let y = m.a1 * m.y1 + m.a2 * m.y2 + m.b * x;
                m.y2 = m.y1;
                m.y1 = y;
                acc += y;
            }
            *o = acc;
        }
        x0 = 0.0;
        done += 256;
    }
    let s = t0.elapsed().as_secs_f64();
    std::hint::black_box(&out);
    (modes * done) as f64 / s
}

/// A 1 s residual at 48 kHz — decaying noise bands around 12 source modes — and its modes.
pub fn test_residual(seed: u64) -> resound_core::Residual {
    use rand::{Rng, SeedableRng};
    let fs = 48_000.0;
    let modes: Vec<resound_core::DampedMode> = (0..12)
        .map(|i| {
            resound_core::DampedMode::new(
                300.0 * 1.35f64.powi(i),
                10.0 + 5.0 * i as f64,
                0.2 / (1.0 + i as f64),
            )
        })
        .collect();
    let n = 48_000;
    let mut samples = vec![0.0f32; n];
    let mut rng = rand::rngs::SmallRng::seed_from_u64(seed);
    for m in &modes {
        let mut y = 0.0;
        for (k, s) in samples.iter_mut().enumerate() {
            let t = k as f64 / fs;
            y = 0.97 * y + 0.03 * (rng.random::<f64>() * 2.0 - 1.0);
            *s += (m.amplitude
                * y
                * (-3.0 * t).exp()
                * (std::f64::consts::TAU * m.freq_hz * t).sin()) as f32;
        }
    }
    resound_core::Residual {
        sample_rate_hz: fs,
        samples,
        source_modes: modes,
    }
}

/// Latencies (ms) of `events` residual transfers of a 1 s residual to target objects whose modes
/// differ from event to event (each mode's frequency and damping scaled by a random factor of
/// 0.8–1.25), 10 fast Griffin–Lim iterations, dominant pairing. Sorted ascending.
pub fn residual_transfer_latencies_ms(events: usize, seed: u64) -> Vec<f64> {
    use rand::{Rng, SeedableRng};
    use resound_synth::residual::{GriffinLim, Pairing, ResidualSource};
    let r = test_residual(seed);
    let mut src = ResidualSource::new(&r);
    let mut rng = rand::rngs::SmallRng::seed_from_u64(seed + 1);
    let mut out: Vec<f64> = (0..events)
        .map(|_| {
            let target: Vec<resound_core::DampedMode> = r
                .source_modes
                .iter()
                .map(|m| {
                    let s: f64 = 0.8 + 0.45 * rng.random::<f64>();
                    resound_core::DampedMode {
                        freq_hz: m.freq_hz * s,
                        damping_per_s: m.damping_per_s * (0.8 + 0.45 * rng.random::<f64>()),
                        amplitude: m.amplitude * (0.5 + rng.random::<f64>()),
                        phase_rad: 0.0,
                    }
                })
                .collect();
            let t0 = Instant::now();
            let x = src.transfer(&target, Pairing::Dominant(8), &GriffinLim::default());
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            std::hint::black_box(&x);
            ms
        })
        .collect();
    out.sort_by(f64::total_cmp);
    out
}
