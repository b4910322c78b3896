//! One object heard by eight microphones: the same poles from every microphone.
//!
//! The object is a bowl-like mode set: three degenerate pairs split by its asymmetry
//! (0.05, 0.2 and 0.5 % apart; members heard as cos nθ and sin nθ of the microphone's angle, so some
//! microphones sit on one member's nodal line) and three single modes. Each microphone hears
//! it with room noise 35 dB under the peak after a lead-in with a DC offset.

use resound_core::damped::synthesize;
use resound_core::DampedMode;
use resound_signal::joint::{joint_fit, JointParams, JointTake};
use resound_signal::{analyze, Analysis, AnalyzeParams};

/// (f, d, amplitude, circumferential order n: 0 single, else (cos nθ, sin nθ) member 0/1).
const TRUTH: [(f64, f64, f64, u32, u8); 9] = [
    (820.0, 2.0, 0.15, 0, 0),
    (1675.0, 3.0, 0.30, 2, 0),
    (1675.84, 3.5, 0.30, 2, 1),
    (2890.0, 6.0, 0.12, 0, 0),
    (4170.0, 10.0, 0.20, 3, 0),
    (4178.0, 12.0, 0.20, 3, 1),
    (7300.0, 20.0, 0.10, 4, 0),
    (7336.5, 22.0, 0.10, 4, 1),
    (11000.0, 45.0, 0.06, 0, 0),
];

fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

fn gauss(state: &mut u64) -> f64 {
    let (u, v) = (lcg(state).max(1e-300), lcg(state));
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// The recording at microphone angle `theta` (with a gain for single modes that varies by
/// microphone too).
fn microphone(theta: f64, mic: usize, fs: f64) -> Vec<f64> {
    let mut state = 1000 + mic as u64;
    let modes: Vec<DampedMode> = TRUTH
        .iter()
        .map(|&(f, d, a, n, member)| {
            let g = match (n, member) {
                (0, _) => 0.6 + 0.4 * lcg(&mut state),
                (n, 0) => (f64::from(n) * theta).cos(),
                (n, _) => (f64::from(n) * theta).sin(),
            };
            DampedMode {
                freq_hz: f,
                damping_per_s: d,
                amplitude: a * g.abs(),
                phase_rad: if g < 0.0 { std::f64::consts::PI } else { 0.0 },
            }
        })
        .collect();
    let lead = (0.08 * fs) as usize + 37 * mic;
    let body = synthesize(&modes, fs, (1.4 * fs) as usize);
    let peak = body.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let noise = peak * 10f64.powf(-35.0 / 20.0);
    let mut x = vec![0.0; lead];
    x.extend(body);
    x.iter_mut()
        .for_each(|v| *v += 0.02 + noise * gauss(&mut state));
    x
}

fn nearest(modes: &[DampedMode], f: f64) -> Option<DampedMode> {
    modes
        .iter()
        .copied()
        .filter(|m| (m.freq_hz - f).abs() < 0.002 * f)
        .min_by(|a, b| (a.freq_hz - f).abs().total_cmp(&(b.freq_hz - f).abs()))
}

#[test]
fn eight_microphones_give_one_set_of_poles() {
    let fs = 48000.0;
    let angles: Vec<f64> = (0..8).map(|m| 0.37 + 0.71 * m as f64).collect();
    let analyses: Vec<Analysis> = angles
        .iter()
        .enumerate()
        .map(|(m, &theta)| {
            analyze(&microphone(theta, m, fs), fs, &AnalyzeParams::default()).unwrap()
        })
        .collect();
    // Each microphone alone: how far the strongest single modes' damping strays.
    for &(f, d, ..) in TRUTH.iter().filter(|t| t.3 == 0) {
        let ds: Vec<f64> = analyses
            .iter()
            .filter_map(|a| nearest(&a.modes, f))
            .map(|m| m.damping_per_s)
            .collect();
        let worst = ds.iter().map(|x| (x / d - 1.0).abs()).fold(0.0, f64::max);
        eprintln!(
            "single {f} Hz: found by {} of 8, worst d error {:.1} %",
            ds.len(),
            100.0 * worst
        );
        assert_eq!(ds.len(), 8, "{f} Hz: {ds:?}");
        assert!(worst < 0.15, "{f} Hz alone: d {ds:?} (truth {d})");
    }
    // Each microphone alone resolves the pairs (as beating pairs, not one mode with a wrong
    // damping) wherever it hears both members: d within 15 % where the member's gain is ≥ 0.3
    // of its largest (a microphone near a member's nodal line does not hear it).
    for &(f, d, _, n, member) in TRUTH.iter().filter(|t| t.3 != 0) {
        let mut heard = 0;
        for (a, &theta) in analyses.iter().zip(&angles) {
            let g = if member == 0 {
                (f64::from(n) * theta).cos()
            } else {
                (f64::from(n) * theta).sin()
            };
            let found = nearest(&a.modes, f).filter(|m| (m.freq_hz - f).abs() < 0.0002 * f);
            eprintln!("pair member {f} Hz d {d}, gain {g:+.2}: {found:?}");
            if g.abs() >= 0.3 {
                let m = found.unwrap_or_else(|| panic!("{f} Hz missing at gain {g:.2}"));
                assert!(
                    (m.damping_per_s / d - 1.0).abs() < 0.15,
                    "{f} Hz at gain {g:.2}: {m:?}"
                );
                heard += 1;
            }
        }
        assert!(heard >= 4, "{f} Hz heard by {heard}");
    }
    let takes: Vec<JointTake> = analyses
        .iter()
        .map(|a| JointTake {
            segment: &a.segment,
            noise_rms: a.noise_rms,
            modes: &a.modes,
        })
        .collect();
    let joint = joint_fit(&takes, fs, &JointParams::default()).unwrap();
    let poles: Vec<DampedMode> = joint
        .modes
        .iter()
        .map(|m| DampedMode::new(m.freq_hz, m.damping_per_s, 1.0))
        .collect();
    for &(f, d, ..) in &TRUTH {
        let m = nearest(&poles, f).unwrap_or_else(|| panic!("{f} Hz missing from {poles:?}"));
        let jm = joint.modes.iter().find(|j| j.freq_hz == m.freq_hz).unwrap();
        eprintln!(
            "joint {f} Hz: f {:.3} d {:.3} (truth {d}), heard {}/8, spread {:.1} σ",
            m.freq_hz,
            m.damping_per_s,
            jm.heard.iter().filter(|&&h| h).count(),
            jm.disagreement_sigmas
        );
        assert!((m.freq_hz / f - 1.0).abs() < 2e-4, "{f}: {m:?}");
        assert!(
            (m.damping_per_s / d - 1.0).abs() < 0.02,
            "{f} Hz: d {} vs {d}",
            m.damping_per_s
        );
        assert!(!jm.disagree, "{jm:?}");
    }
    // No pole beyond the truth carries much: whatever else was kept is weak.
    let strongest = |f: f64| {
        joint
            .modes
            .iter()
            .filter(|m| nearest(&[DampedMode::new(m.freq_hz, 1.0, 1.0)], f).is_some())
            .count()
    };
    let extra = joint.modes.len() - TRUTH.iter().map(|t| strongest(t.0).min(1)).sum::<usize>();
    eprintln!("{} poles, {extra} beyond the truth", joint.modes.len());
    assert!(extra <= 2, "{:?}", joint.modes);
}
