//! PLY reader (ASCII, binary little- and big-endian), vertices and faces only.
//! Written here because the PLY crates on crates.io are unmaintained (ply-rs: last release 2019).

use crate::mesh::read;
use crate::{parse_err, Result};
use resound_fem::SurfaceMesh;
use std::path::Path;

#[derive(Clone, Copy, PartialEq)]
enum Fmt {
    Ascii,
    Le,
    Be,
}

#[derive(Clone, Copy)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

fn ty(s: &str) -> Option<Ty> {
    Some(match s {
        "char" | "int8" => Ty::I8,
        "uchar" | "uint8" => Ty::U8,
        "short" | "int16" => Ty::I16,
        "ushort" | "uint16" => Ty::U16,
        "int" | "int32" => Ty::I32,
        "uint" | "uint32" => Ty::U32,
        "float" | "float32" => Ty::F32,
        "double" | "float64" => Ty::F64,
        _ => return None,
    })
}

enum Prop {
    Scalar(String, Ty),
    List(String, Ty, Ty),
}

struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    fmt: Fmt,
}

impl Reader<'_> {
    fn token(&mut self) -> Option<&str> {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > start).then(|| std::str::from_utf8(&self.data[start..self.pos]).unwrap_or(""))
    }

    fn value(&mut self, t: Ty) -> Option<f64> {
        if self.fmt == Fmt::Ascii {
            return self.token()?.parse::<f64>().ok();
        }
        let size = match t {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        };
        let b = self.data.get(self.pos..self.pos + size)?;
        self.pos += size;
        let mut a = [0u8; 8];
        a[..size].copy_from_slice(b);
        if self.fmt == Fmt::Be {
            a[..size].reverse();
        }
        Some(match t {
            Ty::I8 => a[0] as i8 as f64,
            Ty::U8 => a[0] as f64,
            Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(a),
        })
    }
}

pub(crate) fn load_ply(path: &Path) -> Result<SurfaceMesh> {
    let data = read(path)?;
    let end = data
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or_else(|| parse_err(path, "PLY: no end_header"))?;
    let header = String::from_utf8_lossy(&data[..end]);
    let mut lines = header.lines();
    if lines.next().map(str::trim) != Some("ply") {
        return Err(parse_err(path, "PLY: missing 'ply' magic"));
    }
    let mut fmt = None;
    let mut elements: Vec<Element> = Vec::new();
    for (no, line) in lines.enumerate() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let bad = || parse_err(path, format!("PLY header line {}: '{line}'", no + 2));
        match w.first().copied() {
            Some("format") => {
                fmt = Some(match w.get(1).copied() {
                    Some("ascii") => Fmt::Ascii,
                    Some("binary_little_endian") => Fmt::Le,
                    Some("binary_big_endian") => Fmt::Be,
                    _ => return Err(bad()),
                })
            }
            Some("element") => elements.push(Element {
                name: w.get(1).ok_or_else(bad)?.to_string(),
                count: w.get(2).and_then(|c| c.parse().ok()).ok_or_else(bad)?,
                props: Vec::new(),
            }),
            Some("property") => {
                let el = elements.last_mut().ok_or_else(bad)?;
                if w.get(1) == Some(&"list") {
                    let (c, v) = (ty(w.get(2).ok_or_else(bad)?), ty(w.get(3).ok_or_else(bad)?));
                    el.props.push(Prop::List(
                        w.get(4).ok_or_else(bad)?.to_string(),
                        c.ok_or_else(bad)?,
                        v.ok_or_else(bad)?,
                    ));
                } else {
                    el.props.push(Prop::Scalar(
                        w.get(2).ok_or_else(bad)?.to_string(),
                        ty(w.get(1).ok_or_else(bad)?).ok_or_else(bad)?,
                    ));
                }
            }
            Some("comment") | Some("obj_info") | None => {}
            _ => return Err(bad()),
        }
    }
    let fmt = fmt.ok_or_else(|| parse_err(path, "PLY: no format line"))?;
    // Body starts after the newline following end_header.
    let mut pos = end + 10;
    while pos < data.len() && data[pos] != b'\n' {
        pos += 1;
    }
    let mut r = Reader {
        data: &data,
        pos: pos + 1,
        fmt,
    };
    let declared = elements
        .iter()
        .map(|e| format!("{} {}", e.name, e.count))
        .collect::<Vec<_>>()
        .join(", ");
    let truncated = || {
        parse_err(
            path,
            format!(
                "PLY: the body ends (or holds a non-number) before the header's counts ({declared}) \
                 are read"
            ),
        )
    };
    // Every element takes at least one byte (one property): a count beyond the body is a lie
    // that would otherwise loop (fuzzing found `element face 745884821769` with no properties).
    let body = data.len().saturating_sub(r.pos);
    for el in &elements {
        if el.count > 0 && el.props.is_empty() {
            return Err(parse_err(
                path,
                format!("PLY: element {} has no properties", el.name),
            ));
        }
        if el.count > body {
            return Err(parse_err(
                path,
                format!(
                    "PLY: the header declares {} {} elements but the body has {body} bytes",
                    el.count, el.name
                ),
            ));
        }
    }
    let mut m = SurfaceMesh::default();
    for el in &elements {
        for _ in 0..el.count {
            let mut xyz = [0.0; 3];
            for p in &el.props {
                match p {
                    Prop::Scalar(name, t) => {
                        let v = r.value(*t).ok_or_else(truncated)?;
                        if el.name == "vertex" {
                            match name.as_str() {
                                "x" => xyz[0] = v,
                                "y" => xyz[1] = v,
                                "z" => xyz[2] = v,
                                _ => {}
                            }
                        }
                    }
                    Prop::List(name, ct, vt) => {
                        let n = r.value(*ct).ok_or_else(truncated)?;
                        if !(0.0..=1024.0).contains(&n) {
                            return Err(parse_err(
                                path,
                                format!("PLY: list of {n} entries (at most 1024 supported)"),
                            ));
                        }
                        let n = n as usize;
                        let mut idx = Vec::with_capacity(n);
                        for _ in 0..n {
                            idx.push(r.value(*vt).ok_or_else(truncated)?);
                        }
                        if el.name == "face" && (name == "vertex_indices" || name == "vertex_index")
                        {
                            if idx.iter().any(|&i| i < 0.0) {
                                return Err(parse_err(path, "PLY: negative vertex index"));
                            }
                            for k in 1..n.saturating_sub(1) {
                                m.triangles
                                    .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
                            }
                        }
                    }
                }
            }
            if el.name == "vertex" {
                m.vertices.push(xyz);
            }
        }
    }
    if m.triangles.is_empty() {
        return Err(parse_err(
            path,
            format!("PLY: no faces (the header declares {declared})"),
        ));
    }
    if r.fmt == Fmt::Ascii && r.token().is_some() {
        return Err(parse_err(
            path,
            format!(
                "PLY: more data after the last element than the header's counts ({declared}) \
                 describe"
            ),
        ));
    }
    let nv = m.vertices.len();
    if let Some(t) = m
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= nv))
    {
        return Err(parse_err(
            path,
            format!(
                "PLY: a face refers to vertex {:?} but there are {nv} vertices",
                t
            ),
        ));
    }
    Ok(m)
}
