//! Acoustic transfer against the analytic fields of a pulsating sphere (monopole) and a rigidly
//! oscillating sphere (dipole), for ka from 0.05 to 20, and its convergence as the mesh is
//! refined.
#![allow(clippy::unwrap_used)]

use resound_core::radiation::{FieldScratch, AIR_DENSITY_KG_M3, SOUND_SPEED_M_S};
use resound_fem::primitive::sphere;
use resound_modal::radiation::{fit_transfer, vertex_normals_and_areas, TransferParams};

const A: f64 = 0.1;
const KA: [f64; 8] = [0.05, 0.1, 0.3, 1.0, 2.5, 5.0, 10.0, 20.0];

fn params() -> TransferParams {
    TransferParams {
        span_octaves: 0.34,
        // Enough sources for ka = 20 on the finest mesh (1.5 (ka + 3)² ≈ 800).
        max_sources: 1000,
        ..TransferParams::default()
    }
}

/// |p| of a pulsating sphere (radius A, normal velocity 1 m/s) at r: ρc (a/r) ka/√(1+(ka)²).
fn monopole(ka: f64, r: f64) -> f64 {
    AIR_DENSITY_KG_M3 * SOUND_SPEED_M_S * (A / r) * ka / (1.0 + ka * ka).sqrt()
}

/// |p| of a sphere oscillating at 1 m/s along its axis, at r and angle θ to the axis:
/// ρc |cos θ| |h1(kr)| / |h1'(ka)| with |h1(x)| = √(1+x²)/x², |h1'(x)| = √(x⁴+4)/x³.
fn dipole(ka: f64, r: f64, cos_t: f64) -> f64 {
    let kr = ka * r / A;
    let h1 = (1.0 + kr * kr).sqrt() / (kr * kr);
    let dh1 = (ka.powi(4) + 4.0).sqrt() / ka.powi(3);
    AIR_DENSITY_KG_M3 * SOUND_SPEED_M_S * cos_t.abs() * h1 / dh1
}

fn db(x: f64) -> f64 {
    20.0 * x.log10()
}

/// Worst level error (dB) over ka, listener distances and directions, and worst directivity
/// error (degrees: the dipole's null), for a UV sphere of `segments`.
fn errors(segments: usize, axis: [f64; 3]) -> (f64, f64) {
    let mesh = sphere(A, segments);
    let (normals, _) = vertex_normals_and_areas(&mesh.vertices, &mesh.triangles);
    let nv = mesh.vertices.len();
    // Outward sign from the geometry (the patterns are along the mesh's normals).
    let sign: Vec<f64> = (0..nv)
        .map(|v| {
            let d: f64 = (0..3).map(|c| mesh.vertices[v][c] * normals[v][c]).sum();
            d.signum()
        })
        .collect();
    let freqs: Vec<f64> = KA
        .iter()
        .map(|ka| ka * SOUND_SPEED_M_S / (2.0 * std::f64::consts::PI * A))
        .collect();
    let mut patterns = Vec::new();
    for _ in &freqs {
        patterns.extend((0..nv).map(|v| sign[v]));
    }
    for _ in &freqs {
        // The normal velocity of rigid motion at 1 m/s along `axis`: U·n.
        patterns.extend((0..nv).map(|v| (0..3).map(|c| axis[c] * normals[v][c]).sum::<f64>()));
    }
    let mut all = freqs.clone();
    all.extend(&freqs);
    let (t, info) =
        fit_transfer(&mesh.vertices, &mesh.triangles, &patterns, &all, &params()).expect("fit");
    assert!(info.worst_residual.is_finite());
    if std::env::var("RAD_DEBUG").is_ok() {
        eprintln!("{info:?}");
    }
    let mut scratch = FieldScratch::default();
    let (mut level, mut angle) = (0.0f64, 0.0f64);
    // A direction basis perpendicular to `axis`.
    let perp = {
        let p = if axis[2].abs() < 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let d: f64 = (0..3).map(|c| p[c] * axis[c]).sum();
        let q = [p[0] - d * axis[0], p[1] - d * axis[1], p[2] - d * axis[2]];
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        q.map(|x| x / n)
    };
    for (i, (&ka, &f)) in KA.iter().zip(&freqs).enumerate() {
        for &r in &[1.5 * A, 5.0 * A, 100.0 * A] {
            // Monopole: every direction alike.
            for dir in [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [-0.48, -0.6, 0.64]] {
                let x = [dir[0] * r, dir[1] * r, dir[2] * r];
                let p = t.pressure(i, f, x, &mut scratch).unwrap();
                let e = (db(p) - db(monopole(ka, r))).abs();
                if e > 0.5 && std::env::var("RAD_DEBUG").is_ok() {
                    eprintln!("monopole seg {segments} ka {ka} r {r}: {e:.2} dB");
                }
                level = level.max(e);
            }
            // Dipole: a sweep of angles from the axis; the level where |cos θ| > 0.2 and the
            // direction of the quietest point (the null at 90°).
            let mut quietest = (f64::INFINITY, 0.0);
            for step in 0..=72 {
                let th = (step as f64 * 2.5).to_radians();
                let d = [0, 1, 2].map(|c| th.cos() * axis[c] + th.sin() * perp[c]);
                let x = d.map(|c| c * r);
                let p = t.pressure(KA.len() + i, f, x, &mut scratch).unwrap();
                if th.cos().abs() > 0.2 {
                    let e = (db(p) - db(dipole(ka, r, th.cos()))).abs();
                    if e > 0.5 && std::env::var("RAD_DEBUG").is_ok() {
                        eprintln!("dipole seg {segments} ka {ka} r {r} th {th:.2}: {e:.2} dB");
                    }
                    level = level.max(e);
                }
                if p < quietest.0 {
                    quietest = (p, step as f64 * 2.5);
                }
            }
            angle = angle.max((quietest.1 - 90.0).abs());
        }
    }
    (level, angle)
}

#[test]
fn spheres_radiate_as_the_analytic_monopole_and_dipole() {
    let (level, angle) = errors(64, [0.0, 0.0, 1.0]);
    assert!(level < 1.0, "level error {level:.3} dB");
    assert!(angle <= 10.0, "null {angle}° off");
    // An oblique axis exercises the m ≠ 0 harmonics.
    let s = 1.0 / 3f64.sqrt();
    let (level, angle) = errors(64, [s, s, s]);
    assert!(level < 1.0, "oblique: level error {level:.3} dB");
    assert!(angle <= 10.0, "oblique: null {angle}° off");
}

#[test]
fn refining_the_sphere_converges() {
    let mut table = Vec::new();
    for segments in [16, 32, 64, 96] {
        let (level, angle) = errors(segments, [0.0, 0.0, 1.0]);
        eprintln!("segments {segments:3}: level error {level:.4} dB, null {angle:.1}° off");
        table.push(level);
    }
    // Each refinement cuts the error by 30 % or more until it reaches the floor of the
    // frequency grid's log-log interpolation (about 0.1 dB at 3 points per octave).
    for w in table.windows(2) {
        assert!(w[1] < 0.7 * w[0] || w[1] < 0.1, "{table:?}");
    }
    assert!(table[3] < 0.1, "{table:?}");
}

#[test]
fn bad_surfaces_and_patterns_are_errors_not_panics() {
    let mesh = sphere(A, 16);
    let nv = mesh.vertices.len();
    let ones = vec![1.0; nv];
    let mut bad_tri = mesh.triangles.clone();
    bad_tri[3][1] = nv as u32 + 5;
    let e = fit_transfer(&mesh.vertices, &bad_tri, &ones, &[500.0], &params()).unwrap_err();
    assert!(e.to_string().contains("refers past"), "{e}");
    let mut nan = ones.clone();
    nan[7] = f64::NAN;
    let e = fit_transfer(&mesh.vertices, &mesh.triangles, &nan, &[500.0], &params()).unwrap_err();
    assert!(e.to_string().contains("not finite"), "{e}");
    let e = fit_transfer(
        &mesh.vertices,
        &mesh.triangles,
        &ones[1..],
        &[500.0],
        &params(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("pattern values"), "{e}");
}
