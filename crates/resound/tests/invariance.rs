//! Invariances of the analysis that need no ground truth (issue 16): the same object's modes
//! have the same f and d in both microphones of a stereo recording, in every strike of a file,
//! and after a lead-in of room noise, a DC offset and rumble are put in front of a strike.
#![allow(clippy::unwrap_used)]

use resound::signal::{analyze, Analysis, AnalyzeParams};
use resound_core::DampedMode;
use std::path::{Path, PathBuf};

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/recordings")
}

fn channels(name: &str) -> (Vec<Vec<f64>>, f64) {
    let path = assets().join(name);
    let clip = resound_io::load_audio(&path).unwrap();
    let chans = (0..clip.channels.len())
        .map(|c| clip.mono(Some(c), &path).unwrap())
        .collect();
    (chans, f64::from(clip.sample_rate_hz))
}

fn level(m: &DampedMode) -> f64 {
    resound::signal::mode_level(m, resound::signal::LEVEL_WINDOW_S)
}

/// The `k` strongest modes by level.
fn strongest(a: &Analysis, k: usize) -> Vec<DampedMode> {
    strongest_of(a.modes.clone(), k)
}

fn strongest_of(mut m: Vec<DampedMode>, k: usize) -> Vec<DampedMode> {
    m.sort_by(|p, q| level(q).total_cmp(&level(p)));
    m.truncate(k);
    m
}

/// For each of `reference`'s modes, the mode of `other` within 0.05 % (and 1 Hz) of it.
fn matched(reference: &[DampedMode], other: &[DampedMode]) -> Vec<(DampedMode, DampedMode)> {
    reference
        .iter()
        .filter_map(|r| {
            other
                .iter()
                .filter(|o| (o.freq_hz - r.freq_hz).abs() <= (5e-4 * r.freq_hz).max(1.0))
                .min_by(|a, b| {
                    (a.freq_hz - r.freq_hz)
                        .abs()
                        .total_cmp(&(b.freq_hz - r.freq_hz).abs())
                })
                .map(|o| (*r, *o))
        })
        .collect()
}

fn damping_agrees(a: &DampedMode, b: &DampedMode, rel: f64) -> bool {
    (a.damping_per_s - b.damping_per_s).abs() <= rel * a.damping_per_s.max(b.damping_per_s) + 0.5
}

/// `x` behind a lead-in of room noise, on a DC offset, with rumble (20–45 Hz) throughout: what
/// a raw recording of the same strike looks like.
fn as_recorded(x: &[f64], fs: f64, lead_in_s: f64, seed: u64) -> Vec<f64> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand::rngs::SmallRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 1e-4).unwrap();
    let lead = (lead_in_s * fs) as usize;
    (0..lead + x.len())
        .map(|i| {
            let t = i as f64 / fs;
            let rumble = 0.004 * (std::f64::consts::TAU * 23.0 * t).sin()
                + 0.003 * (std::f64::consts::TAU * 41.0 * t + 0.7).sin();
            let strike = if i >= lead { x[i - lead] } else { 0.0 };
            -0.0014 + noise.sample(&mut rng) + rumble + strike
        })
        .collect()
}

/// The strongest modes of the clean strike come out of its raw-looking version with the same
/// f (0.05 %) and d (15 %) when `modes_too`; always, the onset is found at the lead-in's end
/// (± 2 ms), the offset and the noise floor are measured and the rumble gets a high-pass.
fn check_conditions(name: &str, x: &[f64], fs: f64, modes_too: bool) -> usize {
    let clean = analyze(
        x,
        fs,
        &AnalyzeParams {
            highpass_hz: Some(60.0),
            ..Default::default()
        },
    )
    .unwrap();
    let raw = as_recorded(x, fs, 1.0, 7);
    let got = analyze(&raw, fs, &AnalyzeParams::default()).unwrap();
    // Between the lead-in's end and the clean analysis's onset (a file that fades in has its
    // first audible sample before the point the clean envelope scan calls the onset).
    assert!(
        got.onset_s >= 1.0 - 2e-3 && got.onset_s <= 1.0 + clean.onset_s + 2e-3,
        "{name}: onset {:.4} s, expected {:.4} s ({:?})",
        got.onset_s,
        1.0 + clean.onset_s,
        got.conditioning
    );
    assert!(
        got.conditioning.highpass.hz().is_some(),
        "{name}: rumble not handled: {:?}",
        got.conditioning
    );
    assert!(
        (got.conditioning.dc_offset + 0.0014).abs() < 2e-4,
        "{name}: {:?}",
        got.conditioning
    );
    // Ringing modes (Q = πf/d ≥ 20): a heavily damped cluster has no unique decomposition.
    let ringing: Vec<DampedMode> = clean
        .modes
        .iter()
        .filter(|m| std::f64::consts::PI * m.freq_hz / m.damping_per_s >= 20.0)
        .copied()
        .collect();
    let reference = strongest_of(ringing, 5);
    if std::env::var("SHOW").is_ok() {
        let show = |a: &Analysis| {
            let mut l = strongest(a, 12);
            l.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
            l.iter()
                .map(|m| {
                    format!(
                        "{:.0}/{:.1}/{:.0}",
                        m.freq_hz,
                        m.damping_per_s,
                        20.0 * level(m).log10()
                    )
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        eprintln!(
            "clean {} modes: {}\nraw   {} modes: {}",
            clean.modes.len(),
            show(&clean),
            got.modes.len(),
            show(&got)
        );
    }
    let pairs = matched(&reference, &got.modes);
    let agree = pairs
        .iter()
        .filter(|(r, o)| damping_agrees(r, o, 0.15))
        .count();
    eprintln!(
        "{name}: {} of {} strongest modes found again, {agree} with d within 15 % (high-pass {:?}, noise {:.1} dBFS from the {})",
        pairs.len(),
        reference.len(),
        got.conditioning.highpass,
        got.conditioning.noise_floor_dbfs,
        got.conditioning.noise_from
    );
    for (r, o) in &pairs {
        eprintln!(
            "    {:9.2} Hz {:8.2}/s  ->  {:9.2} Hz {:8.2}/s",
            r.freq_hz, r.damping_per_s, o.freq_hz, o.damping_per_s
        );
    }
    // The noise floor is the added noise (the rumble is filtered off), unless the cut-off had
    // to stay below the strike's own lowest mode.
    let capped = got.conditioning.highpass_reason.contains("capped");
    assert!(
        capped || (got.conditioning.noise_floor_dbfs - 20.0 * 1e-4f64.log10()).abs() < 3.0,
        "{name}: {:?}",
        got.conditioning
    );
    if modes_too {
        assert!(
            agree + 1 >= reference.len(),
            "{name}: only {agree} of the {} strongest ringing modes kept f (0.05 %) and d (15 %): {pairs:?}",
            reference.len()
        );
    }
    agree
}

#[test]
fn conditioning_finds_the_strike_offset_noise_and_rumble_put_before_bundled_strikes() {
    for name in [
        "default_dug_metal.1.ogg",
        "default_place_node_metal.1.ogg",
        "default_dig_choppy.1.ogg",
    ] {
        let (ch, fs) = channels(name);
        check_conditions(name, &ch[0], fs, false);
    }
    // The ramp recording's first strike, cut before the second one.
    let (ch, fs) = channels("steel_nut_M4_2.wav");
    let end = (0.5 * fs) as usize;
    check_conditions("steel_nut_M4_2.wav ch0", &ch[0][..end], fs, false);
}

/// Issue 16's target on the bundled game sounds, not met yet (see the closing note of session
/// 7): their strongest ringing modes keep f and d when a lead-in, an offset and rumble are
/// added. The strongest modes of these edited sounds are low and heavily damped, next to the
/// rumble; 3 of 5 come back, 1 with its d.
#[test]
#[ignore = "issue 16 target not met on the bundled game sounds (run with --ignored)"]
fn a_lead_in_dc_offset_and_rumble_leave_the_modes_of_bundled_strikes_unchanged() {
    for name in ["default_dug_metal.1.ogg", "default_place_node_metal.1.ogg"] {
        let (ch, fs) = channels(name);
        check_conditions(name, &ch[0], fs, true);
    }
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

#[test]
fn conditioning_of_real_impact_strikes_behind_a_lead_in() {
    real_impact(false);
}

/// Issue 16's target on the RealImpact strikes: the 5 strongest ringing modes keep f (0.05 %)
/// and d (15 %), all but one of them at least.
#[test]
fn a_lead_in_dc_offset_and_rumble_leave_the_modes_of_real_impact_strikes_unchanged() {
    real_impact(true);
}

fn real_impact(modes_too: bool) {
    let Some(dir) = shared_data() else {
        eprintln!(
            "skipped: ../shared/data is absent (the RealImpact files stay out of the repository)"
        );
        return;
    };
    for name in [
        "CeramicKoiBowlImpact.wav",
        "CupImpact.wav",
        "SteelStandImpact.wav",
    ] {
        let path = dir.join("recordings/realimpact-mesheditor").join(name);
        if !path.is_file() {
            eprintln!("skipped {name}: absent");
            continue;
        }
        let clip = resound_io::load_audio(&path).unwrap();
        let x = clip.mono(None, &path).unwrap();
        // Two seconds are enough for the strongest modes and keep the test quick.
        let n = x.len().min(2 * clip.sample_rate_hz as usize);
        check_conditions(name, &x[..n], f64::from(clip.sample_rate_hz), modes_too);
    }
}

/// γ, α, β estimated from `raw` (strike `strike`) and from `clean`, on `model` at `hit`.
fn estimate_both(
    clean: &[f64],
    raw: &[f64],
    fs: f64,
    model: &resound_core::ModalModel,
    hit: &resound_core::Hit,
    clean_params: &AnalyzeParams,
) -> (
    resound::estimate::RayleighParams,
    resound::estimate::RayleighParams,
) {
    use resound::material::{estimate_material, EstimateMaterialParams};
    let params = EstimateMaterialParams {
        residual: false,
        allow_implausible: true,
        ..Default::default()
    };
    let a = analyze(clean, fs, clean_params).unwrap();
    let b = analyze(raw, fs, &AnalyzeParams::default()).unwrap();
    let (_, ia) = estimate_material(&a, model, hit, &params, &|_| {}).unwrap();
    let (_, ib) = estimate_material(&b, model, hit, &params, &|_| {}).unwrap();
    (ia.params, ib.params)
}

/// Issue 16: the estimate from a raw file (a second of room noise, a DC offset, rumble) is the
/// estimate from the trimmed strike: γ within 10 %. On a rendered strike of a known material
/// (Hertz contact, wood-like damping on an aluminium bar struck off-centre) both are also
/// near the truth; on the RealImpact Koi bowl (when ../shared is present) against a primitive
/// bowl of its size, the two agree.
#[test]
fn a_raw_file_gives_the_estimate_of_its_trimmed_strike() {
    use resound::strike::{render_strike, StrikeParams, Struck};
    use resound_core::{Material, SoundMaterial};
    let aluminium = Material::preset("aluminium").unwrap();
    let bar = resound_fem::primitive::bar([0.25, 0.03, 0.01]);
    let model = resound_modal::ModalBuilder::surface(&bar, &aluminium)
        .modes(40)
        .solve()
        .unwrap()
        .model;
    let hit = model.hit([0.07, 0.008, 0.005]).unwrap();
    let gamma = aluminium.youngs_modulus / aluminium.density;
    let truth = SoundMaterial::rayleigh("wood-like-al", 2.1364, 3.0828e-6 / 4.0, gamma, 100.0);
    let s = render_strike(
        Struck::Object {
            material: &truth,
            model: &model,
            hit: &hit,
            same_object: true,
        },
        &StrikeParams {
            residual: false,
            duration_s: 1.0,
            ..StrikeParams::default()
        },
    )
    .unwrap();
    let fs = 48000.0;
    let peak = s.samples.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let clean: Vec<f64> = s
        .samples
        .iter()
        .map(|&v| f64::from(v / peak) * 0.5)
        .collect();
    let raw = as_recorded(&clean, fs, 1.0, 11);
    let (a, b) = estimate_both(&clean, &raw, fs, &model, &hit, &AnalyzeParams::default());
    eprintln!("rendered: trimmed {a:?}\n          raw     {b:?}");
    assert!((b.gamma / a.gamma - 1.0).abs() < 0.1, "{a:?} vs {b:?}");
    // The renderer is an independent forward model (resonator bank, Hertz contact).
    for p in [a, b] {
        assert!((p.gamma / gamma - 1.0).abs() < 5e-3, "{p:?}");
        assert!((p.beta / truth.beta - 1.0).abs() < 0.03, "{p:?}");
    }

    let koi = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/recordings/realimpact-mesheditor/CeramicKoiBowlImpact.wav");
    if !koi.exists() {
        eprintln!("skipping the RealImpact part: {} is absent", koi.display());
        return;
    }
    let clip = resound_io::load_audio(&koi).unwrap();
    let x = clip.mono(None, &koi).unwrap();
    let fs = f64::from(clip.sample_rate_hz);
    let ceramic = Material::preset("ceramic").unwrap();
    let bowl = resound_fem::primitive::bowl(0.1, 0.006, 0.06, 32);
    let model = resound_modal::ModalBuilder::surface(&bowl, &ceramic)
        .modes(40)
        .solve()
        .unwrap()
        .model;
    let hit = model.hit([0.1, 0.0, 0.0]).unwrap();
    let raw = as_recorded(&x, fs, 1.0, 12);
    let (a, b) = estimate_both(
        &x,
        &raw,
        fs,
        &model,
        &hit,
        &AnalyzeParams {
            highpass_hz: Some(60.0),
            ..Default::default()
        },
    );
    eprintln!("Koi bowl: trimmed {a:?}\n          raw     {b:?}");
    assert!((b.gamma / a.gamma - 1.0).abs() < 0.1, "{a:?} vs {b:?}");
}

/// Both microphones of the bundled ramp recording, fitted jointly (`analyze --joint
/// --every-channel`): each channel's own fit of every pole both hear agrees with the other's
/// within their σ (damping for all but one in ten, frequency for three in four), and the
/// report reads back as written.
#[test]
fn both_channels_of_the_ramp_give_the_same_poles_within_their_sigma() {
    let path = assets().join("steel_nut_M4_2.wav");
    let (report, joint) = resound::joint::analyze_joint(
        &[&path],
        &Default::default(),
        &AnalyzeParams::default(),
        resound::recording::TakeSelection {
            every_channel: true,
            every_strike: false,
        },
        &Default::default(),
        &|_| {},
    )
    .unwrap();
    assert_eq!(report.takes.len(), 2);
    assert_eq!(report.modes.len(), joint.modes.len());
    let mut zf = Vec::new();
    let mut zd = Vec::new();
    for m in report.modes.iter().filter(|m| m.heard_in == 2) {
        let (Some(a), Some(b)) = (m.own[0], m.own[1]) else {
            panic!("a pole both channels hear lacks a channel's own fit: {m:?}");
        };
        let (Some(sa), Some(sb)) = (a.sigma, b.sigma) else {
            continue;
        };
        zf.push((a.freq_hz - b.freq_hz).abs() / sa.freq_hz.hypot(sb.freq_hz));
        zd.push(
            (a.damping_per_s - b.damping_per_s).abs() / sa.damping_per_s.hypot(sb.damping_per_s),
        );
    }
    let share = |z: &[f64]| z.iter().filter(|&&v| v <= 3.0).count() as f64 / z.len() as f64;
    eprintln!(
        "{} poles heard by both channels: f within 3σ {:.0} %, d within 3σ {:.0} %",
        zf.len(),
        100.0 * share(&zf),
        100.0 * share(&zd)
    );
    assert!(zf.len() >= 15, "{zf:?}");
    assert!(share(&zd) >= 0.9, "{zd:?}");
    assert!(share(&zf) >= 0.75, "{zf:?}");
    // Every take's modes are the shared poles, and the JSON reads back to the same modes.
    let text = serde_json::to_string(&report).unwrap();
    let back: resound::joint::JointReport = serde_json::from_str(&text).unwrap();
    for take in 0..2 {
        assert_eq!(back.take_modes(take), report.take_modes(take));
        assert_eq!(report.take_modes(take), joint.take_modes(take));
        assert!(report.take_modes(take).len() >= 15);
    }
}

/// Every strike of both channels of the ramp recording: the strikes are found once (on the
/// mix), so strike K is the same event in both channels; the poles most takes hear come out
/// of each take's own fit within 3σ of the joint pole (measured: d for 90 % of 161 fits, f
/// for 83 %; required: 85 % and 70 %).
#[test]
fn every_strike_of_both_ramp_channels_gives_the_joint_poles_within_sigma() {
    let path = assets().join("steel_nut_M4_2.wav");
    let (report, _) = resound::joint::analyze_joint(
        &[&path],
        &Default::default(),
        &AnalyzeParams::default(),
        resound::recording::TakeSelection {
            every_channel: true,
            every_strike: true,
        },
        &Default::default(),
        &|_| {},
    )
    .unwrap();
    let takes = &report.takes;
    assert!(takes.len() >= 6 && takes.len() % 2 == 0, "{takes:?}");
    let half = takes.len() / 2;
    for k in 0..half {
        assert!(
            takes[k].label.contains("channel 1") && takes[k + half].label.contains("channel 2")
        );
        assert!(
            (takes[k].onset_s - takes[k + half].onset_s).abs() < 0.002,
            "strike {} differs between channels: {takes:?}",
            k + 1
        );
    }
    let (mut zf, mut zd) = (Vec::new(), Vec::new());
    let common: Vec<_> = report
        .modes
        .iter()
        .filter(|m| 2 * m.heard_in >= takes.len())
        .collect();
    for m in &common {
        for own in m.own.iter().flatten() {
            if let Some(s) = own.sigma {
                zf.push((own.freq_hz - m.freq_hz).abs() / s.freq_hz);
                zd.push((own.damping_per_s - m.damping_per_s).abs() / s.damping_per_s);
            }
        }
    }
    let share = |z: &[f64]| z.iter().filter(|&&v| v <= 3.0).count() as f64 / z.len() as f64;
    eprintln!(
        "{} takes, {} poles heard by half of them, {} own fits: f within 3σ {:.0} %, d {:.0} %",
        takes.len(),
        common.len(),
        zf.len(),
        100.0 * share(&zf),
        100.0 * share(&zd)
    );
    assert!(common.len() >= 12, "{}", common.len());
    assert!(share(&zd) >= 0.85, "{zd:?}");
    assert!(share(&zf) >= 0.7, "{zf:?}");
}

/// A real RealImpact strike fitted "jointly" as its only take: the take's own refit of every
/// pole lands on the joint pole (within half its σ). A joint fit that left clusters short of
/// convergence after its sweeps flagged 18 of 28 poles of this bowl as disagreeing with
/// themselves.
#[test]
fn one_real_take_agrees_with_its_own_joint_fit() {
    let Some(data) = shared_data() else {
        eprintln!("skipped: ../shared/data is not here");
        return;
    };
    let path = data.join("recordings/realimpact-mesheditor/CeramicKoiBowlImpact.wav");
    let (report, _) = resound::joint::analyze_joint(
        &[&path],
        &Default::default(),
        &AnalyzeParams::default(),
        Default::default(),
        &Default::default(),
        &|_| {},
    )
    .unwrap();
    assert!(report.modes.len() >= 10, "{}", report.modes.len());
    for m in &report.modes {
        assert!(m.disagreement_sigmas < 0.5 && !m.disagree, "{m:?}");
    }
    assert!(report
        .warnings
        .iter()
        .any(|w| w.message.contains("one take only")));
}
