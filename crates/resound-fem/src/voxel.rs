//! Voxelization of a closed, outward-oriented surface by winding number.
//!
//! The grid is fitted to the bounding box: along each axis `n = max(1, round(L / h))` voxels
//! of spacing `L / n`, so an axis-aligned box is tiled exactly. A voxel is inside when the
//! winding number of its centre is non-zero. For a closed surface the winding number equals the
//! signed count of crossings of a ray towards +x (exits count +1, entries −1), which is what we
//! evaluate: one ray per (y, z) grid line, every triangle touching only the lines under its
//! shadow, so the cost is O(triangles + voxels) rather than O(triangles × voxels).

use crate::surface::SurfaceMesh;

/// A regular voxel grid with an inside flag per voxel (x fastest, then y, then z).
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelGrid {
    /// Corner of voxel (0, 0, 0) (m).
    pub origin: [f64; 3],
    /// Voxel edge lengths (m).
    pub spacing: [f64; 3],
    /// Voxels along x, y, z.
    pub dims: [usize; 3],
    /// Inside flags, index `i + nx·(j + ny·k)`.
    pub inside: Vec<bool>,
}

impl VoxelGrid {
    /// Linear index of voxel (i, j, k).
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Number of inside voxels.
    pub fn count(&self) -> usize {
        self.inside.iter().filter(|&&b| b).count()
    }

    /// Keeps only the largest face-connected set of inside voxels; returns how many voxels
    /// were dropped (islands a thin gap separated from the main body).
    pub fn keep_largest_component(&mut self) -> usize {
        let [nx, ny, nz] = self.dims;
        let mut label = vec![u32::MAX; self.inside.len()];
        let mut sizes = Vec::new();
        for start in 0..self.inside.len() {
            if !self.inside[start] || label[start] != u32::MAX {
                continue;
            }
            let id = sizes.len() as u32;
            let mut size = 0usize;
            let mut stack = vec![start];
            label[start] = id;
            while let Some(v) = stack.pop() {
                size += 1;
                let (i, j, k) = (v % nx, (v / nx) % ny, v / (nx * ny));
                let mut visit = |ok: bool, w: usize| {
                    if ok && self.inside[w] && label[w] == u32::MAX {
                        label[w] = id;
                        stack.push(w);
                    }
                };
                visit(i > 0, v.wrapping_sub(1));
                visit(i + 1 < nx, v + 1);
                visit(j > 0, v.wrapping_sub(nx));
                visit(j + 1 < ny, v + nx);
                visit(k > 0, v.wrapping_sub(nx * ny));
                visit(k + 1 < nz, v + nx * ny);
            }
            sizes.push(size);
        }
        let Some((best, _)) = sizes.iter().enumerate().max_by_key(|(_, &s)| s) else {
            return 0;
        };
        let mut dropped = 0;
        for (v, l) in label.iter().enumerate() {
            if self.inside[v] && *l != best as u32 {
                self.inside[v] = false;
                dropped += 1;
            }
        }
        dropped
    }
}

/// Largest ratio of voxel edge lengths.
pub const MAX_ASPECT: f64 = 4.0;

/// Grid spacing and dims fitted to the mesh bounding box with `resolution` voxels along its
/// longest side.
pub fn fitted_grid(mesh: &SurfaceMesh, resolution: usize) -> ([f64; 3], [f64; 3], [usize; 3]) {
    let (lo, hi) = mesh.bbox();
    let len = [0, 1, 2].map(|c| hi[c] - lo[c]);
    let lmax = len.iter().cloned().fold(0.0, f64::max);
    let h = lmax / resolution.max(1) as f64;
    let mut dims = len.map(|l| ((l / h).round() as usize).max(1));
    // A thin axis rounds to one voxel of its full length; keep voxels no more than
    // MAX_ASPECT times longer than that, or elements of aspect 100+ ruin the conditioning.
    let hmin = (0..3)
        .map(|c| len[c] / dims[c] as f64)
        .fold(f64::INFINITY, f64::min);
    if hmin > 0.0 {
        for c in 0..3 {
            let need = (len[c] / (MAX_ASPECT * hmin)).ceil().min(1e6) as usize;
            dims[c] = dims[c].max(need).max(1);
        }
    }
    let spacing = [0, 1, 2].map(|c| len[c] / dims[c] as f64);
    (lo, spacing, dims)
}

/// Voxels along the longest side that give about `target_voxels` inside voxels for a mesh of
/// enclosed volume `volume` (m³).
pub fn resolution_for_voxels(mesh: &SurfaceMesh, volume: f64, target_voxels: usize) -> usize {
    let (lo, hi) = mesh.bbox();
    let lmax = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
    let h = (volume.max(1e-30) / target_voxels.max(1) as f64).cbrt();
    ((lmax / h).ceil() as usize).clamp(2, 2000)
}

/// Voxelizes a closed, outward-oriented mesh (see [`SurfaceMesh::repaired`]).
pub fn voxelize(mesh: &SurfaceMesh, resolution: usize) -> VoxelGrid {
    let (origin, spacing, dims) = fitted_grid(mesh, resolution);
    let [nx, ny, nz] = dims;
    // Lines are shifted off the grid by tiny irrational fractions of a voxel so that a ray
    // never passes exactly through a mesh edge or vertex of an axis-aligned model.
    let jy = 0.5 + 1.234_567e-7 * std::f64::consts::SQRT_2;
    let jz = 0.5 + 1.234_567e-7 * std::f64::consts::PI;
    let mut crossings: Vec<Vec<(f64, i8)>> = vec![Vec::new(); ny * nz];
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.vertices[i as usize]);
        let ymin = p.iter().map(|v| v[1]).fold(f64::INFINITY, f64::min);
        let ymax = p.iter().map(|v| v[1]).fold(f64::NEG_INFINITY, f64::max);
        let zmin = p.iter().map(|v| v[2]).fold(f64::INFINITY, f64::min);
        let zmax = p.iter().map(|v| v[2]).fold(f64::NEG_INFINITY, f64::max);
        let j0 = (((ymin - origin[1]) / spacing[1] - jy).ceil().max(0.0)) as usize;
        let j1 = ((ymax - origin[1]) / spacing[1] - jy).floor();
        let k0 = (((zmin - origin[2]) / spacing[2] - jz).ceil().max(0.0)) as usize;
        let k1 = ((zmax - origin[2]) / spacing[2] - jz).floor();
        if j1 < 0.0 || k1 < 0.0 {
            continue;
        }
        let j1 = (j1 as usize).min(ny - 1);
        let k1 = (k1 as usize).min(nz - 1);
        // Signed area of the yz projection: its sign is the sign of the normal's x component.
        let area =
            (p[1][1] - p[0][1]) * (p[2][2] - p[0][2]) - (p[2][1] - p[0][1]) * (p[1][2] - p[0][2]);
        if area == 0.0 {
            continue;
        }
        let sign: i8 = if area > 0.0 { 1 } else { -1 };
        for k in k0..=k1 {
            let z = origin[2] + (k as f64 + jz) * spacing[2];
            for j in j0..=j1 {
                let y = origin[1] + (j as f64 + jy) * spacing[1];
                // Barycentric coordinates of (y, z) in the projected triangle.
                let w0 = (p[1][1] - y) * (p[2][2] - z) - (p[2][1] - y) * (p[1][2] - z);
                let w1 = (p[2][1] - y) * (p[0][2] - z) - (p[0][1] - y) * (p[2][2] - z);
                let w2 = (p[0][1] - y) * (p[1][2] - z) - (p[1][1] - y) * (p[0][2] - z);
                let inside = if area > 0.0 {
                    w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0
                } else {
                    w0 <= 0.0 && w1 <= 0.0 && w2 <= 0.0
                };
                if inside {
                    let x = (w0 * p[0][0] + w1 * p[1][0] + w2 * p[2][0]) / area;
                    crossings[j + ny * k].push((x, sign));
                }
            }
        }
    }
    let mut inside = vec![false; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            let line = &mut crossings[j + ny * k];
            line.sort_by(|a, b| a.0.total_cmp(&b.0));
            // Winding at x = Σ signs of crossings beyond x = total − Σ signs before x.
            let total: i32 = line.iter().map(|c| c.1 as i32).sum();
            let mut before = 0i32;
            let mut c = 0;
            for i in 0..nx {
                let x = origin[0] + (i as f64 + 0.5) * spacing[0];
                while c < line.len() && line[c].0 < x {
                    before += line[c].1 as i32;
                    c += 1;
                }
                inside[i + nx * (j + ny * k)] = total - before != 0;
            }
        }
    }
    VoxelGrid {
        origin,
        spacing,
        dims,
        inside,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitive;

    #[test]
    fn thin_plates_get_bounded_aspect_ratio() {
        let m = primitive::plate(1.0, 1.0, 0.001);
        let (_, h, dims) = fitted_grid(&m, 3);
        assert_eq!(dims[2], 1);
        assert!(
            h[0] / h[2] <= MAX_ASPECT + 1e-9 && h[1] / h[2] <= MAX_ASPECT + 1e-9,
            "{h:?}"
        );
    }

    #[test]
    fn box_is_tiled_exactly() {
        let m = primitive::bar([0.3, 0.02, 0.01]);
        let g = voxelize(&m, 30);
        assert_eq!(g.dims, [30, 2, 1]);
        assert_eq!(g.count(), 60);
    }

    #[test]
    fn sphere_volume_converges() {
        let r = 0.05;
        let m = primitive::sphere(r, 128);
        let exact = m.signed_volume();
        let mut last = f64::INFINITY;
        for res in [10, 20, 40] {
            let g = voxelize(&m, res);
            let dv = g.spacing[0] * g.spacing[1] * g.spacing[2];
            let err = ((g.count() as f64 * dv) - exact).abs() / exact;
            assert!(err < last || err < 0.01, "res {res}: err {err}");
            last = err;
        }
        assert!(last < 0.03, "{last}");
    }

    #[test]
    fn islands_are_dropped() {
        let mut a = primitive::bar([1.0, 1.0, 1.0]);
        let b = primitive::bar([0.2, 0.2, 0.2]);
        let off = a.vertices.len() as u32;
        a.vertices
            .extend(b.vertices.iter().map(|v| [v[0] + 2.0, v[1], v[2]]));
        a.triangles
            .extend(b.triangles.iter().map(|t| t.map(|i| i + off)));
        let mut g = voxelize(&a, 25);
        let before = g.count();
        let dropped = g.keep_largest_component();
        assert!(dropped > 0 && g.count() == before - dropped);
    }
}

/// Nested-dissection order of grid nodes given by integer grid coordinates: recursively split
/// the node set by the grid plane at the median of its longest extent; that plane's nodes
/// separate the two halves exactly (an 8-node hexahedron spans one cell), so they are numbered
/// last. Returns node indices in elimination order. On 3-D grids this gives less Cholesky fill
/// than minimum-degree orderings (George 1973).
pub fn nested_dissection(coords: &[[u32; 3]]) -> Vec<usize> {
    fn rec(coords: &[[u32; 3]], ids: &mut [usize], out: &mut Vec<usize>) {
        if ids.len() <= 64 {
            out.extend_from_slice(ids);
            return;
        }
        let mut lo = [u32::MAX; 3];
        let mut hi = [0u32; 3];
        for &i in ids.iter() {
            for d in 0..3 {
                lo[d] = lo[d].min(coords[i][d]);
                hi[d] = hi[d].max(coords[i][d]);
            }
        }
        let axis = (0..3).max_by_key(|&d| hi[d] - lo[d]).unwrap_or(0);
        if hi[axis] - lo[axis] < 2 {
            out.extend_from_slice(ids);
            return;
        }
        ids.sort_unstable_by_key(|&i| coords[i][axis]);
        let mid = coords[ids[ids.len() / 2]][axis].clamp(lo[axis] + 1, hi[axis] - 1);
        let a = ids.partition_point(|&i| coords[i][axis] < mid);
        let b = ids.partition_point(|&i| coords[i][axis] <= mid);
        let (left, rest) = ids.split_at_mut(a);
        let (sep, right) = rest.split_at_mut(b - a);
        rec(coords, left, out);
        rec(coords, right, out);
        out.extend_from_slice(sep);
    }
    let mut ids: Vec<usize> = (0..coords.len()).collect();
    let mut out = Vec::with_capacity(coords.len());
    rec(coords, &mut ids, &mut out);
    out
}

#[cfg(test)]
mod nd_tests {
    use super::nested_dissection;

    #[test]
    fn nested_dissection_is_a_permutation_with_separator_last() {
        let coords: Vec<[u32; 3]> = (0..10u32)
            .flat_map(|k| (0..10u32).flat_map(move |j| (0..20u32).map(move |i| [i, j, k])))
            .collect();
        let p = nested_dissection(&coords);
        let mut s = p.clone();
        s.sort_unstable();
        assert_eq!(s, (0..coords.len()).collect::<Vec<_>>());
        // The top-level separator (a full x-plane of 100 nodes) comes last.
        let last: Vec<u32> = p[p.len() - 100..].iter().map(|&i| coords[i][0]).collect();
        assert!(last.iter().all(|&x| x == last[0]));
    }
}
