//! The native half of the `resound` Python package (`resound._native`).
//!
//! Thin like the CLI: each function converts arguments, releases the GIL, calls one library
//! function and converts the result. Shapes, dtypes and keyword conventions (`sample_rate`,
//! float32 `(channels, samples)`) are settled in the Python half (`python/resound/`), so this
//! side takes contiguous float64 arrays and returns float32 audio. Reports cross as Python
//! dicts made by pythonize from the library's typed reports — the very structs the CLI's
//! `--json` prints — and documents coming in (materials, scenes) are deserialized by
//! pythonize straight into the library's types, so both front ends share one contract.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use resound::core::{DampedMode, Material, SoundMaterial};
use std::path::{Path, PathBuf};
use std::sync::Arc;

pyo3::create_exception!(
    _native,
    ResoundError,
    PyException,
    "A Resound operation failed; the message is the CLI's."
);

/// The CLI's message for `e` (`error: …` without the prefix): the error and its causes.
/// A parameter out of range names its keyword (`speed_m_s: speed must be …`), as the CLI
/// names its flag.
fn err(e: impl Into<anyhow::Error>) -> PyErr {
    let e = e.into();
    match e.downcast_ref::<resound::Error>() {
        Some(resound::Error::Param { field, .. }) => {
            ResoundError::new_err(format!("{field}: {e:#}"))
        }
        _ => ResoundError::new_err(format!("{e:#}")),
    }
}

/// A library report as Python values (dicts, lists, floats): the document `--json` prints.
fn report<'py, T: serde::Serialize>(py: Python<'py>, v: &T) -> PyResult<Bound<'py, PyAny>> {
    pythonize::pythonize(py, v).map_err(|e| ResoundError::new_err(format!("report: {e}")))
}

/// The serde name of a unit enum value (`legacy_table1`, `rolling`): what the JSON says.
fn serde_name<T: serde::Serialize>(v: &T) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        _ => String::new(),
    }
}

fn checked(m: SoundMaterial) -> PyResult<SoundMaterial> {
    m.validate()
        .map_err(|e| ResoundError::new_err(format!("material {:?}: {e}", m.name)))?;
    Ok(m)
}

/// A material from a reference (library name, file, `preset:NAME`).
fn resolve(spec: &str, library: Option<&Path>) -> PyResult<SoundMaterial> {
    let lib = resound::material::read_library(library).map_err(err)?;
    resound::material::resolve_material(spec, Path::new("."), lib.as_ref()).map_err(err)
}

/// A material argument: a [`PyMaterial`], or a reference (str or path-like) to resolve.
fn material_arg(obj: &Bound<'_, PyAny>, library: Option<&Path>) -> PyResult<SoundMaterial> {
    if let Ok(m) = obj.cast::<PyMaterial>() {
        return Ok(m.get().inner.clone());
    }
    match obj.extract::<PathBuf>() {
        Ok(p) => resolve(&p.to_string_lossy(), library),
        Err(_) => Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "a material is a Material, a library name, a file or 'preset:NAME', not {}",
            obj.get_type().name()?
        ))),
    }
}

/// A sounding material (Ren 2013 §5): Rayleigh damping α (1/s) and β (s), γ = E/ρ (m²/s²),
/// the amplitude scale σ, and what its document carries (damping model, residual,
/// provenance). A value: equal when the documents are equal.
#[pyclass(frozen, eq, skip_from_py_object, module = "resound", name = "Material")]
#[derive(Clone, PartialEq)]
struct PyMaterial {
    inner: SoundMaterial,
    origin: String,
}

impl PyMaterial {
    fn new_from(inner: SoundMaterial, origin: &str) -> Self {
        Self {
            inner,
            origin: origin.to_string(),
        }
    }
}

#[pymethods]
impl PyMaterial {
    /// A Rayleigh material from its four parameters (checked as a material file is).
    #[new]
    fn py_new(name: &str, alpha: f64, beta: f64, gamma: f64, sigma: f64) -> PyResult<Self> {
        let m = SoundMaterial {
            name: name.to_string(),
            alpha,
            beta,
            gamma,
            sigma,
            damping_model: resound::core::DampingModel::default(),
            caughey: Vec::new(),
            mode_damping: Vec::new(),
            provenance: None,
            residual: None,
        };
        Ok(Self::new_from(checked(m)?, "document"))
    }

    /// A material by library name, file, built-in name or `preset:NAME`.
    #[staticmethod]
    #[pyo3(signature = (spec, library=None))]
    fn load(spec: PathBuf, library: Option<PathBuf>) -> PyResult<Self> {
        let m = resolve(&spec.to_string_lossy(), library.as_deref())?;
        Ok(Self::new_from(m, "document"))
    }

    /// A material from its document as a dict (what [`to_dict`] gives), checked.
    #[staticmethod]
    fn from_dict(doc: &Bound<'_, PyAny>) -> PyResult<Self> {
        let m: SoundMaterial = pythonize::depythonize(doc)
            .map_err(|e| ResoundError::new_err(format!("not a material: {e}")))?;
        Ok(Self::new_from(checked(m)?, "document"))
    }

    /// A material from its JSON document (what `resound materials export` writes), checked.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let m: SoundMaterial = serde_json::from_str(text)
            .map_err(|e| ResoundError::new_err(format!("not a material: {e}")))?;
        Ok(Self::new_from(checked(m)?, "document"))
    }

    /// The material's document as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        report(py, &self.inner)
    }

    /// The material's JSON document (what `resound materials export` writes).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner).map_err(err)
    }

    /// Name (the library key).
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Mass-proportional damping α, 1/s.
    #[getter]
    fn alpha(&self) -> f64 {
        self.inner.alpha
    }

    /// Stiffness-proportional damping β, s.
    #[getter]
    fn beta(&self) -> f64 {
        self.inner.beta
    }

    /// γ = E/ρ, m²/s².
    #[getter]
    fn gamma(&self) -> f64 {
        self.inner.gamma
    }

    /// Amplitude scale σ.
    #[getter]
    fn sigma(&self) -> f64 {
        self.inner.sigma
    }

    /// Where it was listed from (`builtin`, `library`, `estimated`, …; `document` otherwise).
    #[getter]
    fn origin(&self) -> &str {
        &self.origin
    }

    /// How it was obtained (a dict), or None for presets.
    #[getter]
    fn provenance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        report(py, &self.inner.provenance)
    }

    fn __repr__(&self) -> String {
        let m = &self.inner;
        format!(
            "Material({:?}, alpha={:.6e}, beta={:.6e}, gamma={:.6e}, sigma={:.6e})",
            m.name, m.alpha, m.beta, m.gamma, m.sigma
        )
    }
}

fn modes_array<'py>(py: Python<'py>, modes: &[DampedMode]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mut v = Vec::with_capacity(4 * modes.len());
    for m in modes {
        v.extend([m.freq_hz, m.damping_per_s, m.amplitude, m.phase_rad]);
    }
    Ok(Array2::from_shape_vec((modes.len(), 4), v)
        .map_err(err)?
        .into_pyarray(py))
}

fn modes_from(rows: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<DampedMode>> {
    let a = rows.as_array();
    if a.ncols() != 4 {
        return Err(ResoundError::new_err(format!(
            "modes must be shaped (n, 4): freq_hz, damping_per_s, amplitude, phase_rad; got {:?}",
            a.shape()
        )));
    }
    Ok(a.rows()
        .into_iter()
        .map(|r| DampedMode {
            freq_hz: r[0],
            damping_per_s: r[1],
            amplitude: r[2],
            phase_rad: r[3],
        })
        .collect())
}

fn analyze_params(
    strike: Option<usize>,
    max_modes: usize,
    min_db: f64,
) -> PyResult<resound::signal::AnalyzeParams> {
    Ok(resound::signal::AnalyzeParams {
        max_modes,
        min_db,
        strike: match strike {
            Some(0) => return Err(ResoundError::new_err("strike counts from 1")),
            s => s.map(|k| k - 1),
        },
        ..Default::default()
    })
}

/// Analyses a recording file: (modes (n, 4), report dict).
#[pyfunction]
#[pyo3(signature = (path, channel=None, strike=None, resample_hz=None, max_modes=64, min_db=60.0))]
fn analyze_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    channel: Option<usize>,
    strike: Option<usize>,
    resample_hz: Option<u32>,
    max_modes: usize,
    min_db: f64,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyAny>)> {
    let params = analyze_params(strike, max_modes, min_db)?;
    let rec = resound::recording::RecordingParams {
        channel,
        resample_hz,
    };
    let report = py.detach(|| {
        resound::recording::analyze_file(&path, &rec, &params)
            .map(|(r, a)| {
                resound::recording::AnalysisReport::new(&path.display().to_string(), &r.codec, &a)
            })
            .map_err(anyhow::Error::from)
    });
    let report = report.map_err(err)?;
    Ok((modes_array(py, &report.modes)?, crate::report(py, &report)?))
}

/// Analyses samples (float64, one channel, full scale 1): (modes (n, 4), report dict).
#[pyfunction]
#[pyo3(signature = (samples, sample_rate, strike=None, max_modes=64, min_db=60.0))]
fn analyze_array<'py>(
    py: Python<'py>,
    samples: PyReadonlyArray1<'py, f64>,
    sample_rate: f64,
    strike: Option<usize>,
    max_modes: usize,
    min_db: f64,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyAny>)> {
    let params = analyze_params(strike, max_modes, min_db)?;
    let x = samples.as_slice().map_err(err)?;
    let report = py
        .detach(|| {
            resound::recording::analyze_samples(x, sample_rate, &params)
                .map(|a| resound::recording::AnalysisReport::new("<array>", "array", &a))
        })
        .map_err(err)?;
    Ok((modes_array(py, &report.modes)?, crate::report(py, &report)?))
}

/// A modal model: frequencies and surface mode shapes of an object (Ren 2013 §3).
#[pyclass(frozen, module = "resound")]
struct ModalModel {
    inner: Arc<resound::core::ModalModel>,
    /// The file it came from (a material estimated on it names it, as the CLI's does).
    source: String,
}

fn object_params(
    scale: f64,
    modes: usize,
    reference_material: &str,
) -> PyResult<resound::object::ObjectParams> {
    let max = resound::core::limits::MAX_MODES;
    if modes == 0 || modes > max {
        return Err(ResoundError::new_err(format!(
            "modes must be within 1–{max}, got {modes}"
        )));
    }
    Ok(resound::object::ObjectParams {
        scale,
        modal: resound::modal::ModalParams {
            n_modes: Some(modes),
            ..Default::default()
        },
        reference_material: Material::parse(reference_material).map_err(err)?,
    })
}

#[pymethods]
impl ModalModel {
    /// Solves a mesh file (OBJ, STL, PLY, tet meshes) or loads a `.rmodal`.
    #[staticmethod]
    #[pyo3(signature = (path, scale=1.0, modes=60, reference_material="ceramic"))]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        scale: f64,
        modes: usize,
        reference_material: &str,
    ) -> PyResult<Self> {
        let params = object_params(scale, modes, reference_material)?;
        let m = py
            .detach(|| resound::object::load_object(&path, &params, &|_| {}))
            .map_err(err)?;
        Ok(Self {
            inner: Arc::new(m),
            source: path.display().to_string(),
        })
    }

    /// Solves a closed surface: vertices (n, 3) in m before `scale`, triangles (m, 3).
    #[staticmethod]
    #[pyo3(signature = (vertices, triangles, scale=1.0, modes=60, reference_material="ceramic"))]
    fn from_arrays(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray2<'_, u32>,
        scale: f64,
        modes: usize,
        reference_material: &str,
    ) -> PyResult<Self> {
        let params = object_params(scale, modes, reference_material)?;
        let (v, t) = (vertices.as_array(), triangles.as_array());
        if v.ncols() != 3 || t.ncols() != 3 {
            return Err(ResoundError::new_err(format!(
                "vertices must be (n, 3) and triangles (m, 3); got {:?} and {:?}",
                v.shape(),
                t.shape()
            )));
        }
        let vs: Vec<[f64; 3]> = v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
        let ts: Vec<[u32; 3]> = t.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
        let m = py
            .detach(|| resound::object::solve_surface(&vs, &ts, &params, &|_| {}))
            .map_err(err)?;
        Ok(Self {
            inner: Arc::new(m),
            source: String::new(),
        })
    }

    /// The model's figures and modes (with the gains at `hit`, m): the document
    /// `resound model FILE --json [--hit]` prints.
    #[pyo3(signature = (hit=None))]
    fn report<'py>(&self, py: Python<'py>, hit: Option<[f64; 3]>) -> PyResult<Bound<'py, PyAny>> {
        let h = hit.map(|h| self.inner.hit(h)).transpose().map_err(err)?;
        crate::report(
            py,
            &resound::object::ModalReport::new(&self.inner, None, h.as_ref()),
        )
    }

    /// Writes the model to a `.rmodal` file (atomically).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        resound::io::model_file::save(&path, &self.inner).map_err(err)
    }

    /// Number of modes.
    #[getter]
    fn n_modes(&self) -> usize {
        self.inner.n_modes()
    }

    /// Eigenvalues λ = ω² of the reference material, rad²/s².
    #[getter]
    fn eigenvalues<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.eigenvalues)
    }

    /// Surface vertices, m: (n, 3).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.inner.vertices.iter().flatten().copied().collect();
        Ok(Array2::from_shape_vec((self.inner.vertices.len(), 3), v)
            .map_err(err)?
            .into_pyarray(py))
    }

    /// Surface triangles: (m, 3).
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let t: Vec<u32> = self.inner.triangles.iter().flatten().copied().collect();
        Ok(Array2::from_shape_vec((self.inner.triangles.len(), 3), t)
            .map_err(err)?
            .into_pyarray(py))
    }

    /// The reference material of the solve (a dict: E, ν, ρ).
    #[getter]
    fn reference_material<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        report(py, &self.inner.material)
    }

    /// The undamped frequencies of an object of `material` (or the reference one), Hz.
    #[pyo3(signature = (material=None, library=None))]
    fn frequencies_hz<'py>(
        &self,
        py: Python<'py>,
        material: Option<&Bound<'py, PyAny>>,
        library: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let m = &self.inner;
        let gamma = match material {
            None => m.gamma0(),
            Some(s) => material_arg(s, library.as_deref())?.gamma,
        };
        Ok(PyArray1::from_vec(py, m.freqs_hz_at(gamma)))
    }

    /// Snaps `point` (m) to the surface: (surface point, distance m, gains per mode at it).
    fn hit<'py>(
        &self,
        py: Python<'py>,
        point: [f64; 3],
    ) -> PyResult<([f64; 3], f64, Bound<'py, PyArray1<f64>>)> {
        let h = self.inner.hit(point).map_err(err)?;
        Ok((h.at.point, h.at.distance, PyArray1::from_vec(py, h.gains)))
    }

    /// The damped modes of an object of `material` struck at `point` (m), per unit impulse
    /// (Ren eqs. 6–11): (n, 4) — Hz, 1/s, amplitude, rad; modes at or above `max_freq_hz` left
    /// out.
    #[pyo3(signature = (material, point, max_freq_hz=24000.0, library=None))]
    fn modes<'py>(
        &self,
        py: Python<'py>,
        material: &Bound<'py, PyAny>,
        point: [f64; 3],
        max_freq_hz: f64,
        library: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let sm = material_arg(material, library.as_deref())?;
        let m = &self.inner;
        let h = m.hit(point).map_err(err)?;
        let gamma0 = m.gamma0();
        modes_array(py, &sm.modes(&m.eigenvalues, &h.gains, gamma0, max_freq_hz))
    }

    fn __repr__(&self) -> String {
        format!(
            "ModalModel({} modes, {} surface vertices, {} FEM dofs)",
            self.inner.n_modes(),
            self.inner.n_vertices(),
            self.inner.fem_dofs
        )
    }
}

/// One material by reference (library name, file, built-in name, `preset:NAME`).
#[pyfunction]
#[pyo3(signature = (spec, library=None))]
fn get_material(spec: PathBuf, library: Option<PathBuf>) -> PyResult<PyMaterial> {
    PyMaterial::load(spec, library)
}

/// Every material (library first, then built-ins), each with its origin.
#[pyfunction]
#[pyo3(signature = (library=None))]
fn list_materials(library: Option<PathBuf>) -> PyResult<Vec<PyMaterial>> {
    let lib = resound::material::read_library(library.as_deref()).map_err(err)?;
    let all = resound::material::list_materials(lib.as_ref()).map_err(err)?;
    Ok(all
        .into_iter()
        .map(|(m, o)| PyMaterial::new_from(m, &serde_name(&o)))
        .collect())
}

/// Saves a material in the library under its name; refuses to replace one unless `replace`.
#[pyfunction]
#[pyo3(signature = (material, library=None, replace=false))]
fn save_material(material: &PyMaterial, library: Option<PathBuf>, replace: bool) -> PyResult<()> {
    resound::material::store_material(library.as_deref(), &material.inner, replace).map_err(|e| {
        match e {
            resound::Error::Exists(_) => {
                ResoundError::new_err(format!("{e}; pass replace=True to replace it"))
            }
            e => err(e),
        }
    })
}

/// Estimates a material from a recording (file, or float64 samples with `sample_rate`) of
/// `model` struck at `hit`: (material, report dict).
#[pyfunction]
#[pyo3(signature = (model, hit, path=None, samples=None, sample_rate=None, channel=None, strike=None, name="estimated", residual=true, allow_implausible=false, mic=None))]
fn estimate_material<'py>(
    py: Python<'py>,
    model: &ModalModel,
    hit: [f64; 3],
    path: Option<PathBuf>,
    samples: Option<PyReadonlyArray1<'_, f64>>,
    sample_rate: Option<f64>,
    channel: Option<usize>,
    strike: Option<usize>,
    name: &str,
    residual: bool,
    allow_implausible: bool,
    mic: Option<[f64; 3]>,
) -> PyResult<(PyMaterial, Bound<'py, PyAny>)> {
    let ap = analyze_params(strike, 64, 60.0)?;
    let h = model.inner.hit(hit).map_err(err)?;
    let params = resound::material::EstimateMaterialParams {
        name: name.to_string(),
        residual,
        allow_implausible,
        mic_m: mic,
        recording_name: path
            .as_ref()
            .map_or("<array>".into(), |p| p.display().to_string()),
        object_name: model.source.clone(),
        ..Default::default()
    };
    let slice = match &samples {
        Some(s) => Some(s.as_slice().map_err(err)?),
        None => None,
    };
    let m = &model.inner;
    let out = py.detach(|| -> anyhow::Result<_> {
        let analysis = match (&path, slice, sample_rate) {
            (Some(p), None, None) => {
                let rec = resound::recording::RecordingParams {
                    channel,
                    resample_hz: None,
                };
                resound::recording::analyze_file(p, &rec, &ap)?.1
            }
            (None, Some(x), Some(fs)) => resound::recording::analyze_samples(x, fs, &ap)?,
            _ => anyhow::bail!("give a path, or samples with sample_rate"),
        };
        Ok(resound::material::estimate_material(
            &analysis,
            m,
            &h,
            &params,
            &|| {},
        )?)
    });
    let (mat, info) = out.map_err(err)?;
    Ok((PyMaterial::new_from(mat, "estimated"), report(py, &info)?))
}

fn strike_params(
    speed_m_s: f64,
    duration_s: f64,
    sample_rate: u32,
    residual: bool,
    impactor_mass_kg: Option<f64>,
    impactor_radius_m: f64,
) -> resound::strike::StrikeParams {
    resound::strike::StrikeParams {
        speed_m_s,
        duration_s,
        sample_rate_hz: sample_rate,
        residual,
        impactor_mass_kg,
        impactor_radius_m,
        ..Default::default()
    }
}

/// Renders a strike of an object of `material` at `hit`: (samples float32, info dict).
#[pyfunction]
#[pyo3(signature = (material, model, hit, speed_m_s=1.0, duration_s=1.0, sample_rate=48000, residual=true, impactor_mass_kg=None, impactor_radius_m=0.005, library=None, mic=None))]
fn render_strike<'py>(
    py: Python<'py>,
    material: &Bound<'py, PyAny>,
    model: &ModalModel,
    hit: [f64; 3],
    speed_m_s: f64,
    duration_s: f64,
    sample_rate: u32,
    residual: bool,
    impactor_mass_kg: Option<f64>,
    impactor_radius_m: f64,
    library: Option<PathBuf>,
    mic: Option<[f64; 3]>,
) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyAny>)> {
    let mat = material_arg(material, library.as_deref())?;
    let h = model.inner.hit(hit).map_err(err)?;
    let mut p = strike_params(
        speed_m_s,
        duration_s,
        sample_rate,
        residual,
        impactor_mass_kg,
        impactor_radius_m,
    );
    p.mic_m = mic;
    let m = &model.inner;
    let s = py
        .detach(|| {
            resound::strike::render_strike(
                resound::strike::Struck::Object {
                    material: &mat,
                    model: m,
                    hit: &h,
                    same_object: false,
                },
                &p,
            )
        })
        .map_err(err)?;
    Ok((s.samples.into_pyarray(py), report(py, &s.info)?))
}

/// Renders analysed modes (n, 4) as recorded, for the reference impact.
#[pyfunction]
#[pyo3(signature = (modes, duration_s=1.0, sample_rate=48000))]
fn render_modes<'py>(
    py: Python<'py>,
    modes: PyReadonlyArray2<'py, f64>,
    duration_s: f64,
    sample_rate: u32,
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let ms = modes_from(&modes)?;
    let p = strike_params(1.0, duration_s, sample_rate, false, None, 0.005);
    let s = py
        .detach(|| resound::strike::render_strike(resound::strike::Struck::Modes(&ms), &p))
        .map_err(err)?;
    Ok(s.samples.into_pyarray(py))
}

/// Per-material mode statistics (Traer 2019): fitted by `resound stats fit`, or a PyImpact
/// table.
#[pyclass(frozen, module = "resound")]
struct ModeStatistics {
    inner: Arc<resound::stats::ModeStatistics>,
    name: String,
}

#[pymethods]
impl ModeStatistics {
    /// Reads statistics: a Resound statistics file, or a PyImpact material table (its name is
    /// the file's stem).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let name = path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let ours = match resound::files::load_stats(&path) {
            Ok(s) => {
                return Ok(Self {
                    inner: Arc::new(s),
                    name,
                })
            }
            Err(e) => e,
        };
        let text = std::fs::read_to_string(&path).map_err(err)?;
        match resound::stats::ModeStatistics::from_pyimpact_json(&name, &text) {
            Ok(s) => Ok(Self {
                inner: Arc::new(s),
                name,
            }),
            Err(theirs) => Err(ResoundError::new_err(format!(
                "{:#}; nor a PyImpact table: {theirs}",
                anyhow::Error::from(ours)
            ))),
        }
    }

    /// Parses a PyImpact material table given as JSON text.
    #[staticmethod]
    fn from_pyimpact_json(material: &str, text: &str) -> PyResult<Self> {
        let s = resound::stats::ModeStatistics::from_pyimpact_json(material, text).map_err(err)?;
        Ok(Self {
            inner: Arc::new(s),
            name: material.to_string(),
        })
    }

    /// The material's name.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// Modes per sampled impulse response.
    #[getter]
    fn modes(&self) -> usize {
        self.inner.modes
    }

    /// An impulse response sampled with `seed`: modes (n, 4).
    fn sample<'py>(&self, py: Python<'py>, seed: u64) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = self.inner.sample(seed).map_err(err)?;
        modes_array(py, &m)
    }

    /// Writes the statistics file (`resound stats fit`'s format), atomically.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        resound::files::write_json(&path, &*self.inner).map_err(err)
    }

    /// Fits statistics of `material` to recordings of it (the first strike of each, high-passed
    /// at `highpass_hz`): `modes` modes per impulse response plus the transient bands (Traer
    /// 2019 eq. 3).
    #[staticmethod]
    #[pyo3(signature = (recordings, material, modes=15, highpass_hz=None))]
    fn fit(
        py: Python<'_>,
        recordings: Vec<PathBuf>,
        material: &str,
        modes: usize,
        highpass_hz: Option<f64>,
    ) -> PyResult<Self> {
        let s = py
            .detach(|| {
                resound::files::fit_stats(&recordings, material, modes, highpass_hz, &|_, _| {})
            })
            .map_err(err)?;
        Ok(Self {
            inner: Arc::new(s),
            name: material.to_string(),
        })
    }

    /// Every PyImpact table (`<material>_<size>_mm.json`) in `dir`, by name (`<material>_<size>`).
    #[staticmethod]
    fn import_pyimpact(dir: PathBuf) -> PyResult<Vec<(String, Self)>> {
        Ok(resound::files::import_pyimpact(&dir)
            .map_err(err)?
            .into_iter()
            .map(|(name, s)| {
                (
                    name.clone(),
                    Self {
                        inner: Arc::new(s),
                        name,
                    },
                )
            })
            .collect())
    }

    /// The statistics as JSON (the statistics file's document).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&*self.inner).map_err(err)
    }

    /// The statistics as a dict (the statistics file's document).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        report(py, &*self.inner)
    }

    fn __repr__(&self) -> String {
        format!(
            "ModeStatistics({:?}, {} modes)",
            self.name, self.inner.modes
        )
    }
}

/// Renders one impact of an object drawn from `stats` with `seed` (the IR with seed, its
/// per-impact variation with seed + 1): samples float32.
#[pyfunction]
#[pyo3(signature = (stats, seed=0, speed_m_s=1.0, duration_s=1.0, sample_rate=44100, residual=false, impactor_mass_kg=None, impactor_radius_m=0.005))]
fn render_impact<'py>(
    py: Python<'py>,
    stats: &ModeStatistics,
    seed: u64,
    speed_m_s: f64,
    duration_s: f64,
    sample_rate: u32,
    residual: bool,
    impactor_mass_kg: Option<f64>,
    impactor_radius_m: f64,
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let p = strike_params(
        speed_m_s,
        duration_s,
        sample_rate,
        residual,
        impactor_mass_kg,
        impactor_radius_m,
    );
    let st = &stats.inner;
    let s = py
        .detach(|| {
            resound::strike::render_strike(resound::strike::Struck::Stats { stats: st, seed }, &p)
        })
        .map_err(err)?;
    Ok(s.samples.into_pyarray(py))
}

/// Renders a scene file: (audio (channels, samples) float32, sample rate, events (list of
/// dicts), summary dict).
#[pyfunction]
#[pyo3(signature = (path, library=None, keep_level=false))]
fn render_scene<'py>(
    py: Python<'py>,
    path: PathBuf,
    library: Option<PathBuf>,
    keep_level: bool,
) -> SceneOut<'py> {
    let params = resound::scene::SceneRenderParams {
        library,
        keep_level,
        ..Default::default()
    };
    let r = py
        .detach(|| resound::scene::render_scene(&path, &params, &|_| {}, &|_| {}))
        .map_err(err)?;
    scene_out(py, r)
}

/// Renders a scrape (Traer 2019 §4) of an object with `modes` (n, 4, per unit impulse) along
/// a constant-speed path or a trajectory (n, 2: time s, position m): samples float32 (not
/// normalized) and the length scraped, m.
#[pyfunction]
#[pyo3(signature = (modes, speed_m_s=None, trajectory=None, duration_s=2.0, surface="fractal", roughness_m=5e-6, surface_spacing_m=1e-5, probe_mass_kg=0.01, friction=100.0, gamma=1.0, tip_width_m=2e-4, irs=8, seed=1, sample_rate=48000))]
fn render_scrape<'py>(
    py: Python<'py>,
    modes: PyReadonlyArray2<'py, f64>,
    speed_m_s: Option<f64>,
    trajectory: Option<PyReadonlyArray2<'py, f64>>,
    duration_s: f64,
    surface: &str,
    roughness_m: f64,
    surface_spacing_m: f64,
    probe_mass_kg: f64,
    friction: f64,
    gamma: f64,
    tip_width_m: f64,
    irs: usize,
    seed: u64,
    sample_rate: u32,
) -> PyResult<(Bound<'py, PyArray1<f32>>, f64)> {
    use resound::scrape::{render_scrape, Path1d, ScrapeJob, SurfaceSpec};
    let path = match (speed_m_s, trajectory) {
        (Some(v), None) => Path1d::Speed(v),
        (None, Some(t)) => {
            let t = t.as_array();
            if t.ncols() != 2 || t.nrows() < 2 {
                return Err(ResoundError::new_err(format!(
                    "a trajectory is shaped (n ≥ 2, 2): time s, position m; got {:?}",
                    t.shape()
                )));
            }
            let pts: Vec<(f64, f64)> = t.rows().into_iter().map(|r| (r[0], r[1])).collect();
            if pts.iter().any(|p| !(p.0.is_finite() && p.1.is_finite()))
                || pts.windows(2).any(|w| w[1].0 <= w[0].0)
            {
                return Err(ResoundError::new_err(
                    "trajectory times must increase and every value be finite",
                ));
            }
            Path1d::Trajectory(pts)
        }
        _ => {
            return Err(ResoundError::new_err(
                "give the probe's path: speed_m_s or trajectory (not both)",
            ))
        }
    };
    let surface = if surface == "fractal" {
        SurfaceSpec::Fractal { roughness_m }
    } else {
        SurfaceSpec::Profile(PathBuf::from(surface))
    };
    let job = ScrapeJob {
        modes: modes_from(&modes)?,
        surface,
        surface_spacing_m,
        path,
        params: resound::synth::scrape::ScrapeParams {
            probe_mass_kg,
            friction,
            gamma,
            tip_width_m,
        },
        irs,
        seed,
        duration_s,
        sample_rate_hz: sample_rate,
    };
    let (x, path_m) = py.detach(|| render_scrape(&job)).map_err(err)?;
    Ok((x.into_pyarray(py), path_m))
}

fn kind_rule(kind: &str) -> PyResult<resound::grain_files::KindRule> {
    resound::grain_files::parse_kind(kind).ok_or_else(|| {
        ResoundError::new_err(format!(
            "unknown contact kind {kind:?} (auto, impact, rolling, sliding, continuous)"
        ))
    })
}

fn grain_params(
    min_db: f64,
    peaks: Option<usize>,
    min_corr: f64,
) -> resound::grains::AnalyzeParams {
    let mut params = resound::grains::AnalyzeParams::default();
    params.segment.min_db = min_db;
    params.pattern.peaks_per_part = peaks;
    params.pattern.min_corr = min_corr;
    params
}

/// Cuts recordings into grains and correlation patterns (Picard 2009) and saves the
/// dictionary to `output`: its figures (a dict). `recordings` are file paths (a `kind:` prefix
/// sets one's kind), or, with `arrays`, names of the mono float32 `arrays` at `sample_rate`.
#[pyfunction]
#[pyo3(signature = (recordings, output, arrays=None, sample_rate=None, kind="auto", kinds=None, min_db=-50.0, peaks=None, min_corr=0.5, prune=None), text_signature = "(recordings, output, arrays=None, sample_rate=None, kind='auto', kinds=None, min_db=-50.0, peaks=None, min_corr=0.5, prune=None)")]
fn grains_analyze<'py>(
    py: Python<'py>,
    recordings: Vec<String>,
    output: PathBuf,
    arrays: Option<Vec<PyReadonlyArray1<'_, f32>>>,
    sample_rate: Option<f64>,
    kind: &str,
    kinds: Option<Vec<String>>,
    min_db: f64,
    peaks: Option<usize>,
    min_corr: f64,
    prune: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    use resound::grain_files::{analyze_to_file, load_recordings, recording_from_samples};
    let rule = kind_rule(kind)?;
    let (recs, fs) = match arrays {
        None => {
            // A rate beyond u32 saturates and is refused by the range check.
            let rate = sample_rate.map(|r| {
                if r.is_finite() && r > 0.0 {
                    r.round() as u32
                } else {
                    0
                }
            });
            let (r, fs, _) = py
                .detach(|| load_recordings(&recordings, rule, rate))
                .map_err(err)?;
            (r, fs)
        }
        Some(arrays) => {
            let Some(fs) = sample_rate else {
                return Err(ResoundError::new_err("arrays need sample_rate="));
            };
            if arrays.len() != recordings.len() {
                return Err(ResoundError::new_err(format!(
                    "{} names for {} arrays",
                    recordings.len(),
                    arrays.len()
                )));
            }
            let mut total_s = 0.0;
            let mut out = Vec::with_capacity(arrays.len());
            for (k, (name, a)) in recordings.iter().zip(&arrays).enumerate() {
                let r = match kinds.as_ref().and_then(|ks| ks.get(k)) {
                    Some(kk) => kind_rule(kk)?,
                    None => rule,
                };
                let samples = a.as_array().iter().copied().collect::<Vec<f32>>();
                total_s += samples.len() as f64 / fs;
                let rec = recording_from_samples(name.clone(), samples, fs, r).map_err(|e| {
                    ResoundError::new_err(format!("{name}: {:#}", anyhow::Error::from(e)))
                })?;
                out.push(rec);
            }
            if total_s > resound::grain_files::MAX_TOTAL_S {
                return Err(ResoundError::new_err(format!(
                    "the recordings add up to more than {:.0} s; analyse them in groups",
                    resound::grain_files::MAX_TOTAL_S
                )));
            }
            (out, fs)
        }
    };
    let params = grain_params(min_db, peaks, min_corr);
    let made = py
        .detach(|| analyze_to_file(&recs, fs, &params, prune, &output, &|_, _| {}))
        .map_err(err)?;
    report(py, &made)
}

/// A recording of a dictionary, by index or name.
#[derive(FromPyObject)]
enum RecordingRef {
    Index(usize),
    Name(String),
}

/// A grain dictionary (`resound grains analyze`): grains and correlation patterns of
/// recordings (Picard 2009).
#[pyclass(frozen, module = "resound")]
struct GrainDictionary {
    inner: Arc<resound::grains::Dictionary>,
}

#[pymethods]
impl GrainDictionary {
    /// Reads a `.grains` file.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let d = resound::io::grains_file::load(&path).map_err(err)?;
        Ok(Self { inner: Arc::new(d) })
    }

    /// Sample rate of the grains, Hz.
    #[getter]
    fn sample_rate(&self) -> f64 {
        self.inner.sample_rate_hz
    }

    /// The recordings: (name, contact kind, samples).
    #[getter]
    fn recordings(&self) -> Vec<(String, String, u32)> {
        self.inner
            .recordings
            .iter()
            .map(|r| (r.name.clone(), serde_name(&r.contact), r.samples))
            .collect()
    }

    /// The dictionary's figures (grains, sizes, compression): a dict.
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        report(
            py,
            &resound::grain_files::summary(&self.inner, None).map_err(err)?,
        )
    }

    /// Rebuilds recording `recording` (index or name), time-scaled by `time_scale` and varied
    /// by `variation` (0–1) with `seed`: float32 samples at the dictionary's rate, at the
    /// recording's level.
    #[pyo3(signature = (recording, time_scale=1.0, variation=0.0, seed=1))]
    fn resynthesize<'py>(
        &self,
        py: Python<'py>,
        recording: RecordingRef,
        time_scale: f64,
        variation: f64,
        seed: u64,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let spec = match recording {
            RecordingRef::Index(k) => k.to_string(),
            RecordingRef::Name(s) => s,
        };
        let k = resound::grain_files::recording_index(&self.inner, &spec).map_err(err)?;
        let p = resound::grains::resynth::ResynthParams {
            time_scale,
            variation,
            seed,
        };
        let d = &self.inner;
        let y = py
            .detach(|| resound::grains::resynth::resynthesize(d, k, &p))
            .map_err(err)?;
        Ok(y.into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "GrainDictionary({} recordings, {} Hz)",
            self.inner.recordings.len(),
            self.inner.sample_rate_hz
        )
    }
}

/// Renders a scene given as a dict of the scene file's fields (relative paths from
/// `base_dir`), deserialized straight into the scene file's types and checked by its rules:
/// as [`render_scene`].
#[pyfunction]
#[pyo3(signature = (scene, base_dir, library=None, keep_level=false))]
fn render_scene_dict<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    base_dir: PathBuf,
    library: Option<PathBuf>,
    keep_level: bool,
) -> SceneOut<'py> {
    let scene: resound::io::scene::SceneFile =
        pythonize::depythonize(scene).map_err(|e| ResoundError::new_err(format!("scene: {e}")))?;
    let params = resound::scene::SceneRenderParams {
        library,
        keep_level,
        ..Default::default()
    };
    let r = py
        .detach(|| {
            resound::scene::render_scene_value(scene, "scene", &base_dir, &params, &|_| {}, &|_| {})
        })
        .map_err(err)?;
    scene_out(py, r)
}

/// Audio (channels, samples), sample rate, events, summary.
type SceneOut<'py> = PyResult<(
    Bound<'py, PyArray2<f32>>,
    u32,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
)>;

fn scene_out<'py>(py: Python<'py>, r: resound::scene::SceneRender) -> SceneOut<'py> {
    let n = r.channels.first().map_or(0, Vec::len);
    let flat: Vec<f32> = r.channels.iter().flatten().copied().collect();
    let audio = Array2::from_shape_vec((r.channels.len(), n), flat)
        .map_err(err)?
        .into_pyarray(py);
    Ok((
        audio,
        r.sample_rate_hz,
        report(py, &r.events)?,
        report(py, &r.summary)?,
    ))
}

/// Runs shard `shard` of `shards` of a jobs file (`resound batch`): the run's figures (a dict).
#[pyfunction]
#[pyo3(signature = (jobs, out, shard=0, shards=1, library=None, cache=None))]
fn batch<'py>(
    py: Python<'py>,
    jobs: PathBuf,
    out: PathBuf,
    shard: usize,
    shards: usize,
    library: Option<PathBuf>,
    cache: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let params = resound::batch::BatchParams {
        out_dir: out,
        shard: (shard, shards),
        library,
        cache_dir: cache,
    };
    let info = py
        .detach(|| resound::batch::run_batch(&jobs, &params, &|_| {}))
        .map_err(err)?;
    report(py, &info)
}

/// The version of the Rust library.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ResoundError", m.py().get_type::<ResoundError>())?;
    m.add_class::<ModalModel>()?;
    m.add_class::<ModeStatistics>()?;
    m.add_function(wrap_pyfunction!(analyze_file, m)?)?;
    m.add_function(wrap_pyfunction!(analyze_array, m)?)?;
    m.add_function(wrap_pyfunction!(get_material, m)?)?;
    m.add_function(wrap_pyfunction!(list_materials, m)?)?;
    m.add_function(wrap_pyfunction!(save_material, m)?)?;
    m.add_function(wrap_pyfunction!(estimate_material, m)?)?;
    m.add_function(wrap_pyfunction!(render_strike, m)?)?;
    m.add_function(wrap_pyfunction!(render_modes, m)?)?;
    m.add_function(wrap_pyfunction!(render_impact, m)?)?;
    m.add_function(wrap_pyfunction!(render_scene, m)?)?;
    m.add_function(wrap_pyfunction!(batch, m)?)?;
    m.add_function(wrap_pyfunction!(render_scrape, m)?)?;
    m.add_function(wrap_pyfunction!(grains_analyze, m)?)?;
    m.add_function(wrap_pyfunction!(render_scene_dict, m)?)?;
    m.add_class::<PyMaterial>()?;
    m.add_class::<GrainDictionary>()?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
