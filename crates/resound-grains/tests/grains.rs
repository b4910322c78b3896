//! End-to-end properties of grain analysis, resynthesis and retargeting.

use rand::{Rng, SeedableRng};
use resound_grains::player::{GrainPlayer, PlayerParams};
use resound_grains::quality::spectral_convergence_db;
use resound_grains::resynth::{resynthesize, ResynthParams};
use resound_grains::{analyze, AnalyzeParams, Contact, Dictionary, Part, Recording};
use std::sync::Arc;

const FS: f64 = 44_100.0;

/// A decaying knock: partials and a noise burst, distinct per `k`.
fn knock(k: usize, len: usize, rng: &mut impl Rng) -> Vec<f32> {
    let f0 = 250.0 * (1.0 + k as f64 * 0.41);
    (0..len)
        .map(|i| {
            let t = i as f64 / FS;
            let env = (-t * (35.0 + 12.0 * k as f64)).exp();
            let tonal: f64 = (1..4)
                .map(|h| (std::f64::consts::TAU * f0 * h as f64 * 1.17 * t).sin() / h as f64)
                .sum();
            let noise = (rng.random::<f64>() - 0.5) * (-t * 500.0).exp();
            ((0.4 * tonal + 0.8 * noise) * env) as f32
        })
        .collect()
}

fn energy(x: &[f32]) -> f64 {
    x.iter().map(|&v| f64::from(v).powi(2)).sum()
}

/// Three knocks placed as A B A C B at known offsets.
fn knock_sequence() -> (Vec<f32>, Vec<usize>, Vec<usize>) {
    let mut rng = rand::rngs::SmallRng::seed_from_u64(21);
    let knocks: Vec<Vec<f32>> = [2400, 2800, 2000]
        .iter()
        .enumerate()
        .map(|(k, &l)| knock(k, l, &mut rng))
        .collect();
    let order = vec![0, 1, 0, 2, 1];
    let mut x = Vec::new();
    let mut offsets = Vec::new();
    for &k in &order {
        offsets.push(x.len());
        x.extend(&knocks[k]);
    }
    (x, offsets, order)
}

fn dictionary_of(recordings: Vec<Recording>) -> Dictionary {
    analyze(&recordings, FS, &AnalyzeParams::default(), &|_| {})
        .expect("analysis")
        .0
}

#[test]
fn known_grains_are_cut_at_their_offsets_and_the_pattern_recovers_them() {
    let (x, offsets, order) = knock_sequence();
    let dict = dictionary_of(vec![Recording {
        name: "knocks".into(),
        contact: Contact::Impact,
        samples: x,
    }]);
    // Onset grains start at the offsets.
    let starts: Vec<usize> = dict
        .grains
        .iter()
        .filter(|g| g.onset)
        .map(|g| (g.start + g.fade_in) as usize)
        .collect();
    assert_eq!(starts.len(), offsets.len(), "{starts:?} vs {offsets:?}");
    for (&s, &o) in starts.iter().zip(&offsets) {
        assert!(s.abs_diff(o) <= 16, "{starts:?} vs {offsets:?}");
    }
    // The pattern holds every knock's grain at every offset where that knock recurs.
    let pattern = &dict.patterns[0];
    for (i, &o) in offsets.iter().enumerate().skip(1) {
        let grain_of = |j: usize| {
            dict.grains
                .iter()
                .position(|g| {
                    g.onset && ((g.start + g.fade_in) as usize).abs_diff(offsets[j]) <= 16
                })
                .expect("onset grain")
        };
        for (j, _) in order
            .iter()
            .enumerate()
            .filter(|&(j, &k)| k == order[i] && j != i)
        {
            let g = grain_of(j);
            let found = pattern.peaks.iter().any(|p| {
                let onset = (p.time + dict.grains[g].fade_in) as usize;
                p.grain as usize == g && onset.abs_diff(o) <= 16 && p.corr > 0.9
            });
            assert!(found, "grain of knock {j} not found at offset {o}");
        }
    }
}

#[test]
fn resynthesis_converges_and_time_scaling_stretches() {
    let (x, _, _) = knock_sequence();
    let dict = dictionary_of(vec![Recording {
        name: "knocks".into(),
        contact: Contact::Impact,
        samples: x.clone(),
    }]);
    let y = resynthesize(&dict, 0, &ResynthParams::default()).expect("resynthesis");
    let sc = spectral_convergence_db(&x, &y, FS);
    assert!(sc < -30.0, "spectral convergence {sc} dB");
    let longest = dict
        .grains
        .iter()
        .map(|g| g.samples.len())
        .max()
        .unwrap_or(0);
    for alpha in [2.0, 0.5] {
        let z = resynthesize(
            &dict,
            0,
            &ResynthParams {
                time_scale: alpha,
                ..ResynthParams::default()
            },
        )
        .expect("time-scaled");
        let want = alpha * x.len() as f64;
        assert!(
            (z.len() as f64 - want).abs() <= longest as f64,
            "α = {alpha}: {} samples for {want}",
            z.len()
        );
        // Stretched, the sound fills its length: no second of silence.
        let e = energy(&z) / z.len() as f64;
        assert!(
            e > 0.2 * energy(&x) / x.len() as f64,
            "α = {alpha}: power {e}"
        );
    }
    // Variations differ from the original but stay close to it.
    let v = resynthesize(
        &dict,
        0,
        &ResynthParams {
            variation: 0.5,
            seed: 7,
            ..ResynthParams::default()
        },
    )
    .expect("variation");
    let scv = spectral_convergence_db(&x, &v, FS);
    assert!(
        scv > sc + 3.0 && scv < -3.0,
        "variation {scv} dB vs {sc} dB"
    );
}

#[test]
fn continuous_recordings_split_into_two_kinds_of_grain() {
    let mut rng = rand::rngs::SmallRng::seed_from_u64(5);
    let n = 66_150;
    let x: Vec<f32> = (0..n)
        .map(|i| {
            let t = i as f64 / FS;
            let hum = 0.2 * (std::f64::consts::TAU * 523.0 * t).sin()
                + 0.1 * (std::f64::consts::TAU * 1580.0 * t).sin();
            let crackle = if rng.random::<f64>() < 0.002 {
                rng.random::<f64>() - 0.5
            } else {
                0.0
            };
            let hiss = 0.02 * (rng.random::<f64>() - 0.5);
            (hum + crackle + hiss) as f32
        })
        .collect();
    let dict = dictionary_of(vec![Recording {
        name: "roll".into(),
        contact: Contact::Rolling,
        samples: x.clone(),
    }]);
    assert_eq!(dict.patterns.len(), 2);
    assert!(dict.grains_of(Part::Sinusoidal).count() > 10);
    assert!(dict.grains_of(Part::Transient).count() > 10);
    assert_eq!(dict.grains_of(Part::Impulsive).count(), 0);
    let y = resynthesize(&dict, 0, &ResynthParams::default()).expect("resynthesis");
    let sc = spectral_convergence_db(&x, &y, FS);
    assert!(sc < -15.0, "spectral convergence {sc} dB");
}

fn player_dictionary() -> Arc<Dictionary> {
    let (x, _, _) = knock_sequence();
    let mut rng = rand::rngs::SmallRng::seed_from_u64(9);
    let roll: Vec<f32> = (0..44_100)
        .map(|i| {
            let t = i as f64 / FS;
            (0.2 * (std::f64::consts::TAU * 700.0 * t).sin() + 0.005 * (rng.random::<f64>() - 0.5))
                as f32
        })
        .collect();
    Arc::new(dictionary_of(vec![
        Recording {
            name: "knocks".into(),
            contact: Contact::Impact,
            samples: x,
        },
        Recording {
            name: "roll".into(),
            contact: Contact::Rolling,
            samples: roll,
        },
    ]))
}

fn run(player: &mut GrainPlayer, blocks: usize, contact: Option<(Contact, f64, f64)>) -> Vec<f32> {
    let mut out = vec![0.0f32; blocks * 184];
    for b in 0..blocks {
        player.set_contact(contact);
        player.process(&mut out[b * 184..(b + 1) * 184]);
    }
    out
}

#[test]
fn retargeted_grains_are_silent_without_contacts_and_grow_with_contact_power() {
    let dict = player_dictionary();
    let mut p = GrainPlayer::new(dict.clone(), FS, PlayerParams::default()).expect("player");
    let quiet = run(&mut p, 200, None);
    assert!(quiet.iter().all(|&v| v == 0.0));
    assert!(p.is_silent());
    let rms = |power: f64| {
        let mut p = GrainPlayer::new(dict.clone(), FS, PlayerParams::default()).expect("player");
        let y = run(&mut p, 240, Some((Contact::Rolling, power, 0.5)));
        (energy(&y) / y.len() as f64).sqrt()
    };
    let (a, b) = (rms(0.5), rms(2.0));
    assert!(a > 0.0 && (b / a - 4.0).abs() < 0.4, "rms {a} → {b}");
    // Faster rolling raises the pitch of the sinusoidal grains: the hum (700 Hz) moves by
    // (v / 1 m/s)^0.5.
    let pitch = |speed: f64| {
        let mut p = GrainPlayer::new(dict.clone(), FS, PlayerParams::default()).expect("player");
        let mut y = run(&mut p, 240, Some((Contact::Rolling, 1.0, speed)));
        y.truncate(32_768);
        let fft = realfft::RealFftPlanner::<f32>::new().plan_fft_forward(y.len());
        let mut spec = fft.make_output_vec();
        fft.process(&mut y, &mut spec).expect("fft");
        let k = (1..spec.len())
            .max_by(|&a, &b| spec[a].norm().total_cmp(&spec[b].norm()))
            .unwrap_or(0);
        k as f64 * FS / 32_768.0
    };
    for speed in [0.5f64, 2.0] {
        let want = 700.0 * speed.sqrt();
        let got = pitch(speed);
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "{speed} m/s: {got} Hz, want {want}"
        );
    }
    // After the contact ends the player falls silent.
    let mut p = GrainPlayer::new(dict.clone(), FS, PlayerParams::default()).expect("player");
    run(&mut p, 50, Some((Contact::Rolling, 1.0, 1.0)));
    let tail = run(&mut p, 50, None);
    assert!(p.is_silent());
    assert!(tail[tail.len() - 184..].iter().all(|&v| v == 0.0));
}

#[test]
fn an_impact_sounds_from_its_instant_and_scales_with_the_impulse() {
    let dict = player_dictionary();
    let level = |impulse: f64| {
        let mut p = GrainPlayer::new(
            dict.clone(),
            FS,
            PlayerParams {
                seed: 3,
                ..PlayerParams::default()
            },
        )
        .expect("player");
        let mut out = vec![0.0f32; 512];
        p.impact(100, impulse);
        p.process(&mut out);
        let first = out.iter().position(|&v| v != 0.0).expect("sound");
        let mut rest = run(&mut p, 400, None);
        rest.splice(0..0, out);
        assert!(p.is_silent());
        (first, energy(&rest).sqrt())
    };
    let (t1, e1) = level(0.05);
    let (t2, e2) = level(0.2);
    // The attack lands on the force peak; only the fade-in comes before it.
    assert!((60..=100).contains(&t1) && t1 == t2, "{t1}, {t2}");
    assert!((e2 / e1 - 4.0).abs() < 1e-3, "{e1} → {e2}");
}

#[test]
fn the_player_does_not_allocate() {
    use assert_no_alloc::assert_no_alloc;
    let dict = player_dictionary();
    let mut p = GrainPlayer::new(dict, FS, PlayerParams::default()).expect("player");
    let mut out = vec![0.0f32; 256];
    assert_no_alloc(|| {
        for k in 0..400 {
            if k % 50 == 0 {
                p.impact(k % 7, 0.1);
            }
            let c = if k % 100 < 60 {
                Some((Contact::Rolling, 1.0, 0.3 + k as f64 * 0.01))
            } else {
                None
            };
            p.set_contact(c);
            p.process(&mut out);
        }
    });
}

#[cfg(debug_assertions)]
#[global_allocator]
static ALLOC: assert_no_alloc::AllocDisabler = assert_no_alloc::AllocDisabler;
