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
    assert!(heard.info.warnings.is_empty(), "{:?}", heard.info.warnings);
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
        inside.info.warnings.iter().any(|w| w.contains("inside")),
        "{:?}",
        inside.info.warnings
    );
}
