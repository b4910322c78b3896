//! Closed primitive surface meshes for tests and users, centred on the origin, in m.

use crate::surface::SurfaceMesh;
use std::f64::consts::PI;

/// Axis-aligned box with edge lengths `size` (m), 8 vertices and 12 triangles, outward.
pub fn bar(size: [f64; 3]) -> SurfaceMesh {
    let h = size.map(|s| 0.5 * s);
    let vertices = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { -h[0] } else { h[0] },
                if i & 2 == 0 { -h[1] } else { h[1] },
                if i & 4 == 0 { -h[2] } else { h[2] },
            ]
        })
        .collect();
    // Faces as quads (counter-clockwise from outside), split into two triangles.
    let quads: [[u32; 4]; 6] = [
        [0, 2, 3, 1], // z-
        [4, 5, 7, 6], // z+
        [0, 1, 5, 4], // y-
        [2, 6, 7, 3], // y+
        [0, 4, 6, 2], // x-
        [1, 3, 7, 5], // x+
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    SurfaceMesh {
        vertices,
        triangles,
    }
}

/// A plate: a box `size_x × size_y × thickness` (m).
pub fn plate(size_x: f64, size_y: f64, thickness: f64) -> SurfaceMesh {
    bar([size_x, size_y, thickness])
}

/// Solid of revolution about z of a profile (r, z) running from a point on the axis to another
/// point on the axis, with `segments` around. The profile must go upward along the outside.
pub fn revolve(profile: &[(f64, f64)], segments: usize) -> SurfaceMesh {
    let segments = segments.max(3);
    let mut vertices = Vec::new();
    let mut index = Vec::with_capacity(profile.len());
    for &(r, z) in profile {
        if r <= 0.0 {
            vertices.push([0.0, 0.0, z]);
            index.push(vec![(vertices.len() - 1) as u32; segments]);
        } else {
            let ring = (0..segments)
                .map(|j| {
                    let phi = 2.0 * PI * j as f64 / segments as f64;
                    vertices.push([r * phi.cos(), r * phi.sin(), z]);
                    (vertices.len() - 1) as u32
                })
                .collect();
            index.push(ring);
        }
    }
    let mut triangles = Vec::new();
    for i in 0..profile.len() - 1 {
        for j in 0..segments {
            let j1 = (j + 1) % segments;
            let (a, b, c, d) = (index[i][j], index[i][j1], index[i + 1][j1], index[i + 1][j]);
            for t in [[a, b, c], [a, c, d]] {
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    triangles.push(t);
                }
            }
        }
    }
    SurfaceMesh {
        vertices,
        triangles,
    }
}

/// Closed cylinder of `radius` and `height` (m) along z.
pub fn cylinder(radius: f64, height: f64, segments: usize) -> SurfaceMesh {
    let h = 0.5 * height;
    revolve(&[(0.0, -h), (radius, -h), (radius, h), (0.0, h)], segments)
}

/// UV sphere of `radius` (m) with `segments` around and `segments / 2` rings.
pub fn sphere(radius: f64, segments: usize) -> SurfaceMesh {
    let rings = (segments / 2).max(2);
    let profile: Vec<_> = (0..=rings)
        .map(|i| {
            let t = -0.5 * PI + PI * i as f64 / rings as f64;
            if i == 0 || i == rings {
                (0.0, radius * t.sin())
            } else {
                (radius * t.cos(), radius * t.sin())
            }
        })
        .collect();
    revolve(&profile, segments)
}

/// Bowl: a spherical shell cap of outer `radius`, wall `thickness` and `depth` (m, ≤ radius
/// gives a cap no deeper than a hemisphere), opening upward with the rim at z = 0.
pub fn bowl(radius: f64, thickness: f64, depth: f64, segments: usize) -> SurfaceMesh {
    let depth = depth.clamp(thickness * 1.01, radius);
    let inner = radius - thickness;
    let z_rim = depth - radius; // sphere centred at origin; shift later so rim sits at 0
    let n_arc = (segments / 4).max(4);
    let mut profile = Vec::new();
    // Outer arc: bottom pole up to the rim.
    let t0 = -0.5 * PI;
    let t1 = (z_rim / radius).asin();
    for i in 0..=n_arc {
        let t = t0 + (t1 - t0) * i as f64 / n_arc as f64;
        let r = if i == 0 { 0.0 } else { radius * t.cos() };
        profile.push((r, radius * t.sin()));
    }
    // Inner arc: rim down to the inner bottom pole.
    let s1 = (z_rim / inner).clamp(-1.0, 1.0).asin();
    for i in 0..=n_arc {
        let t = s1 + (t0 - s1) * i as f64 / n_arc as f64;
        let r = if i == n_arc { 0.0 } else { inner * t.cos() };
        profile.push((r, inner * t.sin()));
    }
    let mut m = revolve(&profile, segments);
    // The inner arc runs downward on the inside: with the outer arc upward, the revolve
    // orientation is outward on both.
    for v in &mut m.vertices {
        v[2] -= z_rim;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_closed_outward_with_expected_volume() {
        let cases: Vec<(SurfaceMesh, f64, f64)> = vec![
            (bar([0.3, 0.02, 0.01]), 0.3 * 0.02 * 0.01, 1e-12),
            (cylinder(0.1, 0.2, 96), PI * 0.01 * 0.2, 2e-3),
            (sphere(0.1, 96), 4.0 / 3.0 * PI * 1e-3, 3e-3),
            // Hemispherical shell: 2/3 π (R³ − r³).
            (
                bowl(0.1, 0.01, 0.1, 128),
                2.0 / 3.0 * PI * (1e-3 - 0.09f64.powi(3)),
                3e-3,
            ),
        ];
        for (m, vol, rel) in cases {
            let (r, rep) = m.repaired(0).unwrap();
            assert!(rep.is_clean(), "{rep:?}");
            let v = r.signed_volume();
            assert!((v - vol).abs() <= rel * vol, "volume {v} vs {vol}");
        }
    }
}
