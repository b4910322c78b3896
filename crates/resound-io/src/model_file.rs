//! The `.rmodal` modal model file.
//!
//! Little-endian binary, version 2 (version 1, the same without the transfer section, is
//! still read):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `RSMODAL\0` |
//! | 4 | format version (u32) = 1 |
//! | 4 + n | material name (u32 length, UTF-8) |
//! | 24 | E (Pa), ν, ρ (kg/m³) as f64 |
//! | 16 | FEM DOFs, elements (u64) |
//! | 12 | modes m, vertices v, triangles t (u32) |
//! | 8m | eigenvalues λ = ω² (f64, rad²/s²) |
//! | 24v | vertex positions (f64, m) |
//! | 12t | triangles (u32) |
//! | 12mv | mass-normalised shapes (f32, 1/√kg), mode-major |
//! | 4 | 1 when an acoustic transfer follows, else 0 (u32) |
//! | 48 + 4 | transfer: centre (3 × f64, m), radius (m), sound speed (m/s), air density (kg/m³), grid start (Hz) as f64 — 7 × f64 = 56 bytes —, points per octave (u32) |
//! | per mode | first grid point, points n (u32), n orders (u8), n misfits (f32), coefficients 2 Σ(L+1)² (f32) |
//! | 8 | FNV-1a 64 checksum of all preceding bytes |
//!
//! Shapes are f32 (about 7 digits: far below what any sound needs) so a 200-mode model of a
//! 5 000-vertex surface is 12 MB. Reading is one `read` and a few `copy_from_slice`s.

use crate::atomic::write_atomic;
use crate::{parse_err, Result};
use resound_core::radiation::{AcousticTransfer, ModeTransfer};
use resound_core::{Material, ModalModel};
use std::path::Path;

const MAGIC: &[u8; 8] = b"RSMODAL\0";
/// Current format version.
pub const VERSION: u32 = 2;

pub(crate) fn fnv1a(data: &[u8]) -> u64 {
    let mut h = Fnv1a::new();
    h.write(data);
    h.finish()
}

/// 64-bit FNV-1a, the one content hash of the workspace: the checksum of `.rmodal` and
/// `.grains` files and the modal cache key of scenes. The same on every build and platform
/// (unlike `std`'s `DefaultHasher`).
#[derive(Clone, Copy, Debug)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Self::new()
    }
}

impl Fnv1a {
    /// The offset basis.
    pub fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    /// Hashes `data` in.
    pub fn write(&mut self, data: &[u8]) {
        for &b in data {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// Encodes a model.
pub fn encode(m: &ModalModel) -> Vec<u8> {
    let mut b = Vec::with_capacity(
        96 + m.eigenvalues.len() * 8 + m.vertices.len() * 24 + m.shapes.len() * 4,
    );
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&VERSION.to_le_bytes());
    b.extend_from_slice(&(m.material.name.len() as u32).to_le_bytes());
    b.extend_from_slice(m.material.name.as_bytes());
    for x in [
        m.material.youngs_modulus,
        m.material.poisson_ratio,
        m.material.density,
    ] {
        b.extend_from_slice(&x.to_le_bytes());
    }
    b.extend_from_slice(&m.fem_dofs.to_le_bytes());
    b.extend_from_slice(&m.fem_elements.to_le_bytes());
    for n in [m.eigenvalues.len(), m.vertices.len(), m.triangles.len()] {
        b.extend_from_slice(&(n as u32).to_le_bytes());
    }
    for x in &m.eigenvalues {
        b.extend_from_slice(&x.to_le_bytes());
    }
    for v in &m.vertices {
        for x in v {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for t in &m.triangles {
        for x in t {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for x in &m.shapes {
        b.extend_from_slice(&x.to_le_bytes());
    }
    match &m.transfer {
        None => b.extend_from_slice(&0u32.to_le_bytes()),
        Some(t) => {
            b.extend_from_slice(&1u32.to_le_bytes());
            for x in [
                t.centre_m[0],
                t.centre_m[1],
                t.centre_m[2],
                t.radius_m,
                t.sound_speed_m_s,
                t.air_density_kg_m3,
                t.grid_start_hz,
            ] {
                b.extend_from_slice(&x.to_le_bytes());
            }
            b.extend_from_slice(&t.per_octave.to_le_bytes());
            for mt in &t.modes {
                b.extend_from_slice(&mt.first.to_le_bytes());
                b.extend_from_slice(&(mt.orders.len() as u32).to_le_bytes());
                b.extend_from_slice(&mt.orders);
                for r in &mt.residuals {
                    b.extend_from_slice(&r.to_le_bytes());
                }
                for x in &mt.coeffs {
                    b.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
    }
    let h = fnv1a(&b);
    b.extend_from_slice(&h.to_le_bytes());
    b
}

pub(crate) struct R<'a> {
    pub(crate) d: &'a [u8],
    pub(crate) p: usize,
}

impl<'a> R<'a> {
    pub(crate) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.d.get(self.p..self.p.checked_add(n)?)?;
        self.p += n;
        Some(s)
    }
    pub(crate) fn u32(&mut self) -> Option<u32> {
        self.take(4)
            .map(|s| u32::from_le_bytes(s.try_into().unwrap_or([0; 4])))
    }
    pub(crate) fn u64(&mut self) -> Option<u64> {
        self.take(8)
            .map(|s| u64::from_le_bytes(s.try_into().unwrap_or([0; 8])))
    }
    pub(crate) fn f64s(&mut self, n: usize) -> Option<Vec<f64>> {
        let s = self.take(n.checked_mul(8)?)?;
        Some(
            s.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                .collect(),
        )
    }
}

/// Checks a checksummed binary file's magic, version (u32 after the magic) and FNV-1a trailer;
/// returns a reader over its body positioned after the version. `bad` makes the errors.
pub(crate) fn open<'a>(
    data: &'a [u8],
    magic: &[u8; 8],
    version: u32,
    not_magic: &str,
    bad: &dyn Fn(&str) -> crate::IoError,
) -> Result<R<'a>> {
    open_versions(data, magic, version..=version, not_magic, bad).map(|(r, _)| r)
}

/// [`open`] accepting any version in `versions`; also returns the version found.
pub(crate) fn open_versions<'a>(
    data: &'a [u8],
    magic: &[u8; 8],
    versions: std::ops::RangeInclusive<u32>,
    not_magic: &str,
    bad: &dyn Fn(&str) -> crate::IoError,
) -> Result<(R<'a>, u32)> {
    let version = *versions.end();
    if data.len() < 8 || &data[..8] != magic {
        return Err(bad(not_magic));
    }
    if data.len() < 20 {
        return Err(bad("truncated"));
    }
    let (body, sum) = data.split_at(data.len() - 8);
    let mut r = R { d: body, p: 8 };
    let found = r.u32().ok_or_else(|| bad("truncated"))?;
    if !versions.contains(&found) {
        return Err(bad(&format!(
            "format version {found}; this build reads version {version}"
        )));
    }
    if u64::from_le_bytes(sum.try_into().unwrap_or([0; 8])) != fnv1a(body) {
        return Err(bad("checksum mismatch (file is truncated or corrupt)"));
    }
    Ok((r, found))
}

/// Decodes a model; `path` is for messages.
///
/// # Errors
/// [`crate::IoError::Parse`] for a wrong magic, unknown version, truncation, checksum mismatch
/// or an inconsistent model.
pub fn decode(data: &[u8], path: &Path) -> Result<ModalModel> {
    let bad = |m: &str| parse_err(path, format!("modal model file: {m}"));
    let (mut r, version) = open_versions(
        data,
        MAGIC,
        1..=VERSION,
        "not a .rmodal file (bad magic)",
        &bad,
    )?;
    let trunc = || bad("truncated");
    let nlen = r.u32().ok_or_else(trunc)? as usize;
    let name = String::from_utf8(r.take(nlen).ok_or_else(trunc)?.to_vec())
        .map_err(|_| bad("material name is not UTF-8"))?;
    let mat = r.f64s(3).ok_or_else(trunc)?;
    let material = Material {
        name,
        youngs_modulus: mat[0],
        poisson_ratio: mat[1],
        density: mat[2],
    };
    material.validate().map_err(|e| bad(&e.to_string()))?;
    let fem_dofs = r.u64().ok_or_else(trunc)?;
    let fem_elements = r.u64().ok_or_else(trunc)?;
    let (nm, nv, nt) = (
        r.u32().ok_or_else(trunc)? as usize,
        r.u32().ok_or_else(trunc)? as usize,
        r.u32().ok_or_else(trunc)? as usize,
    );
    let eigenvalues = r.f64s(nm).ok_or_else(trunc)?;
    let vflat = r
        .f64s(nv.checked_mul(3).ok_or_else(trunc)?)
        .ok_or_else(trunc)?;
    let tb = r
        .take(nt.checked_mul(12).ok_or_else(trunc)?)
        .ok_or_else(trunc)?;
    let ns = nm
        .checked_mul(nv)
        .and_then(|x| x.checked_mul(3))
        .ok_or_else(trunc)?;
    let sb = r
        .take(ns.checked_mul(4).ok_or_else(trunc)?)
        .ok_or_else(trunc)?;
    let transfer = if version >= 2 && r.u32().ok_or_else(trunc)? == 1 {
        Some(read_transfer(&mut r, nm).ok_or_else(trunc)?)
    } else {
        None
    };
    if r.p != data.len() - 8 {
        return Err(bad("trailing bytes"));
    }
    if let Some(t) = &transfer {
        let ok_grid = t.grid_start_hz > 0.0 && t.per_octave > 0 && t.per_octave <= 48;
        let ok_air = t.sound_speed_m_s > 0.0 && t.air_density_kg_m3 > 0.0 && t.radius_m > 0.0;
        // Orders and grid extents the fit can make (order ≤ 30; a grid point ≤ 20 octaves up):
        // anything beyond would make evaluation overflow or allocate without bound.
        let grid_top = u64::from(t.per_octave) * 20;
        let ok_extent = t.modes.iter().all(|m| {
            m.orders.iter().all(|&l| l <= 30)
                && u64::from(m.first) + m.orders.len() as u64 <= grid_top
                && m.residuals.iter().all(|r| r.is_finite())
        });
        if !(ok_grid && ok_air && ok_extent)
            || t.modes
                .iter()
                .any(|m| m.coeffs.iter().any(|c| !c.is_finite()))
        {
            return Err(bad(
                "acoustic transfer has a non-physical or non-finite value",
            ));
        }
    }
    let m = ModalModel {
        material,
        eigenvalues,
        vertices: vflat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        triangles: tb
            .chunks_exact(12)
            .map(|c| [0, 4, 8].map(|o| u32::from_le_bytes([c[o], c[o + 1], c[o + 2], c[o + 3]])))
            .collect(),
        shapes: sb
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
        fem_dofs,
        fem_elements,
        transfer,
    };
    m.check().map_err(|e| bad(&e.to_string()))?;
    Ok(m)
}

fn read_transfer(r: &mut R<'_>, n_modes: usize) -> Option<AcousticTransfer> {
    let h = r.f64s(7)?;
    let per_octave = r.u32()?;
    let mut modes = Vec::with_capacity(n_modes);
    for _ in 0..n_modes {
        let first = r.u32()?;
        let n = r.u32()? as usize;
        let orders = r.take(n)?.to_vec();
        let residuals = r
            .take(n.checked_mul(4)?)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let nc: usize = orders
            .iter()
            .map(|&l| (usize::from(l) + 1).pow(2) * 2)
            .sum();
        let coeffs = r
            .take(nc.checked_mul(4)?)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        modes.push(ModeTransfer {
            first,
            orders,
            coeffs,
            residuals,
        });
    }
    Some(AcousticTransfer {
        centre_m: [h[0], h[1], h[2]],
        radius_m: h[3],
        sound_speed_m_s: h[4],
        air_density_kg_m3: h[5],
        grid_start_hz: h[6],
        per_octave,
        modes,
    })
}

/// Writes a model atomically.
///
/// # Errors
/// I/O errors.
pub fn save(path: &Path, m: &ModalModel) -> Result<()> {
    let bytes = encode(m);
    write_atomic(path, |w| w.write_all(&bytes))
}

/// Reads a model.
///
/// # Errors
/// I/O errors and everything [`decode`] rejects.
pub fn load(path: &Path) -> Result<ModalModel> {
    let data = crate::mesh::read(path)?;
    decode(&data, path)
}
