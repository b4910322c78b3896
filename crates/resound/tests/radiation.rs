//! Radiation in strikes: invariances that need no ground truth, and what a strike with a
//! microphone reports.
#![allow(clippy::unwrap_used)]

use resound::core::radiation::FieldScratch;
use resound::core::Material;
use resound::strike::{render_strike, StrikeParams, Struck};

fn bar_model() -> resound::core::ModalModel {
    let steel = Material::preset("steel").unwrap();
    let bar = resound_fem::primitive::bar([0.2, 0.04, 0.02]).refined(0.006);
    let mut model = resound_modal::ModalBuilder::surface(&bar, &steel)
        .modes(12)
        .solve()
        .unwrap()
        .model;
    resound::radiation::add_transfer(&mut model, &resound::modal::TransferParams::default())
        .unwrap();
    model
}

fn db(x: f64) -> f64 {
    20.0 * x.log10()
}

/// A bar symmetric under x → −x, y → −y and z → −z radiates the same level to mirrored
/// microphones, mode by mode (each mode is symmetric or antisymmetric), near (0.3 m) and far
/// (3 m). Compared where the mode radiates within 10 dB of its loudest direction (near a
/// radiation null a level in dB means nothing; the voxel FEM's own shapes are symmetric only
/// to a few per cent). Then a strike with a microphone: the modes' frequencies and dampings
/// are the material's, only their levels change, and a microphone inside the object warns.
#[test]
fn mirrored_microphones_hear_each_mode_of_a_symmetric_bar_alike() {
    let model = bar_model();
    let t = model.transfer.as_ref().unwrap();
    let mut s = FieldScratch::default();
    let mut diffs = Vec::new();
    // Directions in one octant (all components non-zero), mirrored into the others.
    let dirs: Vec<[f64; 3]> = (0..12)
        .map(|i| {
            let a = 0.2 + 0.11 * i as f64;
            let b = 0.3 + 0.09 * i as f64;
            [a.sin() * b.cos(), a.sin() * b.sin(), a.cos()]
        })
        .collect();
    for j in 0..model.n_modes() {
        let f = model.freq_hz(j);
        for r in [0.3, 3.0] {
            let mut rows = Vec::new();
            for d in &dirs {
                let levels: Vec<f64> = [
                    [1.0, 1.0, 1.0],
                    [-1.0, 1.0, 1.0],
                    [1.0, -1.0, 1.0],
                    [1.0, 1.0, -1.0],
                    [-1.0, -1.0, -1.0],
                ]
                .iter()
                .map(|m| {
                    db(t.pressure(j, f, [0, 1, 2].map(|c| r * d[c] * m[c]), &mut s)
                        .unwrap())
                })
                .collect();
                rows.push(levels);
            }
            let top = rows.iter().flatten().copied().fold(f64::MIN, f64::max);
            for l in &rows {
                if l.iter().all(|&v| v > top - 10.0) {
                    diffs.extend(l[1..].iter().map(|v| (v - l[0]).abs()));
                }
            }
        }
    }
    diffs.sort_by(f64::total_cmp);
    let q = |p: f64| diffs[((diffs.len() - 1) as f64 * p) as usize];
    eprintln!(
        "mirror differences over {} pairs: median {:.2} dB, 90 % {:.2} dB, worst {:.2} dB",
        diffs.len(),
        q(0.5),
        q(0.9),
        q(1.0)
    );
    assert!(diffs.len() > 100, "{} pairs", diffs.len());
    assert!(
        q(0.5) < 0.5 && q(0.9) < 2.0,
        "median {:.2}, 90 % {:.2}",
        q(0.5),
        q(0.9)
    );

    // A strike heard by a microphone 0.5 m above: the same modes, other levels.
    let material =
        resound::material::resolve_material("steel", std::path::Path::new("."), None).unwrap();
    let hit = model.hit([0.05, 0.02, 0.01]).unwrap();
    let struck = Struck::Object {
        material: &material,
        model: &model,
        hit: &hit,
        same_object: false,
    };
    let plain = render_strike(
        struck,
        &StrikeParams {
            residual: false,
            ..Default::default()
        },
    )
    .unwrap();
    let heard = render_strike(
        struck,
        &StrikeParams {
            residual: false,
            mic_m: Some([0.0, 0.5, 0.0]),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(plain.modes.len(), heard.modes.len());
    let mut changed = 0;
    for (a, b) in plain.modes.iter().zip(&heard.modes) {
        assert_eq!(a.freq_hz, b.freq_hz);
        assert_eq!(a.damping_per_s, b.damping_per_s);
        if (a.gain.abs() - b.gain.abs()).abs() > 1e-3 * a.gain.abs() {
            changed += 1;
        }
    }
    assert!(
        changed >= plain.modes.len() / 2,
        "{changed} of {} levels changed",
        plain.modes.len()
    );
    // No word about the microphone (a built-in steel's level is faint, which is said too).
    assert!(
        heard
            .info
            .warnings
            .iter()
            .all(|w| w.kind == resound_core::WarningKind::Quiet),
        "{:?}",
        heard.info.warnings
    );
    assert_eq!(heard.info.mic, Some([0.0, 0.5, 0.0]));
    let inside = render_strike(
        struck,
        &StrikeParams {
            residual: false,
            mic_m: Some([0.0, 0.0, 0.0]),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        inside
            .info
            .warnings
            .iter()
            .any(|w| w.message.contains("inside")),
        "{:?}",
        inside.info.warnings
    );
}

/// A scene of one fixed steel bar, turned 90° about y and struck once by a silent ball in zero
/// gravity, rendered with and without `radiation = true`: the physics and forces are the
/// same, so each mode's amplitude at the listener (fitted by least squares with the mode's
/// known frequency and decay) must change by exactly that mode's radiation factor at the
/// listener *seen from the bar* (`AcousticTransfer::factor`, the single-mode path, at the
/// listener turned into the body frame). The factors must differ from mode to mode and from
/// the un-turned listener's, so a constant scale or a wrong frame fails.
#[test]
fn a_scene_body_radiates_each_mode_by_its_transfer_in_its_own_frame() {
    let scene_text = |radiation: bool| {
        format!(
            r#"
duration = 0.6
sample_rate = 48000
stereo = false
radiation = {radiation}
gravity = [0.0, 0.0, 0.0]
[listener]
position = [0.25, 0.35, 0.15]
[air]
absorption = false
[[body]]
name = "bar"
fixed = true
shape = {{ box = [0.2, 0.03, 0.02] }}
material = "preset:steel"
density = 7850
rotation = [0.0, 90.0, 0.0]
modes = 8
contact_damping = 0.0   # a fixed body is otherwise damped by its mounting
[[body]]
name = "ball"
shape = {{ sphere = 0.015 }}
material = "preset:steel"
density = 7850
position = [0.0, 0.05, 0.03]
velocity = [0.0, -3.0, 0.0]
restitution = 0.8
sound = false
"#
        )
    };
    let dir = tempfile::tempdir().unwrap();
    let quiet = |_: resound::Progress| {};
    let render = |radiation: bool| {
        let scene = resound::io::scene::parse_scene(&scene_text(radiation), "bar.toml").unwrap();
        let (bodies, params) = resound::scene::build_scene(
            &scene,
            &resound::scene::BuildOptions {
                base_dir: dir.path(),
                library: None,
                cache_dir: None,
                progress: &quiet,
            },
        )
        .unwrap();
        let out = resound::physics::simulate(&bodies, &params, &|_| {}).unwrap();
        (bodies, out)
    };
    let (plain_bodies, plain) = render(false);
    let (bodies, heard) = render(true);
    let impacts: Vec<f64> = heard
        .events
        .iter()
        .filter(|e| matches!(e.kind, resound::physics::ContactKind::Impact))
        .map(|e| e.time_s)
        .collect();
    assert_eq!(impacts.len(), 1, "one impact, got {impacts:?}");
    assert_eq!(plain.events.len(), heard.events.len());
    let sound = bodies[0].sound.as_ref().unwrap();
    assert!(plain_bodies[0].sound.as_ref().unwrap().radiation.is_none());
    let rad = sound.radiation.as_ref().expect("the bar radiates");
    let modes = &sound.modes;

    // Each mode's amplitude from 20 ms after the impact (pulse and propagation over), 0.3 s.
    let fs = 48_000.0;
    let start = ((impacts[0] + 0.02) * fs) as usize;
    let n = (0.3 * fs) as usize;
    let amplitudes = |x: &[f32]| -> Vec<f64> {
        let cols = 2 * modes.len();
        let mut ata = vec![vec![0.0f64; cols + 1]; cols];
        let mut row = vec![0.0f64; cols];
        for k in 0..n {
            let t = k as f64 / fs;
            for (j, &(f, d)) in modes.iter().enumerate() {
                let (s, c) = (std::f64::consts::TAU * f * t).sin_cos();
                let e = (-d * t).exp();
                row[2 * j] = e * c;
                row[2 * j + 1] = e * s;
            }
            let y = f64::from(x[start + k]);
            for a in 0..cols {
                for b in 0..cols {
                    ata[a][b] += row[a] * row[b];
                }
                ata[a][cols] += row[a] * y;
            }
        }
        // Gaussian elimination with partial pivoting.
        for c in 0..cols {
            let p = (c..cols)
                .max_by(|&a, &b| ata[a][c].abs().total_cmp(&ata[b][c].abs()))
                .unwrap();
            ata.swap(c, p);
            for r in 0..cols {
                if r != c {
                    let q = ata[r][c] / ata[c][c];
                    for k in c..=cols {
                        ata[r][k] -= q * ata[c][k];
                    }
                }
            }
        }
        (0..modes.len())
            .map(|j| {
                let a = ata[2 * j][cols] / ata[2 * j][2 * j];
                let b = ata[2 * j + 1][cols] / ata[2 * j + 1][2 * j + 1];
                a.hypot(b)
            })
            .collect()
    };
    let a_plain = amplitudes(&plain.channels[0]);
    let a_heard = amplitudes(&heard.channels[0]);

    // The listener in the bar's frame: R⁻¹ (L − p), R a 90° turn about y.
    let l = [0.25, 0.35, 0.15];
    let (s, c) = std::f64::consts::FRAC_PI_2.sin_cos();
    let local = [c * l[0] - s * l[2], l[1], s * l[0] + c * l[2]];
    let mut scratch = FieldScratch::default();
    let top = a_plain.iter().copied().fold(0.0, f64::max);
    let mut compared = 0;
    let (mut lo, mut hi, mut frame_sensitive) = (f64::MAX, 0.0f64, false);
    let mut worst = 0.0f64;
    for (i, &(f, _)) in modes.iter().enumerate() {
        let j = rad.modes[i];
        let want = rad.transfer.factor(j, f, local, &mut scratch).unwrap();
        let unturned = rad.transfer.factor(j, f, l, &mut scratch).unwrap();
        let got = a_heard[i] / a_plain[i];
        eprintln!(
            "mode {i}: {f:8.1} Hz  amplitude {:.3e}  factor {want:.4e}  measured {got:.4e}  \
             (un-turned listener {unturned:.4e})",
            a_plain[i]
        );
        if a_plain[i] < 1e-4 * top {
            continue;
        }
        worst = worst.max((got / want - 1.0).abs());
        lo = lo.min(want);
        hi = hi.max(want);
        frame_sensitive |= (unturned / want - 1.0).abs() > 0.1;
        compared += 1;
    }
    assert!(compared >= 6, "{compared} modes loud enough to compare");
    assert!(
        worst < 0.02,
        "measured factors off the transfer's by up to {worst:.3}"
    );
    assert!(
        hi / lo > 2.0,
        "factors {lo:.3e}..{hi:.3e}: too alike to tell"
    );
    assert!(frame_sensitive, "the body's turn changes no factor");
}

/// `estimate --mic`: a strike of a known material on the steel bar rendered as a microphone
/// hears it (`synth --mic`), analysed and estimated back. With the microphone in the forward
/// model the estimated modes' levels follow the recorded ones (the per-mode level ratios of
/// paired modes spread little) and γ is the truth's; without it, the modes' radiation is
/// missing from the forward model and the estimate goes wrong or its levels do. The material
/// is stiffer than the model's own, so the factors must follow γ: the estimate reports the
/// microphone and settles in two to four passes.
#[test]
fn an_estimate_with_the_microphone_hears_the_modes_as_recorded() {
    use resound::material::{estimate_material, EstimateMaterialParams};
    let model = bar_model();
    let hit = model.hit([0.07, 0.02, 0.01]).unwrap();
    let steel = Material::preset("steel").unwrap();
    // A stiffer material than the model's own: its modes sound 0.29 octaves higher, where the
    // radiation differs, so the estimate must follow γ with the factors (more than one pass).
    let gamma = 1.5 * steel.youngs_modulus / steel.density;
    let truth = resound_core::SoundMaterial::rayleigh("stiff", 3.0, 4e-8, gamma, 100.0);
    let mic = [0.05, 0.35, 0.25];
    let strike = render_strike(
        Struck::Object {
            material: &truth,
            model: &model,
            hit: &hit,
            same_object: true,
        },
        &StrikeParams {
            residual: false,
            duration_s: 1.0,
            mic_m: Some(mic),
            ..Default::default()
        },
    )
    .unwrap();
    let fs = 48_000.0;
    let x: Vec<f64> = strike.samples.iter().map(|&v| f64::from(v)).collect();
    let analysis = resound::recording::analyze_samples(&x, fs, &Default::default()).unwrap();
    let spread_db = |info: &resound::material::EstimateInfo| {
        let mut ratios = Vec::new();
        // Below 10 kHz: above, the renderer's Hertz pulse (5 mm steel ball) rolls the recorded
        // modes off, which the estimator's impulse model does not (both with and without).
        for r in analysis.modes.iter().filter(|r| r.freq_hz < 10_000.0) {
            if let Some(e) = info
                .estimated_modes
                .iter()
                .find(|e| (e.freq_hz / r.freq_hz - 1.0).abs() < 0.01)
            {
                eprintln!(
                    "  {:8.1} Hz  recorded {:.3e}  estimated {:.3e}  ratio {:+.2} dB",
                    r.freq_hz,
                    r.amplitude,
                    e.amplitude,
                    db(e.amplitude / r.amplitude)
                );
                ratios.push(db(e.amplitude / r.amplitude));
            }
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len().max(1) as f64;
        let sd = (ratios.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
            / ratios.len().saturating_sub(1).max(1) as f64)
            .sqrt();
        (ratios.len(), sd)
    };
    let params = EstimateMaterialParams {
        residual: false,
        allow_implausible: true,
        ..Default::default()
    };
    let (_, plain) = estimate_material(&analysis, &model, &hit, &params, &|_| {}).unwrap();
    let (_, heard) = estimate_material(
        &analysis,
        &model,
        &hit,
        &EstimateMaterialParams {
            mic_m: Some(mic),
            ..params.clone()
        },
        &|_| {},
    )
    .unwrap();
    let (n_plain, sd_plain) = spread_db(&plain);
    let (n_heard, sd_heard) = spread_db(&heard);
    eprintln!(
        "without the microphone: {:?}, {n_plain} paired modes, level ratios spread {sd_plain:.2} dB\n\
         with it ({} passes):    {:?}, {n_heard} paired modes, level ratios spread {sd_heard:.2} dB",
        plain.params, heard.passes, heard.params
    );
    assert_eq!(heard.mic, Some(mic));
    assert_eq!(plain.mic, None);
    assert_eq!(plain.passes, 1);
    assert!((2..=resound::material::MIC_PASSES).contains(&heard.passes));
    assert!(n_heard >= 4, "{n_heard} paired modes below 10 kHz");
    let p = heard.params;
    assert!((p.gamma / gamma - 1.0).abs() < 0.01, "{p:?}");
    assert!((p.beta / truth.beta - 1.0).abs() < 0.03, "{p:?}");
    assert!((p.alpha / truth.alpha - 1.0).abs() < 0.1, "{p:?}");
    assert!(
        sd_heard < 0.5,
        "level ratios spread {sd_heard:.2} dB with the microphone"
    );
    // The microphone matters here: without it the estimate is off or its levels are.
    let plain_off = (plain.params.gamma / gamma - 1.0).abs() > 0.05;
    assert!(
        plain_off || n_plain < n_heard || sd_plain > 2.0 * sd_heard,
        "without the microphone as good: {:?}, {sd_plain:.2} dB",
        plain.params
    );
}

/// A thin plate (4 mm under a 200 × 150 mm face) gets equivalent sources inside its wall and
/// a transfer; by its mirror symmetry z → −z each mode sounds as loud 0.3 m above as below.
#[test]
fn a_thin_plate_radiates_and_sounds_alike_on_both_sides() {
    // As `resound synth --mesh plate.obj --mic …` and the studio make it: the primitive's
    // file, voxelized (the wall is one or two voxels thick).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plate.obj");
    resound::mesh::write_primitive(
        resound::mesh::PrimitiveKind::Plate,
        &[0.2, 0.15, 0.004],
        48,
        &path,
    )
    .unwrap();
    let mut params = resound::object::ObjectParams::default();
    params.modal.n_modes = Some(6);
    let mut model = resound::object::load_object(&path, &params, &|_| {}).unwrap();
    resound::radiation::add_transfer(&mut model, &resound::modal::TransferParams::default())
        .expect("a thin plate's transfer");
    let t = model.transfer.as_ref().unwrap();
    let mut s = FieldScratch::default();
    let mut diffs = Vec::new();
    for j in 0..model.n_modes() {
        let f = model.freq_hz(j);
        // Directions over the upper half, each compared with its mirror below, where the mode
        // radiates within 10 dB of its loudest of these (a level near a null means nothing).
        let pairs: Vec<(f64, f64)> = (0..16)
            .map(|i| {
                let (a, b) = (0.15 + 0.08 * i as f64, 0.7 * i as f64);
                let d = [a.sin() * b.cos(), a.sin() * b.sin(), a.cos()].map(|c| 0.3 * c);
                let up = t.pressure(j, f, d, &mut s).unwrap();
                let down = t.pressure(j, f, [d[0], d[1], -d[2]], &mut s).unwrap();
                assert!(up.is_finite() && down.is_finite() && up > 0.0);
                (db(up), db(down))
            })
            .collect();
        let top = pairs.iter().map(|p| p.0.max(p.1)).fold(f64::MIN, f64::max);
        diffs.extend(
            pairs
                .iter()
                .filter(|p| p.0.min(p.1) > top - 10.0)
                .map(|p| (p.0 - p.1).abs()),
        );
    }
    diffs.sort_by(f64::total_cmp);
    let median = diffs[diffs.len() / 2];
    let worst = diffs[diffs.len() - 1];
    eprintln!(
        "thin plate, above vs below over {} pairs: median {median:.2} dB, worst {worst:.2} dB",
        diffs.len()
    );
    assert!(diffs.len() >= 30);
    assert!(
        median < 0.5 && worst < 2.0,
        "median {median} dB, worst {worst} dB"
    );
}
