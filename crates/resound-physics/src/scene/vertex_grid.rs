//! The nearest surface vertex to a contact point, in about constant time.

/// Surface vertices of a body binned in a uniform grid (CSR), for the nearest vertex to a
/// contact point in about constant time: refined surfaces have thousands of vertices, and a
/// linear scan per contact and step dominated busy scenes.
pub(super) struct VertexGrid {
    pub(super) lo: [f64; 3],
    pub(super) cell: f64,
    pub(super) dims: [usize; 3],
    pub(super) start: Vec<u32>,
    pub(super) items: Vec<u32>,
}

impl VertexGrid {
    pub(super) fn new(vertices: &[[f64; 3]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in vertices {
            for c in 0..3 {
                lo[c] = lo[c].min(v[c]);
                hi[c] = hi[c].max(v[c]);
            }
        }
        let diag = (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt();
        // A surface of n vertices: about √n cells along its diagonal hold a few vertices each.
        let cell = (diag / (vertices.len().max(1) as f64).sqrt()).max(1e-9);
        let dims = [0, 1, 2].map(|c| (((hi[c] - lo[c]) / cell).floor() as usize + 1).min(1024));
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut grid = Self {
            lo,
            cell,
            dims,
            start: vec![0; n_cells + 1],
            items: vec![0; vertices.len()],
        };
        let cells: Vec<usize> = vertices
            .iter()
            .map(|&v| grid.index(grid.cell_of(v)))
            .collect();
        for &k in &cells {
            grid.start[k + 1] += 1;
        }
        for k in 0..n_cells {
            grid.start[k + 1] += grid.start[k];
        }
        let mut fill = grid.start.clone();
        for (i, &k) in cells.iter().enumerate() {
            grid.items[fill[k] as usize] = i as u32;
            fill[k] += 1;
        }
        grid
    }

    pub(super) fn cell_of(&self, p: [f64; 3]) -> [usize; 3] {
        [0, 1, 2].map(|c| {
            (((p[c] - self.lo[c]) / self.cell).floor().max(0.0) as usize).min(self.dims[c] - 1)
        })
    }

    pub(super) fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// The vertex nearest `p` (the lowest index among equals, as a linear scan would give).
    pub(super) fn nearest(&self, vertices: &[[f64; 3]], p: [f64; 3]) -> usize {
        let c = self.cell_of(p);
        let mut best = (f64::INFINITY, 0usize);
        let visit = |best: &mut (f64, usize), x: usize, y: usize, z: usize| {
            let k = self.index([x, y, z]);
            for &i in &self.items[self.start[k] as usize..self.start[k + 1] as usize] {
                let v = vertices[i as usize];
                let dd = (v[0] - p[0]).powi(2) + (v[1] - p[1]).powi(2) + (v[2] - p[2]).powi(2);
                if dd < best.0 || (dd == best.0 && (i as usize) < best.1) {
                    *best = (dd, i as usize);
                }
            }
        };
        let max_r = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_r {
            let lo = [0, 1, 2].map(|k| c[k].saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    // The shell's cells only: a whole row on its faces, else the row's ends.
                    if r == 0 || z.abs_diff(c[2]) == r || y.abs_diff(c[1]) == r {
                        for x in lo[0]..=hi[0] {
                            visit(&mut best, x, y, z);
                        }
                    } else {
                        if c[0] >= r {
                            visit(&mut best, c[0] - r, y, z);
                        }
                        if c[0] + r < self.dims[0] {
                            visit(&mut best, c[0] + r, y, z);
                        }
                    }
                }
            }
            // Anything in the next shell is at least r cells away.
            if best.0.is_finite() && (r as f64 * self.cell).powi(2) > best.0 {
                break;
            }
        }
        best.1
    }
}

#[cfg(test)]
mod tests {
    use super::VertexGrid;

    #[test]
    fn the_grid_finds_the_same_vertex_as_a_scan() {
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let v: Vec<[f64; 3]> = (0..3000)
            .map(|_| [next() * 0.3, next() * 0.02, next() * 0.01])
            .collect();
        let g = VertexGrid::new(&v);
        for _ in 0..2000 {
            // Points inside, near and far outside the cloud.
            let p = [
                next() * 0.6 - 0.15,
                next() * 0.1 - 0.04,
                next() * 0.1 - 0.05,
            ];
            let scan = (0..v.len())
                .min_by(|&a, &b| {
                    let d = |i: usize| (0..3).map(|c| (v[i][c] - p[c]).powi(2)).sum::<f64>();
                    d(a).total_cmp(&d(b)).then(a.cmp(&b))
                })
                .unwrap();
            assert_eq!(g.nearest(&v, p), scan, "{p:?}");
        }
    }
}
