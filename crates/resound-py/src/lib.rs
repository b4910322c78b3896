//! The native half of the `resound` Python package (`resound._native`).
//!
//! Thin like the CLI: each function converts arguments, releases the GIL, calls one library
//! function and converts the result. Shapes, dtypes and keyword conventions (`sample_rate`,
//! float32 `(channels, samples)`) are settled in the Python half (`python/resound/`), so this
//! side takes contiguous float64 arrays and returns float32 audio. Reports cross as JSON text
//! (the very documents the CLI's `--json` prints), decoded in Python.

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
fn err(e: impl Into<anyhow::Error>) -> PyErr {
    ResoundError::new_err(format!("{:#}", e.into()))
}

fn json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string(v).map_err(err)
}

/// A material from a reference (library name, file, `preset:NAME`) or its JSON document.
fn material(spec: &str, library: Option<&Path>) -> PyResult<SoundMaterial> {
    if spec.trim_start().starts_with('{') {
        let m: SoundMaterial = serde_json::from_str(spec)
            .map_err(|e| ResoundError::new_err(format!("not a material: {e}")))?;
        m.validate()
            .map_err(|e| ResoundError::new_err(format!("material {:?}: {e}", m.name)))?;
        return Ok(m);
    }
    let lib = resound::material::read_library(library).map_err(err)?;
    resound::material::resolve_material(spec, Path::new("."), lib.as_ref()).map_err(err)
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

/// Analyses a recording file: (modes (n, 4), report JSON).
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
) -> PyResult<(Bound<'py, PyArray2<f64>>, String)> {
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
    Ok((modes_array(py, &report.modes)?, json(&report)?))
}

/// Analyses samples (float64, one channel, full scale 1): (modes (n, 4), report JSON).
#[pyfunction]
#[pyo3(signature = (samples, sample_rate, strike=None, max_modes=64, min_db=60.0))]
fn analyze_array<'py>(
    py: Python<'py>,
    samples: PyReadonlyArray1<'py, f64>,
    sample_rate: f64,
    strike: Option<usize>,
    max_modes: usize,
    min_db: f64,
) -> PyResult<(Bound<'py, PyArray2<f64>>, String)> {
    let params = analyze_params(strike, max_modes, min_db)?;
    let x = samples.as_slice().map_err(err)?;
    let report = py
        .detach(|| {
            resound::recording::analyze_samples(x, sample_rate, &params)
                .map(|a| resound::recording::AnalysisReport::new("<array>", "array", &a))
        })
        .map_err(err)?;
    Ok((modes_array(py, &report.modes)?, json(&report)?))
}

/// A modal model: frequencies and surface mode shapes of an object (Ren 2013 §3).
#[pyclass(frozen, module = "resound")]
struct ModalModel {
    inner: Arc<resound::core::ModalModel>,
}

fn object_params(
    scale: f64,
    modes: usize,
    reference_material: &str,
) -> PyResult<resound::object::ObjectParams> {
    if modes == 0 || modes > 2000 {
        return Err(ResoundError::new_err(format!(
            "modes must be within 1–2000, got {modes}"
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
        Ok(Self { inner: Arc::new(m) })
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
        Ok(Self { inner: Arc::new(m) })
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

    /// The reference material of the solve (JSON: E, ν, ρ).
    #[getter]
    fn reference_material(&self) -> PyResult<String> {
        json(&self.inner.material)
    }

    /// The undamped frequencies of an object of `material` (or the reference one), Hz.
    #[pyo3(signature = (material=None, library=None))]
    fn frequencies_hz<'py>(
        &self,
        py: Python<'py>,
        material: Option<&str>,
        library: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let m = &self.inner;
        let ratio = match material {
            None => 1.0,
            Some(s) => {
                let sm = crate::material(s, library.as_deref())?;
                sm.gamma / (m.material.youngs_modulus / m.material.density)
            }
        };
        let f: Vec<f64> = m
            .eigenvalues
            .iter()
            .map(|&l| (l * ratio).max(0.0).sqrt() / std::f64::consts::TAU)
            .collect();
        Ok(PyArray1::from_vec(py, f))
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

    fn __repr__(&self) -> String {
        format!(
            "ModalModel({} modes, {} surface vertices, {} FEM dofs)",
            self.inner.n_modes(),
            self.inner.n_vertices(),
            self.inner.fem_dofs
        )
    }
}

/// One material as JSON.
#[pyfunction]
#[pyo3(signature = (spec, library=None))]
fn get_material(spec: &str, library: Option<PathBuf>) -> PyResult<String> {
    json(&material(spec, library.as_deref())?)
}

/// Every material (library first, then built-ins) as JSON: [[material, origin], …].
#[pyfunction]
#[pyo3(signature = (library=None))]
fn list_materials(library: Option<PathBuf>) -> PyResult<String> {
    let lib = resound::material::read_library(library.as_deref()).map_err(err)?;
    let all = resound::material::list_materials(lib.as_ref()).map_err(err)?;
    let rows: Vec<(SoundMaterial, String)> = all
        .into_iter()
        .map(|(m, o)| (m, format!("{o:?}").to_lowercase()))
        .collect();
    json(&rows)
}

/// Saves a material (JSON) in the library under its name; refuses to replace one unless
/// `replace`.
#[pyfunction]
#[pyo3(signature = (material_json, library=None, replace=false))]
fn save_material(material_json: &str, library: Option<PathBuf>, replace: bool) -> PyResult<()> {
    let m = material(material_json, None)?;
    let mut lib = resound::material::open_library(library.as_deref()).map_err(err)?;
    if !replace && lib.get(&m.name).map_err(err)?.is_some() {
        return Err(ResoundError::new_err(format!(
            "the library already has a material {:?}; pass replace=True to replace it",
            m.name
        )));
    }
    lib.put(&m).map_err(err)
}

/// Estimates a material from a recording (file, or float64 samples with `sample_rate`) of
/// `model` struck at `hit`: (material JSON, report JSON).
#[pyfunction]
#[pyo3(signature = (model, hit, path=None, samples=None, sample_rate=None, channel=None, strike=None, name="estimated", residual=true, allow_implausible=false))]
fn estimate_material(
    py: Python<'_>,
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
) -> PyResult<(String, String)> {
    let ap = analyze_params(strike, 64, 60.0)?;
    let h = model.inner.hit(hit).map_err(err)?;
    let params = resound::material::EstimateMaterialParams {
        name: name.to_string(),
        residual,
        allow_implausible,
        recording_name: path
            .as_ref()
            .map_or("<array>".into(), |p| p.display().to_string()),
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
    Ok((json(&mat)?, json(&info)?))
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

/// Renders a strike of an object of `material` at `hit`: (samples float32, info JSON).
#[pyfunction]
#[pyo3(signature = (material, model, hit, speed_m_s=1.0, duration_s=1.0, sample_rate=48000, residual=true, impactor_mass_kg=None, impactor_radius_m=0.005, library=None))]
fn render_strike<'py>(
    py: Python<'py>,
    material: &str,
    model: &ModalModel,
    hit: [f64; 3],
    speed_m_s: f64,
    duration_s: f64,
    sample_rate: u32,
    residual: bool,
    impactor_mass_kg: Option<f64>,
    impactor_radius_m: f64,
    library: Option<PathBuf>,
) -> PyResult<(Bound<'py, PyArray1<f32>>, String)> {
    let mat = crate::material(material, library.as_deref())?;
    let h = model.inner.hit(hit).map_err(err)?;
    let p = strike_params(
        speed_m_s,
        duration_s,
        sample_rate,
        residual,
        impactor_mass_kg,
        impactor_radius_m,
    );
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
    Ok((s.samples.into_pyarray(py), json(&s.info)?))
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

    /// The statistics as JSON.
    fn to_json(&self) -> PyResult<String> {
        json(&*self.inner)
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

/// Renders a scene file: (audio (channels, samples) float32, sample rate, events JSON,
/// summary JSON).
#[pyfunction]
#[pyo3(signature = (path, library=None, keep_level=false))]
fn render_scene<'py>(
    py: Python<'py>,
    path: PathBuf,
    library: Option<PathBuf>,
    keep_level: bool,
) -> PyResult<(Bound<'py, PyArray2<f32>>, u32, String, String)> {
    let params = resound::scene::SceneRenderParams {
        library,
        keep_level,
        ..Default::default()
    };
    let r = py
        .detach(|| resound::scene::render_scene(&path, &params, &|_| {}, &|_| {}))
        .map_err(err)?;
    let n = r.channels.first().map_or(0, Vec::len);
    let flat: Vec<f32> = r.channels.iter().flatten().copied().collect();
    let audio = Array2::from_shape_vec((r.channels.len(), n), flat)
        .map_err(err)?
        .into_pyarray(py);
    Ok((audio, r.sample_rate_hz, json(&r.events)?, json(&r.summary)?))
}

/// Runs shard `shard` of `shards` of a jobs file (`resound batch`): the run's figures as JSON.
#[pyfunction]
#[pyo3(signature = (jobs, out, shard=0, shards=1, library=None, cache=None))]
fn batch(
    py: Python<'_>,
    jobs: PathBuf,
    out: PathBuf,
    shard: usize,
    shards: usize,
    library: Option<PathBuf>,
    cache: Option<PathBuf>,
) -> PyResult<String> {
    let params = resound::batch::BatchParams {
        out_dir: out,
        shard: (shard, shards),
        library,
        cache_dir: cache,
    };
    let info = py
        .detach(|| resound::batch::run_batch(&jobs, &params, &|_| {}))
        .map_err(err)?;
    json(&info)
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
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
