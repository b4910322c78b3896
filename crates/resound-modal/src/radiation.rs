//! Fitting each mode's acoustic transfer ([`resound_core::radiation`]) to its surface normal
//! velocity.
//!
//! Method (equivalent sources re-expanded as one multipole, precomputed once per model): up to
//! [`TransferParams::max_sources`] monopoles are placed inside the surface (vertices spread by
//! farthest-point sampling, moved inward along their normals as deep as they stay clear of the
//! rest of the surface). At each grid frequency their strengths are fitted in the least-squares
//! sense to the mode's normal velocity `φ·n` at every surface vertex (the field's `∂p/∂n /
//! (iωρ)`, each equation weighted by the square root of its vertex's area; columns scaled to
//! unit norm, a small Tikhonov term; one QR factorisation (faer) per grid frequency for all the
//! modes that need it). The sources are then re-expanded about the centre by the addition
//! theorem into the outgoing multipole series the run time evaluates, of order kR + 6 up to
//! [`TransferParams::max_order`] (R: the radius of the sphere that holds the surface).
//! Distributed sources follow a complicated shape (legs, ears, a thin plate) where one
//! expansion fitted directly to the surface cannot (the Rayleigh hypothesis fails there); the
//! relative misfit of each fit is kept (`ModeTransfer::residual`) so a poorly represented mode
//! is reported, not hidden.

use faer::c64;
use faer::linalg::solvers::SolveLstsq;
use faer::Mat;
use rayon::prelude::*;
use resound_core::radiation::{
    real_spherical_harmonics, spherical_bessel, AcousticTransfer, ModeTransfer, AIR_DENSITY_KG_M3,
    SOUND_SPEED_M_S,
};
use resound_core::ModalModel;

/// Most equivalent sources a transfer fit may ask for (the cost grows as their square).
pub const MAX_SOURCES: usize = 5000;

/// Settings of [`fit_transfer`].
#[derive(Clone, Debug, PartialEq)]
pub struct TransferParams {
    /// Highest multipole order L (at most 30).
    pub max_order: usize,
    /// Grid points per octave.
    pub per_octave: u32,
    /// Octaves stored on each side of a mode's frequency (materials with other E/ρ move it).
    pub span_octaves: f64,
    /// Frequency of grid point 0, Hz.
    pub grid_start_hz: f64,
    /// Grid points above this are not stored, Hz.
    pub max_freq_hz: f64,
    /// Speed of sound, m/s.
    pub sound_speed_m_s: f64,
    /// Air density, kg/m³.
    pub air_density_kg_m3: f64,
    /// Tikhonov weight relative to the unit column norms.
    pub regularization: f64,
    /// Most equivalent sources (monopoles inside the surface; at most a third of the surface
    /// vertices). More follow a complicated shape more closely; the cost grows as their square.
    pub max_sources: usize,
}

impl TransferParams {
    /// Checks the settings (what [`fit_transfer`] checks first; front ends call it before a
    /// modal solve so a bad setting is refused at once).
    ///
    /// # Errors
    /// [`TransferError::Parameter`] naming the setting.
    pub fn validate(&self) -> Result<(), TransferError> {
        let p = self;
        if !(1..=30).contains(&p.max_order)
            || p.per_octave == 0
            || p.per_octave > 48
            || !(p.span_octaves >= 0.0 && p.span_octaves <= 6.0)
            || !(p.grid_start_hz > 0.0 && p.max_freq_hz > p.grid_start_hz)
            || !(p.sound_speed_m_s > 0.0 && p.air_density_kg_m3 > 0.0)
            || !(p.regularization >= 0.0 && p.regularization < 1.0)
        {
            return Err(TransferError::Parameter(format!("unusable settings {p:?}")));
        }
        if !(1..=MAX_SOURCES).contains(&p.max_sources) {
            return Err(TransferError::Parameter(format!(
                "{} equivalent sources: between 1 and {MAX_SOURCES} fit a surface's radiation",
                p.max_sources
            )));
        }
        Ok(())
    }
}

impl Default for TransferParams {
    fn default() -> Self {
        Self {
            max_order: 20,
            per_octave: 3,
            span_octaves: 2.0,
            grid_start_hz: 10.0,
            max_freq_hz: 40_000.0,
            sound_speed_m_s: SOUND_SPEED_M_S,
            air_density_kg_m3: AIR_DENSITY_KG_M3,
            regularization: 1e-10,
            max_sources: 800,
        }
    }
}

/// What [`fit_transfer`] did.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TransferInfo {
    /// Grid frequencies factorised.
    pub grid_points: usize,
    /// Surface points (equations) per fit.
    pub surface_points: usize,
    /// The largest number of unknowns of one fit.
    pub max_unknowns: usize,
    /// The worst relative misfit of any mode at any stored point (the ends of the ±2 octaves
    /// included: the highest are the hardest).
    pub worst_residual: f64,
    /// Modes whose misfit exceeds 0.9 at their own frequency.
    pub poorly_fitted: usize,
    /// Bytes the coefficients take.
    pub bytes: usize,
    /// Equivalent sources.
    pub sources: usize,
    /// Grid frequencies whose expansion was cut at `max_order` below kR + 6 (their
    /// directivity loses fine lobes).
    pub truncated_points: usize,
}

/// Errors of [`fit_transfer`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TransferError {
    /// Unusable settings or inputs.
    #[error("acoustic transfer: {0}")]
    Parameter(String),
}

/// +1 when the triangles wind outward (positive signed volume), −1 when inward.
fn winding_sign(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> f64 {
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum();
    if volume < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Per surface vertex: area-weighted unit outward normal and a third of the adjacent triangles' area.
pub fn vertex_normals_and_areas(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut normals = vec![[0.0f64; 3]; vertices.len()];
    let mut areas = vec![0.0; vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let area = 0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        for &i in t {
            for k in 0..3 {
                normals[i as usize][k] += n[k];
            }
            areas[i as usize] += area / 3.0;
        }
    }
    // Outward: flip all when the signed volume says the triangles wind inward.
    let sign = winding_sign(vertices, triangles);
    for n in &mut normals {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len > 0.0 {
            *n = n.map(|x| sign * x / len);
        }
    }
    (normals, areas)
}

/// Fits the transfer of modes whose normal velocity patterns (`patterns`, mode-major,
/// `freqs_hz.len() × vertices.len()`, per unit modal velocity) are given on a closed surface.
///
/// # Errors
/// [`TransferError::Parameter`] for inconsistent sizes, no surface or unusable settings.
pub fn fit_transfer(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    patterns: &[f64],
    freqs_hz: &[f64],
    params: &TransferParams,
) -> Result<(AcousticTransfer, TransferInfo), TransferError> {
    let nv = vertices.len();
    let bad = |m: String| Err(TransferError::Parameter(m));
    if patterns.len() != nv * freqs_hz.len() {
        return bad(format!(
            "{} pattern values for {} modes × {nv} vertices",
            patterns.len(),
            freqs_hz.len()
        ));
    }
    if triangles.is_empty() || nv < 4 {
        return bad("the surface has no triangles".into());
    }
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= nv))
    {
        return bad(format!("triangle {t:?} refers past the {nv} vertices"));
    }
    if vertices.iter().flatten().any(|c| !c.is_finite()) || patterns.iter().any(|v| !v.is_finite())
    {
        return bad("a vertex or a normal velocity is not finite".into());
    }
    params.validate()?;
    let p = params;
    if freqs_hz.iter().any(|f| !(f.is_finite() && *f >= 0.0)) {
        return bad("a mode frequency is not finite".into());
    }
    let (normals, areas) = vertex_normals_and_areas(vertices, triangles);
    let total: f64 = areas.iter().sum();
    let mut centre = [0.0; 3];
    for (v, a) in vertices.iter().zip(&areas) {
        for c in 0..3 {
            centre[c] += v[c] * a / total;
        }
    }
    let rel: Vec<[f64; 3]> = vertices
        .iter()
        .map(|v| [v[0] - centre[0], v[1] - centre[1], v[2] - centre[2]])
        .collect();
    let radius = rel
        .iter()
        .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
        .fold(0.0f64, f64::max);
    if !(radius > 0.0 && total > 0.0) {
        return bad("the surface has no extent".into());
    }
    // Equations: vertices with area, off the centre.
    let rows: Vec<usize> = (0..nv)
        .filter(|&v| {
            let d = rel[v];
            areas[v] > 0.0 && (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() > 1e-6 * radius
        })
        .collect();
    let n_oct = f64::from(p.per_octave);
    let grid_index = |f: f64| n_oct * (f / p.grid_start_hz).log2();
    let top = grid_index(p.max_freq_hz).floor().max(0.0) as i64;
    // Each mode's stored range of grid points.
    let ranges: Vec<Option<(u32, u32)>> = freqs_hz
        .iter()
        .map(|&f| {
            if !(f > 0.0) {
                return None;
            }
            let lo = (grid_index(f) - n_oct * p.span_octaves).floor().max(0.0) as i64;
            let hi = ((grid_index(f) + n_oct * p.span_octaves).ceil() as i64).min(top);
            (hi >= lo).then_some((lo as u32, hi as u32))
        })
        .collect();
    let mut needed: Vec<u32> = ranges.iter().flatten().flat_map(|&(a, b)| a..=b).collect();
    needed.sort_unstable();
    needed.dedup();
    // A mode that barely moves the surface normally (a torsion of a sphere) radiates next to
    // nothing: its misfit is measured against a hundredth of the typical mode's velocity, not
    // against its own numerical noise.
    let mut norms: Vec<f64> = (0..freqs_hz.len())
        .map(|j| {
            (0..nv)
                .map(|v| areas[v] * patterns[j * nv + v].powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    norms.sort_by(f64::total_cmp);
    let floor = 1e-2 * norms.get(norms.len() / 2).copied().unwrap_or(0.0);
    let sources = equivalent_sources(
        vertices,
        triangles,
        &normals,
        centre,
        radius,
        p.max_sources.min(rows.len() / 3).max(1),
    );
    if sources.is_empty() {
        return bad("no point inside the surface for an equivalent source (is it closed?)".into());
    }
    // The re-expansion's order: kR plus a margin (its terms fall off as (r_s/R)^l beyond kR).
    let order_at = |f: f64| {
        let kr = 2.0 * std::f64::consts::PI * f / p.sound_speed_m_s * radius;
        ((kr.ceil() as usize) + 6).min(p.max_order)
    };
    let truncated = needed
        .iter()
        .filter(|&&gi| {
            let f = p.grid_start_hz * (f64::from(gi) / n_oct).exp2();
            let kr = 2.0 * std::f64::consts::PI * f / p.sound_speed_m_s * radius;
            (kr.ceil() as usize) + 6 > p.max_order
        })
        .count();
    // One factorisation per grid point: (grid index, per mode in range: coefficients, misfit).
    let solved: Vec<(u32, Vec<PointFit>)> = needed
        .par_iter()
        .map(|&gi| {
            let f = p.grid_start_hz * (f64::from(gi) / n_oct).exp2();
            let modes: Vec<usize> = (0..freqs_hz.len())
                .filter(|&j| ranges[j].is_some_and(|(a, b)| (a..=b).contains(&gi)))
                .collect();
            (
                gi,
                solve_point(
                    f,
                    order_at(f),
                    &rows,
                    &rel,
                    &normals,
                    &areas,
                    &sources,
                    patterns,
                    nv,
                    &modes,
                    floor,
                    p,
                ),
            )
        })
        .collect();
    let mut modes: Vec<ModeTransfer> = ranges
        .iter()
        .map(|r| ModeTransfer {
            first: r.map_or(0, |(a, _)| a),
            orders: Vec::new(),
            coeffs: Vec::new(),
            residuals: Vec::new(),
        })
        .collect();
    let mut max_unknowns = 0;
    for (_, sols) in &solved {
        for (j, c, res) in sols {
            let m = &mut modes[*j];
            let l = ((c.len() as f64).sqrt() as usize).saturating_sub(1);
            max_unknowns = max_unknowns.max(c.len());
            m.orders.push(l as u8);
            m.coeffs
                .extend(c.iter().flat_map(|z| [z.re as f32, z.im as f32]));
            m.residuals.push(*res as f32);
        }
    }
    let worst = modes
        .iter()
        .flat_map(|m| m.residuals.iter().map(|&r| f64::from(r)))
        .fold(0.0, f64::max);
    // Poorly fitted at the mode's own frequency (the material the model was solved with).
    let poorly = modes
        .iter()
        .zip(freqs_hz)
        .filter(|(m, &f)| {
            let pos = n_oct * (f / p.grid_start_hz).log2() - f64::from(m.first);
            let i = (pos.round().max(0.0) as usize).min(m.residuals.len().saturating_sub(1));
            m.residuals
                .get(i)
                .is_some_and(|&r| f64::from(r) > resound_core::limits::POOR_TRANSFER_MISFIT)
        })
        .count();
    let transfer = AcousticTransfer {
        centre_m: centre,
        radius_m: radius,
        sound_speed_m_s: p.sound_speed_m_s,
        air_density_kg_m3: p.air_density_kg_m3,
        grid_start_hz: p.grid_start_hz,
        per_octave: p.per_octave,
        modes,
    };
    let info = TransferInfo {
        grid_points: needed.len(),
        surface_points: rows.len(),
        max_unknowns,
        worst_residual: worst,
        poorly_fitted: poorly,
        bytes: transfer.coeff_bytes(),
        sources: sources.len(),
        truncated_points: truncated,
    };
    Ok((transfer, info))
}

/// One mode's fit at one grid frequency: mode index, coefficients, relative misfit.
type PointFit = (usize, Vec<c64>, f64);

/// The least-squares fit at one grid frequency for the modes `modes`: equivalent monopoles
/// at `sources` fitted to the normal velocity, then re-expanded about the centre (addition
/// theorem: `e^{ik|x−s|}/(4π|x−s|) = ik Σ_l j_l(k r_s) h_l(k r) Σ_m Y_lm(ŝ) Y_lm(x̂)` for
/// `r > r_s`) to order `l_max`.
#[allow(clippy::too_many_arguments)]
fn solve_point(
    freq_hz: f64,
    l_max: usize,
    rows: &[usize],
    rel: &[[f64; 3]],
    normals: &[[f64; 3]],
    areas: &[f64],
    sources: &[[f64; 3]],
    patterns: &[f64],
    nv: usize,
    modes: &[usize],
    floor: f64,
    p: &TransferParams,
) -> Vec<PointFit> {
    let ns = sources.len();
    let k = 2.0 * std::f64::consts::PI * freq_hz / p.sound_speed_m_s;
    let omega_rho = 2.0 * std::f64::consts::PI * freq_hz * p.air_density_kg_m3;
    let nr = rows.len();
    let mut a = Mat::<c64>::zeros(nr + ns, ns);
    let inv4pi = 1.0 / (4.0 * std::f64::consts::PI);
    for (row, &v) in rows.iter().enumerate() {
        let x = rel[v];
        let w = areas[v].sqrt();
        let n = normals[v];
        for (c, s) in sources.iter().enumerate() {
            let d = [x[0] - s[0], x[1] - s[1], x[2] - s[2]];
            let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
            // G = e^{ikr}/(4πr); ∂G/∂n = G (ik − 1/r) (d̂·n); v_n = ∂p/∂n / (iωρ)
            let g = c64::new((k * r).cos(), (k * r).sin()) * (inv4pi / r);
            let dn = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) / r;
            let dg = g * c64::new(-1.0 / r, k) * dn;
            a[(row, c)] = dg * c64::new(0.0, -1.0 / omega_rho) * w;
        }
    }
    let mut scale = vec![0.0; ns];
    for (c, sc) in scale.iter_mut().enumerate() {
        let norm = (0..nr).map(|r| a[(r, c)].norm_sqr()).sum::<f64>().sqrt();
        *sc = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        for r in 0..nr {
            a[(r, c)] *= *sc;
        }
        a[(nr + c, c)] = c64::new(p.regularization.sqrt(), 0.0);
    }
    let mut b = Mat::<c64>::zeros(nr + ns, modes.len());
    for (col, &j) in modes.iter().enumerate() {
        for (row, &v) in rows.iter().enumerate() {
            b[(row, col)] = c64::new(patterns[j * nv + v] * areas[v].sqrt(), 0.0);
        }
    }
    let q = a.qr().solve_lstsq(&b);
    let fit = a.as_ref().subrows(0, nr) * &q;
    // Re-expansion: per source, ik j_l(k r_s) Y_lm(ŝ).
    let nc = (l_max + 1) * (l_max + 1);
    let mut basis = Mat::<c64>::zeros(nc, ns);
    let mut jl = vec![0.0; l_max + 1];
    let mut ylm = vec![0.0; nc];
    for (c, s) in sources.iter().enumerate() {
        let rs = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        spherical_bessel(k * rs, &mut jl);
        let u = if rs > 0.0 {
            s.map(|x| x / rs)
        } else {
            [0.0, 0.0, 1.0]
        };
        real_spherical_harmonics(l_max, u, &mut ylm);
        for l in 0..=l_max {
            for i in l * l..(l + 1) * (l + 1) {
                basis[(i, c)] = c64::new(0.0, k * jl[l] * ylm[i] * scale[c]);
            }
        }
    }
    let coeffs = &basis * q.as_ref().subrows(0, ns);
    modes
        .iter()
        .enumerate()
        .map(|(col, &j)| {
            let (mut e, mut t) = (0.0, 0.0);
            for row in 0..nr {
                e += (fit[(row, col)] - b[(row, col)]).norm_sqr();
                t += b[(row, col)].norm_sqr();
            }
            let den = t.sqrt().max(floor);
            let res = if den > 0.0 { e.sqrt() / den } else { 0.0 };
            let c: Vec<c64> = (0..nc).map(|i| coeffs[(i, col)]).collect();
            (j, c, res)
        })
        .collect()
}

/// Equivalent-source positions (relative to the centre): up to `max` surface vertices spread
/// by farthest-point sampling, each moved inward along its normal by the largest of a few
/// depths (a fraction of the radius) at which it stays inside, clear of the rest of the surface.
fn equivalent_sources(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    normals: &[[f64; 3]],
    centre: [f64; 3],
    radius: f64,
    max: usize,
) -> Vec<[f64; 3]> {
    let nv = vertices.len();
    let mut chosen = Vec::with_capacity(max.min(nv));
    let mut dist = vec![f64::INFINITY; nv];
    let mut next = 0;
    while chosen.len() < max.min(nv) {
        chosen.push(next);
        let c = vertices[next];
        let mut best = (0.0, next);
        for (v, d) in dist.iter_mut().enumerate() {
            let x = vertices[v];
            let dd = (x[0] - c[0]).powi(2) + (x[1] - c[1]).powi(2) + (x[2] - c[2]).powi(2);
            *d = d.min(dd);
            if *d > best.0 {
                best = (*d, v);
            }
        }
        if best.0 <= 0.0 {
            break;
        }
        next = best.1;
    }
    let sign = winding_sign(vertices, triangles);
    // The sources' spacing over the surface: a source about that deep makes a smooth field
    // at the surface (shallower ones show as bumps between them).
    let area: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            0.5 * ((u[1] * v[2] - u[2] * v[1]).powi(2)
                + (u[2] * v[0] - u[0] * v[2]).powi(2)
                + (u[0] * v[1] - u[1] * v[0]).powi(2))
            .sqrt()
        })
        .sum();
    let spacing = (area / chosen.len().max(1) as f64).sqrt();
    chosen
        .iter()
        .filter_map(|&v| {
            let (x, n) = (vertices[v], normals[v]);
            // The shallow depths are for thin walls (a 4 mm plate, a bowl): a source must stay
            // nearer its own face than the opposite one.
            [
                2.0, 1.4, 1.0, 0.7, 0.5, 0.35, 0.25, 0.18, 0.12, 0.08, 0.05, 0.03,
            ]
            .iter()
            .find_map(|&f| {
                let depth = (f * spacing).min(0.3 * radius);
                let s = [0, 1, 2].map(|c| x[c] - depth * n[c]);
                let sp = resound_core::geometry::closest_surface_point(vertices, triangles, s)?;
                // Still inside: the nearest surface faces away (outward normal points from s).
                let out = sign
                    * (0..3)
                        .map(|c| (sp.point[c] - s[c]) * sp.normal[c])
                        .sum::<f64>();
                (sp.distance >= 0.6 * depth && out > 0.0)
                    .then(|| [0, 1, 2].map(|c| s[c] - centre[c]))
            })
        })
        .collect()
}

/// [`fit_transfer`] for a modal model: each mode's pattern is `φ_j · n` at the surface vertices.
///
/// # Errors
/// As [`fit_transfer`].
pub fn model_transfer(
    model: &ModalModel,
    params: &TransferParams,
) -> Result<(AcousticTransfer, TransferInfo), TransferError> {
    let (normals, _) = vertex_normals_and_areas(&model.vertices, &model.triangles);
    let nv = model.n_vertices();
    let mut patterns = vec![0.0; model.n_modes() * nv];
    for j in 0..model.n_modes() {
        for (v, n) in normals.iter().enumerate() {
            let s = model.shape(j, v);
            patterns[j * nv + v] =
                f64::from(s[0]) * n[0] + f64::from(s[1]) * n[1] + f64::from(s[2]) * n[2];
        }
    }
    fit_transfer(
        &model.vertices,
        &model.triangles,
        &patterns,
        &model.freqs_hz(),
        params,
    )
}
