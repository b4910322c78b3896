//! Tetrahedral mesh readers: gmsh MSH 2.2 and 4.1 (ASCII and binary), TetGen `.node`/`.ele`,
//! MEDIT `.mesh`. Quadratic tets are read by their four corners. Files with triangles but no
//! tets load as surfaces.

use crate::mesh::{read, LoadedMesh};
use crate::{parse_err, Result};
use resound_fem::{SurfaceMesh, TetMesh};
use std::collections::HashMap;
use std::path::Path;

/// A cursor over file bytes with ASCII tokens and little-endian binary values.
struct Cur<'a> {
    d: &'a [u8],
    p: usize,
}

impl<'a> Cur<'a> {
    fn skip_ws(&mut self) {
        while self.p < self.d.len() && self.d[self.p].is_ascii_whitespace() {
            self.p += 1;
        }
    }
    fn token(&mut self) -> Option<&'a str> {
        self.skip_ws();
        let s = self.p;
        while self.p < self.d.len() && !self.d[self.p].is_ascii_whitespace() {
            self.p += 1;
        }
        (self.p > s).then(|| std::str::from_utf8(&self.d[s..self.p]).unwrap_or("\u{0}"))
    }
    fn num<T: std::str::FromStr>(&mut self) -> Option<T> {
        self.token()?.parse().ok()
    }
    fn skip_line(&mut self) {
        while self.p < self.d.len() && self.d[self.p] != b'\n' {
            self.p += 1;
        }
        self.p += 1;
    }
    fn bytes<const N: usize>(&mut self) -> Option<[u8; N]> {
        let b = self.d.get(self.p..self.p + N)?;
        self.p += N;
        b.try_into().ok()
    }
    fn i32(&mut self) -> Option<i32> {
        self.bytes::<4>().map(i32::from_le_bytes)
    }
    fn u64(&mut self) -> Option<u64> {
        self.bytes::<8>().map(u64::from_le_bytes)
    }
    fn f64(&mut self) -> Option<f64> {
        self.bytes::<8>().map(f64::from_le_bytes)
    }
    /// Advances past the next line equal to `marker`.
    fn find_section(&mut self, marker: &str) -> bool {
        let m = marker.as_bytes();
        while self.p < self.d.len() {
            let line_start = self.p;
            let mut e = self.p;
            while e < self.d.len() && self.d[e] != b'\n' {
                e += 1;
            }
            let line = self.d[line_start..e].trim_ascii();
            self.p = e + 1;
            if line == m {
                return true;
            }
        }
        false
    }
}

/// Nodes per gmsh element type (types up to 19, and 15 = point).
fn gmsh_nodes(t: i32) -> Option<usize> {
    Some(match t {
        1 => 2,
        2 => 3,
        3 => 4,
        4 => 4,
        5 => 8,
        6 => 6,
        7 => 5,
        8 => 3,
        9 => 6,
        10 => 9,
        11 => 10,
        12 => 27,
        13 => 18,
        14 => 14,
        15 => 1,
        16 => 8,
        17 => 20,
        18 => 15,
        19 => 13,
        _ => return None,
    })
}

#[derive(Default)]
struct Raw {
    node_tags: HashMap<u64, u32>,
    nodes: Vec<[f64; 3]>,
    tets: Vec<[u64; 4]>,
    tris: Vec<[u64; 3]>,
}

impl Raw {
    fn add_node(&mut self, tag: u64, x: [f64; 3]) {
        self.node_tags.insert(tag, self.nodes.len() as u32);
        self.nodes.push(x);
    }
    fn add_element(&mut self, t: i32, nodes: &[u64]) {
        match t {
            4 | 11 => self.tets.push([nodes[0], nodes[1], nodes[2], nodes[3]]),
            2 | 9 => self.tris.push([nodes[0], nodes[1], nodes[2]]),
            _ => {}
        }
    }
    fn finish(self, path: &Path) -> Result<LoadedMesh> {
        let map = |tag: &u64| {
            self.node_tags
                .get(tag)
                .copied()
                .ok_or_else(|| parse_err(path, format!("element refers to undefined node {tag}")))
        };
        if !self.tets.is_empty() {
            let tets = self
                .tets
                .iter()
                .map(|t| Ok([map(&t[0])?, map(&t[1])?, map(&t[2])?, map(&t[3])?]))
                .collect::<Result<Vec<_>>>()?;
            return Ok(LoadedMesh::Tets(TetMesh {
                nodes: self.nodes,
                tets,
            }));
        }
        if !self.tris.is_empty() {
            let triangles = self
                .tris
                .iter()
                .map(|t| Ok([map(&t[0])?, map(&t[1])?, map(&t[2])?]))
                .collect::<Result<Vec<_>>>()?;
            return Ok(LoadedMesh::Surface(SurfaceMesh {
                vertices: self.nodes,
                triangles,
            }));
        }
        Err(parse_err(path, "no tetrahedra or triangles found"))
    }
}

pub(crate) fn load_msh(path: &Path) -> Result<LoadedMesh> {
    let data = read(path)?;
    let mut c = Cur { d: &data, p: 0 };
    let bad = |what: &str| parse_err(path, format!("MSH: {what}"));
    if !c.find_section("$MeshFormat") {
        return Err(bad("no $MeshFormat section (not a gmsh file?)"));
    }
    let version: f64 = c.num().ok_or_else(|| bad("bad version"))?;
    let binary: i32 = c.num().ok_or_else(|| bad("bad file type"))?;
    let dsize: usize = c.num().ok_or_else(|| bad("bad data size"))?;
    if binary == 1 {
        c.skip_line();
        let one = c.i32().ok_or_else(|| bad("truncated header"))?;
        if one != 1 {
            return Err(bad("big-endian binary files are not supported"));
        }
        if dsize != 8 {
            return Err(bad("binary files need 8-byte data size"));
        }
    }
    let mut raw = Raw::default();
    let v2 = (2.0..3.0).contains(&version);
    let v4 = (4.0..5.0).contains(&version);
    if !v2 && !v4 {
        return Err(bad(&format!(
            "version {version} not supported (2.2 and 4.1 are)"
        )));
    }
    let trunc = || parse_err(path, "MSH: truncated or malformed $Nodes/$Elements");
    if !c.find_section("$Nodes") {
        return Err(bad("no $Nodes section"));
    }
    if v2 {
        let n: usize = c.num().ok_or_else(trunc)?;
        if binary == 1 {
            c.skip_line();
            for _ in 0..n {
                let tag = c.i32().ok_or_else(trunc)? as u64;
                let x = [
                    c.f64().ok_or_else(trunc)?,
                    c.f64().ok_or_else(trunc)?,
                    c.f64().ok_or_else(trunc)?,
                ];
                raw.add_node(tag, x);
            }
        } else {
            for _ in 0..n {
                let tag: u64 = c.num().ok_or_else(trunc)?;
                let x = [
                    c.num().ok_or_else(trunc)?,
                    c.num().ok_or_else(trunc)?,
                    c.num().ok_or_else(trunc)?,
                ];
                raw.add_node(tag, x);
            }
        }
        if !c.find_section("$Elements") {
            return Err(bad("no $Elements section"));
        }
        let n: usize = c.num().ok_or_else(trunc)?;
        if binary == 1 {
            c.skip_line();
            let mut done = 0;
            while done < n {
                let t = c.i32().ok_or_else(trunc)?;
                let count = usize::try_from(c.i32().ok_or_else(trunc)?)
                    .map_err(|_| bad("negative element count"))?;
                let ntags = usize::try_from(c.i32().ok_or_else(trunc)?)
                    .ok()
                    .filter(|&t| t <= 64)
                    .ok_or_else(|| bad("element tag count outside 0..=64"))?;
                let nn = gmsh_nodes(t).ok_or_else(|| bad(&format!("unknown element type {t}")))?;
                for _ in 0..count {
                    let mut v = Vec::with_capacity(1 + ntags + nn);
                    for _ in 0..1 + ntags + nn {
                        v.push(c.i32().ok_or_else(trunc)? as u64);
                    }
                    raw.add_element(t, &v[1 + ntags..]);
                }
                done += count.max(1);
            }
        } else {
            for _ in 0..n {
                let _id: u64 = c.num().ok_or_else(trunc)?;
                let t: i32 = c.num().ok_or_else(trunc)?;
                let ntags: usize = c.num().ok_or_else(trunc)?;
                let nn = gmsh_nodes(t).ok_or_else(|| bad(&format!("unknown element type {t}")))?;
                for _ in 0..ntags {
                    c.token().ok_or_else(trunc)?;
                }
                let v: Vec<u64> = (0..nn)
                    .map(|_| c.num().ok_or_else(trunc))
                    .collect::<Result<_>>()?;
                raw.add_element(t, &v);
            }
        }
    } else if binary == 1 {
        // 4.1 binary: the data follows the `$Nodes` line directly.
        let blocks = c.u64().ok_or_else(trunc)?;
        let _total = c.u64().ok_or_else(trunc)?;
        c.u64().ok_or_else(trunc)?;
        c.u64().ok_or_else(trunc)?;
        for _ in 0..blocks {
            let _dim = c.i32().ok_or_else(trunc)?;
            let _tag = c.i32().ok_or_else(trunc)?;
            let parametric = c.i32().ok_or_else(trunc)?;
            let n = c.u64().ok_or_else(trunc)? as usize;
            if parametric != 0 {
                return Err(bad("parametric nodes are not supported in binary files"));
            }
            let tags: Vec<u64> = (0..n)
                .map(|_| c.u64().ok_or_else(trunc))
                .collect::<Result<_>>()?;
            for tag in tags {
                let x = [
                    c.f64().ok_or_else(trunc)?,
                    c.f64().ok_or_else(trunc)?,
                    c.f64().ok_or_else(trunc)?,
                ];
                raw.add_node(tag, x);
            }
        }
        if !c.find_section("$Elements") {
            return Err(bad("no $Elements section"));
        }
        let blocks = c.u64().ok_or_else(trunc)?;
        for _ in 0..3 {
            c.u64().ok_or_else(trunc)?;
        }
        for _ in 0..blocks {
            let _dim = c.i32().ok_or_else(trunc)?;
            let _tag = c.i32().ok_or_else(trunc)?;
            let t = c.i32().ok_or_else(trunc)?;
            let n = c.u64().ok_or_else(trunc)? as usize;
            let nn = gmsh_nodes(t).ok_or_else(|| bad(&format!("unknown element type {t}")))?;
            for _ in 0..n {
                let v: Vec<u64> = (0..=nn)
                    .map(|_| c.u64().ok_or_else(trunc))
                    .collect::<Result<_>>()?;
                raw.add_element(t, &v[1..]);
            }
        }
    } else {
        let blocks: usize = c.num().ok_or_else(trunc)?;
        for _ in 0..3 {
            c.token().ok_or_else(trunc)?;
        }
        for _ in 0..blocks {
            let dim: usize = c.num().ok_or_else(trunc)?;
            let _tag: i64 = c.num().ok_or_else(trunc)?;
            let parametric: usize = c.num().ok_or_else(trunc)?;
            let n: usize = c.num().ok_or_else(trunc)?;
            let tags: Vec<u64> = (0..n)
                .map(|_| c.num().ok_or_else(trunc))
                .collect::<Result<_>>()?;
            for tag in tags {
                let x = [
                    c.num().ok_or_else(trunc)?,
                    c.num().ok_or_else(trunc)?,
                    c.num().ok_or_else(trunc)?,
                ];
                if parametric == 1 {
                    for _ in 0..dim {
                        c.token().ok_or_else(trunc)?;
                    }
                }
                raw.add_node(tag, x);
            }
        }
        if !c.find_section("$Elements") {
            return Err(bad("no $Elements section"));
        }
        let blocks: usize = c.num().ok_or_else(trunc)?;
        for _ in 0..3 {
            c.token().ok_or_else(trunc)?;
        }
        for _ in 0..blocks {
            let _dim: i64 = c.num().ok_or_else(trunc)?;
            let _tag: i64 = c.num().ok_or_else(trunc)?;
            let t: i32 = c.num().ok_or_else(trunc)?;
            let n: usize = c.num().ok_or_else(trunc)?;
            let nn = gmsh_nodes(t).ok_or_else(|| bad(&format!("unknown element type {t}")))?;
            for _ in 0..n {
                let v: Vec<u64> = (0..=nn)
                    .map(|_| c.num().ok_or_else(trunc))
                    .collect::<Result<_>>()?;
                raw.add_element(t, &v[1..]);
            }
        }
    }
    raw.finish(path)
}

/// Strips `#` comments from TetGen files.
fn strip_comments(d: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(d.len());
    let mut in_comment = false;
    for &b in d {
        if b == b'#' {
            in_comment = true;
        } else if b == b'\n' {
            in_comment = false;
        }
        out.push(if in_comment { b' ' } else { b });
    }
    out
}

pub(crate) fn load_tetgen(path: &Path) -> Result<TetMesh> {
    let node_path = path.with_extension("node");
    let ele_path = path.with_extension("ele");
    let nd = strip_comments(&read(&node_path)?);
    let mut c = Cur { d: &nd, p: 0 };
    let trunc = |p: &Path| parse_err(p, "TetGen: truncated or malformed");
    let n: usize = c.num().ok_or_else(|| trunc(&node_path))?;
    let dim: usize = c.num().ok_or_else(|| trunc(&node_path))?;
    let nattr: usize = c.num().ok_or_else(|| trunc(&node_path))?;
    let nmark: usize = c.num().ok_or_else(|| trunc(&node_path))?;
    if dim != 3 {
        return Err(parse_err(
            &node_path,
            format!("TetGen: dimension {dim}, expected 3"),
        ));
    }
    let mut raw = Raw::default();
    for _ in 0..n {
        let tag: u64 = c.num().ok_or_else(|| trunc(&node_path))?;
        let x = [
            c.num().ok_or_else(|| trunc(&node_path))?,
            c.num().ok_or_else(|| trunc(&node_path))?,
            c.num().ok_or_else(|| trunc(&node_path))?,
        ];
        for _ in 0..nattr + nmark.min(1) {
            c.token().ok_or_else(|| trunc(&node_path))?;
        }
        raw.add_node(tag, x);
    }
    let ed = strip_comments(&read(&ele_path)?);
    let mut c = Cur { d: &ed, p: 0 };
    let ne: usize = c.num().ok_or_else(|| trunc(&ele_path))?;
    let npt: usize = c.num().ok_or_else(|| trunc(&ele_path))?;
    let nattr: usize = c.num().ok_or_else(|| trunc(&ele_path))?;
    if npt != 4 && npt != 10 {
        return Err(parse_err(
            &ele_path,
            format!("TetGen: {npt} nodes per tet (4 or 10 expected)"),
        ));
    }
    for _ in 0..ne {
        let _id: u64 = c.num().ok_or_else(|| trunc(&ele_path))?;
        let v: Vec<u64> = (0..npt)
            .map(|_| c.num().ok_or_else(|| trunc(&ele_path)))
            .collect::<Result<_>>()?;
        for _ in 0..nattr {
            c.token().ok_or_else(|| trunc(&ele_path))?;
        }
        raw.add_element(4, &v);
    }
    match raw.finish(path)? {
        LoadedMesh::Tets(t) => Ok(t),
        LoadedMesh::Surface(_) => Err(parse_err(path, "TetGen: no tetrahedra")),
    }
}

pub(crate) fn load_medit(path: &Path) -> Result<LoadedMesh> {
    let data = read(path)?;
    let data = strip_comments(&data);
    let mut c = Cur { d: &data, p: 0 };
    let trunc = || parse_err(path, "MEDIT: truncated or malformed");
    let mut raw = Raw::default();
    let mut seen_version = false;
    // Ints per entry of sections we skip.
    let skip = |k: &str| -> Option<usize> {
        Some(match k {
            "Edges" => 3,
            "Quadrilaterals" => 5,
            "Hexahedra" => 9,
            "Prisms" => 7,
            "Corners" | "Ridges" | "RequiredVertices" | "RequiredEdges" | "RequiredTriangles" => 1,
            "Normals" | "Tangents" => 3,
            "NormalAtVertices" | "TangentAtVertices" => 2,
            _ => return None,
        })
    };
    while let Some(tok) = c.token() {
        match tok {
            "MeshVersionFormatted" => {
                let v: i32 = c.num().ok_or_else(trunc)?;
                if v != 1 && v != 2 {
                    return Err(parse_err(path, format!("MEDIT: version {v} not supported")));
                }
                seen_version = true;
            }
            "Dimension" => {
                let d: usize = c.num().ok_or_else(trunc)?;
                if d != 3 {
                    return Err(parse_err(path, format!("MEDIT: dimension {d}, expected 3")));
                }
            }
            "Vertices" => {
                let n: usize = c.num().ok_or_else(trunc)?;
                for i in 0..n {
                    let x = [
                        c.num().ok_or_else(trunc)?,
                        c.num().ok_or_else(trunc)?,
                        c.num().ok_or_else(trunc)?,
                    ];
                    let _r: i64 = c.num().ok_or_else(trunc)?;
                    raw.add_node(i as u64 + 1, x);
                }
            }
            "Tetrahedra" | "Triangles" => {
                let n: usize = c.num().ok_or_else(trunc)?;
                let k = if tok == "Tetrahedra" { 4 } else { 3 };
                for _ in 0..n {
                    let v: Vec<u64> = (0..k)
                        .map(|_| c.num().ok_or_else(trunc))
                        .collect::<Result<_>>()?;
                    let _r: i64 = c.num().ok_or_else(trunc)?;
                    raw.add_element(if k == 4 { 4 } else { 2 }, &v);
                }
            }
            "End" => break,
            other => {
                let per = skip(other).ok_or_else(|| {
                    parse_err(path, format!("MEDIT: unsupported section '{other}'"))
                })?;
                let n: usize = c.num().ok_or_else(trunc)?;
                for _ in 0..n.checked_mul(per).ok_or_else(trunc)? {
                    c.token().ok_or_else(trunc)?;
                }
            }
        }
    }
    if !seen_version {
        return Err(parse_err(path, "MEDIT: no MeshVersionFormatted header"));
    }
    raw.finish(path)
}
