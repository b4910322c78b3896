//! Triangle surface meshes: validation and safe repair.

use resound_core::geometry::{cross, dot, norm, sub};
use std::collections::HashMap;

/// A triangle mesh. Vertices in m; triangles index `vertices`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceMesh {
    /// Vertex positions (m).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles (counter-clockwise seen from outside once repaired).
    pub triangles: Vec<[u32; 3]>,
}

/// Mesh problems that cannot be repaired safely.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// No triangles at all.
    #[error("mesh is empty ({vertices} vertices, {triangles} triangles)")]
    Empty {
        /// Vertex count.
        vertices: usize,
        /// Triangle count.
        triangles: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {index} has a non-finite coordinate {value:?}")]
    NonFiniteVertex {
        /// Vertex index.
        index: usize,
        /// Its coordinates.
        value: [f64; 3],
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "triangle {triangle} refers to vertex {vertex}, but the mesh has {n_vertices} vertices"
    )]
    BadIndex {
        /// Triangle index.
        triangle: usize,
        /// Offending vertex index.
        vertex: u32,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// The surface has holes.
    #[error("mesh has {loops} boundary loop(s) ({edges} boundary edges); not closed. Close the holes (or let larger holes be filled (max_hole_edges); the largest has {largest} edges)")]
    NotClosed {
        /// Number of boundary loops.
        loops: usize,
        /// Number of boundary edges.
        edges: usize,
        /// Edges of the largest loop.
        largest: usize,
    },
    /// Edges shared by more than two triangles.
    #[error("mesh is non-manifold: {count} edge(s) are shared by more than two triangles (e.g. between input vertices {example:?}, at {at:?})")]
    NonManifold {
        /// Number of such edges.
        count: usize,
        /// One example edge: its vertices' indices in the input (0-based, as in the file's
        /// order; after welding, the first of the coincident ones).
        example: [u32; 2],
        /// Where its two ends are.
        at: [[f64; 3]; 2],
    },
    /// Filling holes made edges shared by more than two triangles: holes that touch at a
    /// vertex form one boundary loop through it twice, which a fan cannot close.
    #[error("filling the holes made {count} edge(s) shared by more than two triangles, at input vertex {vertex} ({at:?}): holes that touch at a vertex cannot be closed by a fan; close them in a mesh editor")]
    HolesTouch {
        /// Number of such edges.
        count: usize,
        /// The input vertex the holes share (0-based, in the file's order).
        vertex: u32,
        /// Where it is.
        at: [f64; 3],
    },
    /// Orientation cannot be made consistent (e.g. a Möbius strip).
    #[error("mesh is not orientable: triangles cannot be given a consistent orientation")]
    NotOrientable,
    /// The enclosed volume is (numerically) zero.
    #[error("mesh encloses no volume ({volume:.3e} m^3 for a bounding box of {bbox:.3e} m^3): flat or degenerate")]
    ZeroVolume {
        /// Signed volume (m³).
        volume: f64,
        /// Bounding-box volume (m³).
        bbox: f64,
    },
}

/// What [`SurfaceMesh::repaired`] changed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RepairReport {
    /// Vertices merged into an identical earlier one.
    pub welded_vertices: usize,
    /// Zero-area or repeated-vertex triangles removed.
    pub degenerate_triangles: usize,
    /// Duplicate triangles removed.
    pub duplicate_triangles: usize,
    /// Triangles flipped to make orientation consistent and outward.
    pub flipped_triangles: usize,
    /// Holes (boundary loops) closed by a fan around their centroid.
    pub filled_holes: usize,
}

impl RepairReport {
    /// True when nothing was changed.
    pub fn is_clean(&self) -> bool {
        *self == RepairReport::default()
    }

    /// One line per repair, for users.
    pub fn lines(&self) -> Vec<String> {
        let mut v = Vec::new();
        let mut push = |n: usize, what: &str| {
            if n > 0 {
                v.push(format!("{n} {what}"));
            }
        };
        push(self.welded_vertices, "duplicate vertices welded");
        push(self.degenerate_triangles, "degenerate triangles removed");
        push(self.duplicate_triangles, "duplicate triangles removed");
        push(
            self.flipped_triangles,
            "triangles flipped for consistent outward orientation",
        );
        push(self.filled_holes, "small holes filled");
        v
    }
}

impl SurfaceMesh {
    /// Axis-aligned bounding box (min, max) in m. Zeros for an empty mesh.
    pub fn bbox(&self) -> ([f64; 3], [f64; 3]) {
        resound_core::geometry::bbox(&self.vertices)
    }

    /// Length of the bounding-box diagonal (m).
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bbox();
        norm(sub(hi, lo))
    }

    /// Whether `p` lies inside this closed surface: the parity of a ray's crossings (a
    /// direction off every axis, so it meets edges and vertices only by accident of measure
    /// zero). For meshes that are not closed the answer means little.
    pub fn contains_point(&self, p: [f64; 3]) -> bool {
        let dir = [0.577_215_664_9, 0.618_033_988_7, 0.529_177_210_9];
        let mut crossings = 0usize;
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            // Möller–Trumbore.
            let (e1, e2) = (sub(b, a), sub(c, a));
            let h = cross(dir, e2);
            let det = dot(e1, h);
            if det.abs() < 1e-300 {
                continue;
            }
            let s = sub(p, a);
            let u = dot(s, h) / det;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let q = cross(s, e1);
            let v = dot(dir, q) / det;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            if dot(e2, q) / det > 0.0 {
                crossings += 1;
            }
        }
        crossings % 2 == 1
    }

    /// Signed enclosed volume (m³) by the divergence theorem; positive for outward orientation.
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Multiplies all coordinates by `s` (e.g. 0.001 for a file in mm).
    pub fn scale(&mut self, s: f64) {
        for v in &mut self.vertices {
            for x in v.iter_mut() {
                *x *= s;
            }
        }
    }

    /// Checks indices and coordinates.
    ///
    /// # Errors
    /// [`MeshError::Empty`], [`MeshError::NonFiniteVertex`], [`MeshError::BadIndex`].
    pub fn check_basic(&self) -> Result<(), MeshError> {
        if self.triangles.is_empty() || self.vertices.len() < 3 {
            return Err(MeshError::Empty {
                vertices: self.vertices.len(),
                triangles: self.triangles.len(),
            });
        }
        if let Some((index, v)) = self
            .vertices
            .iter()
            .enumerate()
            .find(|(_, v)| v.iter().any(|x| !x.is_finite()))
        {
            return Err(MeshError::NonFiniteVertex { index, value: *v });
        }
        let n = self.vertices.len();
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&v) = tri.iter().find(|&&v| v as usize >= n) {
                return Err(MeshError::BadIndex {
                    triangle: t,
                    vertex: v,
                    n_vertices: n,
                });
            }
        }
        Ok(())
    }

    /// A closed, manifold, consistently outward-oriented copy of the mesh, and what was repaired.
    ///
    /// Safe repairs: welding coincident vertices (within 1e-9 of the bounding-box diagonal —
    /// STL files repeat every vertex), dropping degenerate and duplicate triangles, flipping
    /// triangles to a consistent outward orientation, and filling holes whose boundary loop has
    /// at most `max_hole_edges` edges by a fan around the loop centroid (0 disables filling).
    ///
    /// # Errors
    /// [`MeshError`] naming the first problem that cannot be repaired safely: holes larger than
    /// allowed, non-manifold edges, a non-orientable surface, zero enclosed volume.
    pub fn repaired(
        &self,
        max_hole_edges: usize,
    ) -> Result<(SurfaceMesh, RepairReport), MeshError> {
        self.check_basic()?;
        let mut report = RepairReport::default();
        let diag = self.diagonal();
        // 1. Weld coincident vertices.
        let tol = (diag * 1e-9).max(f64::MIN_POSITIVE);
        let mut map = Vec::with_capacity(self.vertices.len());
        let mut cells: HashMap<[i64; 3], u32> = HashMap::new();
        let mut verts: Vec<[f64; 3]> = Vec::new();
        for v in &self.vertices {
            let key = v.map(|x| (x / tol).round() as i64);
            let id = *cells.entry(key).or_insert_with(|| {
                verts.push(*v);
                (verts.len() - 1) as u32
            });
            map.push(id);
        }
        report.welded_vertices = self.vertices.len() - verts.len();
        // 2. Degenerate and duplicate triangles.
        let area_tol = diag * diag * 1e-14;
        let mut seen = HashMap::new();
        let mut tris = Vec::with_capacity(self.triangles.len());
        for t in &self.triangles {
            let t = t.map(|i| map[i as usize]);
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                report.degenerate_triangles += 1;
                continue;
            }
            let [a, b, c] = t.map(|i| verts[i as usize]);
            if norm(cross(sub(b, a), sub(c, a))) <= area_tol {
                report.degenerate_triangles += 1;
                continue;
            }
            let mut key = t;
            key.sort_unstable();
            if seen.insert(key, ()).is_some() {
                report.duplicate_triangles += 1;
                continue;
            }
            tris.push(t);
        }
        let mut mesh = SurfaceMesh {
            vertices: verts,
            triangles: tris,
        };
        if mesh.triangles.is_empty() {
            return Err(MeshError::Empty {
                vertices: mesh.vertices.len(),
                triangles: 0,
            });
        }
        // 3. Manifoldness and holes. Errors name input vertices: the first input vertex of
        // each welded one; vertices the hole filling adds have none.
        let mut input_of = vec![u32::MAX; mesh.vertices.len()];
        for (i, &w) in map.iter().enumerate().rev() {
            input_of[w as usize] = i as u32;
        }
        mesh.check_manifold(&input_of)?;
        let loops = mesh.boundary_loops();
        if !loops.is_empty() {
            let largest = loops.iter().map(Vec::len).max().unwrap_or(0);
            if largest > max_hole_edges {
                return Err(MeshError::NotClosed {
                    loops: loops.len(),
                    edges: loops.iter().map(Vec::len).sum(),
                    largest,
                });
            }
            for lp in &loops {
                mesh.fill_hole(lp);
            }
            report.filled_holes = loops.len();
            mesh.check_manifold(&input_of)?;
            if !mesh.boundary_loops().is_empty() {
                return Err(MeshError::NotClosed {
                    loops: loops.len(),
                    edges: loops.iter().map(Vec::len).sum(),
                    largest,
                });
            }
        }
        // 4. Orientation.
        report.flipped_triangles = mesh.orient_outward()?;
        let vol = mesh.signed_volume();
        let (lo, hi) = mesh.bbox();
        let bbox = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        if !(vol > 1e-9 * bbox) || bbox <= 0.0 {
            return Err(MeshError::ZeroVolume { volume: vol, bbox });
        }
        Ok((mesh, report))
    }

    /// Undirected edge → number of incident triangles.
    fn edge_counts(&self) -> HashMap<[u32; 2], u32> {
        let mut m = HashMap::with_capacity(self.triangles.len() * 3 / 2);
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *m.entry([a.min(b), a.max(b)]).or_insert(0) += 1;
            }
        }
        m
    }

    /// Edges shared by more than two triangles are an error naming input vertices
    /// (`input_of`: this mesh's vertex → the input's; vertices beyond it were added by the
    /// repair).
    fn check_manifold(&self, input_of: &[u32]) -> Result<(), MeshError> {
        let counts = self.edge_counts();
        let bad: Vec<_> = counts.iter().filter(|(_, &c)| c > 2).collect();
        let input = |v: u32| input_of.get(v as usize).copied();
        // An edge of input vertices first; else one the repair made.
        let pick = bad
            .iter()
            .map(|(e, _)| **e)
            .min_by_key(|e| (e.iter().any(|&v| input(v).is_none()), *e));
        let Some(e) = pick else { return Ok(()) };
        let at = e.map(|v| self.vertices[v as usize]);
        match e.map(input) {
            [Some(a), Some(b)] => Err(MeshError::NonManifold {
                count: bad.len(),
                example: [a, b],
                at,
            }),
            [Some(v), None] | [None, Some(v)] => Err(MeshError::HolesTouch {
                count: bad.len(),
                vertex: v,
                at: self.vertices[e[usize::from(input(e[0]).is_none())] as usize],
            }),
            [None, None] => Err(MeshError::HolesTouch {
                count: bad.len(),
                vertex: u32::MAX,
                at: at[0],
            }),
        }
    }

    /// Splits the longest edge of every triangle while it is longer than `max_edge_m`, at its
    /// midpoint (shared by both triangles), until no edge is, keeping the mesh conforming and oriented: a triangle with one, two or
    /// three long edges becomes two, three or four. Mode shapes are reported at the vertices
    /// and interpolated linearly between them, so a primitive's 8 corner vertices would make
    /// a bar's centre sound like its ends; refined to the voxel scale, the surface samples the
    /// FE solution wherever it is struck.
    pub fn refined(&self, max_edge_m: f64) -> SurfaceMesh {
        let mut m = self.clone();
        if !(max_edge_m > 0.0 && max_edge_m.is_finite()) {
            return m;
        }
        let len2 = |v: &[[f64; 3]], a: u32, b: u32| {
            let (p, q) = (v[a as usize], v[b as usize]);
            (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>()
        };
        let limit2 = max_edge_m * max_edge_m;
        // Each pass at least halves every long edge; 60 passes cover any finite ratio.
        for _ in 0..60 {
            let mut mid: std::collections::HashMap<(u32, u32), u32> =
                std::collections::HashMap::new();
            for t in &m.triangles {
                // Only each triangle's longest edge (Rivara's longest-edge bisection: no
                // slivers from splitting a long thin triangle across); a neighbour that shares
                // it is split too, which keeps the mesh conforming.
                let k = (0..3)
                    .max_by(|&i, &j| {
                        len2(&m.vertices, t[i], t[(i + 1) % 3]).total_cmp(&len2(
                            &m.vertices,
                            t[j],
                            t[(j + 1) % 3],
                        ))
                    })
                    .unwrap_or(0);
                {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if len2(&m.vertices, a, b) > limit2 {
                        let key = (a.min(b), a.max(b));
                        if let std::collections::hash_map::Entry::Vacant(e) = mid.entry(key) {
                            let (p, q) = (m.vertices[a as usize], m.vertices[b as usize]);
                            m.vertices.push([
                                0.5 * (p[0] + q[0]),
                                0.5 * (p[1] + q[1]),
                                0.5 * (p[2] + q[2]),
                            ]);
                            e.insert((m.vertices.len() - 1) as u32);
                        }
                    }
                }
            }
            if mid.is_empty() {
                break;
            }
            let mut tris = Vec::with_capacity(m.triangles.len() * 2);
            for &t in &m.triangles {
                let mark = |a: u32, b: u32| mid.get(&(a.min(b), a.max(b))).copied();
                // Rotate so that the marked edges come first: (v0 v1), then (v1 v2).
                let mut v = t;
                let mut marks = [mark(v[0], v[1]), mark(v[1], v[2]), mark(v[2], v[0])];
                let count = marks.iter().filter(|x| x.is_some()).count();
                for _ in 0..3 {
                    let ok = match count {
                        1 => marks[0].is_some(),
                        2 => marks[2].is_none(),
                        _ => true,
                    };
                    if ok {
                        break;
                    }
                    v = [v[1], v[2], v[0]];
                    marks = [marks[1], marks[2], marks[0]];
                }
                match (count, marks) {
                    (0, _) => tris.push(v),
                    (1, [Some(m01), _, _]) => {
                        tris.push([v[0], m01, v[2]]);
                        tris.push([m01, v[1], v[2]]);
                    }
                    (2, [Some(m01), Some(m12), None]) => {
                        tris.push([m01, v[1], m12]);
                        tris.push([v[0], m01, m12]);
                        tris.push([v[0], m12, v[2]]);
                    }
                    (_, [Some(m01), Some(m12), Some(m20)]) => {
                        tris.push([v[0], m01, m20]);
                        tris.push([m01, v[1], m12]);
                        tris.push([m20, m12, v[2]]);
                        tris.push([m01, m12, m20]);
                    }
                    _ => tris.push(v),
                }
            }
            m.triangles = tris;
        }
        m
    }

    /// Boundary loops as vertex sequences (each edge used by exactly one triangle).
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let counts = self.edge_counts();
        // Directed boundary edges in triangle order: next[a] = b.
        let mut next: HashMap<u32, Vec<u32>> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if counts[&[a.min(b), a.max(b)]] == 1 {
                    // Walk the hole in the opposite direction so filling keeps orientation.
                    next.entry(b).or_default().push(a);
                }
            }
        }
        let mut loops = Vec::new();
        let mut starts: Vec<u32> = next.keys().copied().collect();
        starts.sort_unstable();
        for s in starts {
            while let Some(mut cur) = next.get_mut(&s).and_then(Vec::pop) {
                let mut lp = vec![s];
                while cur != s {
                    lp.push(cur);
                    match next.get_mut(&cur).and_then(Vec::pop) {
                        Some(n) => cur = n,
                        None => break,
                    }
                }
                loops.extend(split_at_repeats(&lp));
            }
        }
        loops
    }

    fn fill_hole(&mut self, lp: &[u32]) {
        let n = lp.len();
        if n < 3 {
            return;
        }
        if n == 3 {
            self.triangles.push([lp[0], lp[1], lp[2]]);
            return;
        }
        let mut c = [0.0; 3];
        for &v in lp {
            for k in 0..3 {
                c[k] += self.vertices[v as usize][k] / n as f64;
            }
        }
        self.vertices.push(c);
        let ci = (self.vertices.len() - 1) as u32;
        for k in 0..n {
            self.triangles.push([lp[k], lp[(k + 1) % n], ci]);
        }
    }

    /// Makes orientation consistent within each connected component (flood fill across
    /// edges) and outward (positive signed volume per component). Returns the flip count.
    fn orient_outward(&mut self) -> Result<usize, MeshError> {
        let nt = self.triangles.len();
        let mut edge_tris: HashMap<[u32; 2], Vec<usize>> = HashMap::new();
        for (i, t) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edge_tris.entry([a.min(b), a.max(b)]).or_default().push(i);
            }
        }
        let mut state = vec![0u8; nt]; // 0 unvisited, 1 kept, 2 flipped
        let mut flipped = 0;
        for seed in 0..nt {
            if state[seed] != 0 {
                continue;
            }
            state[seed] = 1;
            let mut comp = vec![seed];
            let mut stack = vec![seed];
            while let Some(i) = stack.pop() {
                let t = self.oriented(i, state[i]);
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    for &j in &edge_tris[&[a.min(b), a.max(b)]] {
                        if j == i {
                            continue;
                        }
                        // Neighbour must traverse the shared edge as b→a.
                        let u = self.triangles[j];
                        let same_dir = (0..3).any(|m| u[m] == a && u[(m + 1) % 3] == b);
                        let want = if same_dir { 2 } else { 1 };
                        if state[j] == 0 {
                            state[j] = want;
                            comp.push(j);
                            stack.push(j);
                        } else if state[j] != want {
                            return Err(MeshError::NotOrientable);
                        }
                    }
                }
            }
            let vol: f64 = comp
                .iter()
                .map(|&i| {
                    let [a, b, c] = self
                        .oriented(i, state[i])
                        .map(|v| self.vertices[v as usize]);
                    dot(a, cross(b, c))
                })
                .sum();
            if vol < 0.0 {
                for &i in &comp {
                    state[i] = 3 - state[i];
                }
            }
        }
        for (i, s) in state.iter().enumerate() {
            if *s == 2 {
                let t = &mut self.triangles[i];
                t.swap(1, 2);
                flipped += 1;
            }
        }
        Ok(flipped)
    }

    fn oriented(&self, i: usize, state: u8) -> [u32; 3] {
        let t = self.triangles[i];
        if state == 2 {
            [t[0], t[2], t[1]]
        } else {
            t
        }
    }
}

/// A boundary walk through a vertex twice (holes that touch at a vertex) as its simple loops:
/// a fan around one centroid would give the shared vertex's edge to four triangles.
fn split_at_repeats(lp: &[u32]) -> Vec<Vec<u32>> {
    let mut out = Vec::new();
    let mut stack: Vec<u32> = Vec::with_capacity(lp.len());
    for &v in lp {
        if let Some(k) = stack.iter().position(|&u| u == v) {
            // stack[k..] is a closed loop from v back to v.
            out.push(stack.split_off(k));
        }
        stack.push(v);
    }
    out.push(stack);
    out.retain(|l| l.len() >= 3);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitive;

    #[test]
    fn clean_box_is_unchanged_and_has_right_volume() {
        let b = primitive::bar([0.3, 0.02, 0.01]);
        let (m, r) = b.repaired(0).unwrap();
        assert!(r.is_clean(), "{r:?}");
        assert!((m.signed_volume() - 0.3 * 0.02 * 0.01).abs() < 1e-15);
    }

    #[test]
    fn flipped_and_split_box_is_repaired() {
        let b = primitive::bar([1.0, 1.0, 1.0]);
        // Unweld (as STL does), flip every triangle, and flip one back: inconsistent.
        let mut soup = SurfaceMesh::default();
        for (i, t) in b.triangles.iter().enumerate() {
            let base = soup.vertices.len() as u32;
            for &v in t {
                soup.vertices.push(b.vertices[v as usize]);
            }
            soup.triangles.push(if i == 3 {
                [base, base + 1, base + 2]
            } else {
                [base, base + 2, base + 1]
            });
        }
        let (m, r) = soup.repaired(0).unwrap();
        assert_eq!(r.welded_vertices, 36 - 8);
        assert_eq!(r.flipped_triangles, 11);
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn holes_are_reported_or_filled() {
        let mut b = primitive::bar([1.0, 1.0, 1.0]);
        b.triangles.truncate(10); // remove one face (2 triangles): one loop of 4 edges
        match b.repaired(0) {
            Err(MeshError::NotClosed { loops, edges, .. }) => {
                assert_eq!((loops, edges), (1, 4))
            }
            other => panic!("expected NotClosed, got {other:?}"),
        }
        let (m, r) = b.repaired(8).unwrap();
        assert_eq!(r.filled_holes, 1);
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_meshes_get_named_errors() {
        assert!(matches!(
            SurfaceMesh::default().repaired(0),
            Err(MeshError::Empty { .. })
        ));
        let mut b = primitive::bar([1.0, 1.0, 1.0]);
        b.vertices[2][1] = f64::NAN;
        assert!(matches!(
            b.repaired(0),
            Err(MeshError::NonFiniteVertex { index: 2, .. })
        ));
        // Flat: a closed box squashed to zero height.
        let mut f = primitive::bar([1.0, 1.0, 1.0]);
        for v in &mut f.vertices {
            v[2] = 0.0;
        }
        assert!(f.repaired(0).is_err());
        // Non-manifold: two boxes sharing one edge's triangles... a fin added on an edge.
        let mut n = primitive::bar([1.0, 1.0, 1.0]);
        let t0 = n.triangles[0];
        n.vertices.push([5.0, 5.0, 5.0]);
        let k = (n.vertices.len() - 1) as u32;
        n.triangles.push([t0[0], t0[1], k]);
        match n.repaired(0) {
            Err(MeshError::NonManifold { example, at, .. }) => {
                // Named in the input's numbering, with where the edge is.
                let mut e = example;
                e.sort_unstable();
                let mut want = [t0[0], t0[1]];
                want.sort_unstable();
                assert_eq!(e, want);
                assert_eq!(at[0], n.vertices[example[0] as usize]);
            }
            other => panic!("expected NonManifold, got {other:?}"),
        }
    }

    /// Issue 37: two holes touching at one vertex were blamed on "vertices [47, 2296]", the
    /// second made by the hole filler: a boundary walk through the shared vertex twice was
    /// filled as one hole. Such walks are split into their simple loops, each filled alone.
    #[test]
    fn holes_touching_at_a_vertex_are_filled_apart() {
        let whole = primitive::bar([1.0, 1.0, 1.0]).refined(0.3);
        let mut tried = 0;
        for v in 0..whole.vertices.len() as u32 {
            // The triangles around v in fan order.
            let around: Vec<[u32; 3]> = whole
                .triangles
                .iter()
                .filter(|t| t.contains(&v))
                .copied()
                .collect();
            // Inside a face (a planar fan): filling it back gives the very volume.
            let on_face = (0..3).any(|c| {
                around
                    .iter()
                    .flatten()
                    .all(|&u| whole.vertices[u as usize][c] == whole.vertices[v as usize][c])
            });
            if around.len() < 6 || !on_face {
                continue;
            }
            let other = |t: &[u32; 3], not: u32| *t.iter().find(|&&u| u != v && u != not).unwrap();
            let mut fan = vec![around[0]];
            let mut w = other(&around[0], u32::MAX);
            while fan.len() < around.len() {
                let Some(t) = around.iter().find(|t| t.contains(&w) && !fan.contains(t)) else {
                    break;
                };
                w = other(t, w);
                fan.push(*t);
            }
            if fan.len() != around.len() {
                continue;
            }
            // Two quads of the fan (triangles 0–1 and 3–4) share only v: two 4-edge holes.
            let gone = [fan[0], fan[1], fan[3], fan[4]];
            let mut m = whole.clone();
            m.triangles.retain(|t| !gone.contains(t));
            assert_eq!(m.boundary_loops().iter().map(Vec::len).sum::<usize>(), 8);
            let (fixed, r) = m.repaired(8).unwrap_or_else(|e| panic!("vertex {v}: {e}"));
            assert_eq!(r.filled_holes, 2, "vertex {v}");
            assert!(fixed.boundary_loops().is_empty());
            assert!((fixed.signed_volume() - 1.0).abs() < 1e-9, "vertex {v}");
            tried += 1;
        }
        assert!(tried > 10, "{tried} vertices tried");
    }

    /// The microphone check's point-in-surface test (issue 38): ray parity on a unit box, its
    /// refined copy and a cylinder, against the analytic solid.
    #[test]
    fn points_inside_a_closed_surface_are_told_from_points_outside() {
        let meshes = [
            (primitive::bar([1.0, 1.0, 1.0]), 0.5, false),
            (primitive::bar([1.0, 1.0, 1.0]).refined(0.2), 0.5, false),
            (primitive::cylinder(0.5, 1.0, 48), 0.5, true),
        ];
        for (m, h, round) in &meshes {
            for k in 0..400 {
                // A deterministic spread over [-0.8, 0.8]³, off the faces by at least 1 %.
                let c = |j: u32| ((f64::from(k * 7 + j * 13) * 0.618_034).fract() - 0.5) * 1.6;
                let p = [c(1), c(2), c(3)];
                let inside = if *round {
                    p[0].hypot(p[1]) < *h && p[2].abs() < *h
                } else {
                    p.iter().all(|v| v.abs() < *h)
                };
                let margin = if *round {
                    (p[0].hypot(p[1]) - h).abs().min((p[2].abs() - h).abs())
                } else {
                    p.iter()
                        .map(|v| (v.abs() - h).abs())
                        .fold(f64::MAX, f64::min)
                };
                if margin < 0.02 {
                    continue;
                }
                assert_eq!(m.contains_point(p), inside, "{p:?}");
            }
        }
    }

    #[test]
    fn a_walk_through_a_vertex_twice_splits_into_simple_loops() {
        let mut loops = split_at_repeats(&[1, 2, 3, 9, 4, 5, 6, 9, 7]);
        loops.sort();
        assert_eq!(loops, vec![vec![1, 2, 3, 9, 7], vec![9, 4, 5, 6]]);
        assert_eq!(split_at_repeats(&[1, 2, 3, 4]), vec![vec![1, 2, 3, 4]]);
    }
}
