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

mod grains;
mod material;
mod model;
mod stats;

use grains::*;
use material::*;
use model::*;
use stats::*;

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
    // The library names no setting; the advice for each of its error variants is given here
    // in keywords, as the CLI gives it in flags.
    match e.downcast_ref::<resound::Error>().map(resound::Error::root) {
        Some(resound::Error::Param { field, .. }) => {
            ResoundError::new_err(format!("{field}: {e:#}"))
        }
        Some(resound::Error::Exists(_)) => {
            ResoundError::new_err(format!("{e:#}; pass replace=True to replace it"))
        }
        Some(resound::Error::Implausible(..)) => {
            ResoundError::new_err(format!("{e:#}; keep it anyway with allow_implausible=True"))
        }
        Some(r) if r.is_too_many_modes() => ResoundError::new_err(format!(
            "{e:#}; if the file is not in metres pass scale=0.001 (millimetres), else ask \
             for fewer modes"
        )),
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
    highpass_hz: Option<f64>,
) -> PyResult<resound::signal::AnalyzeParams> {
    Ok(resound::signal::AnalyzeParams {
        max_modes,
        min_db,
        highpass_hz,
        strike: resound::recording::index_from_1("strike", strike).map_err(err)?,
        ..Default::default()
    })
}

/// Analyses a recording file: (modes (n, 4), report dict).
#[pyfunction]
#[pyo3(signature = (path, channel=None, strike=None, resample_hz=None, max_modes=64, min_db=60.0, highpass_hz=None))]
fn analyze_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    channel: Option<usize>,
    strike: Option<usize>,
    resample_hz: Option<u32>,
    max_modes: usize,
    min_db: f64,
    highpass_hz: Option<f64>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyAny>)> {
    let params = analyze_params(strike, max_modes, min_db, highpass_hz)?;
    let rec = resound::recording::RecordingParams {
        channel: resound::recording::index_from_1("channel", channel).map_err(err)?,
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

/// Fits one set of poles shared by the takes of several files (their channels and strikes with
/// `every_channel` / `every_strike`): the joint report dict (`analyze --joint --json`).
#[pyfunction]
#[pyo3(signature = (paths, channel=None, strike=None, every_channel=false, every_strike=false, resample_hz=None, max_modes=64, min_db=60.0, highpass_hz=None))]
#[allow(clippy::too_many_arguments)]
fn analyze_joint<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    channel: Option<usize>,
    strike: Option<usize>,
    every_channel: bool,
    every_strike: bool,
    resample_hz: Option<u32>,
    max_modes: usize,
    min_db: f64,
    highpass_hz: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let params = analyze_params(strike, max_modes, min_db, highpass_hz)?;
    let rec = resound::recording::RecordingParams {
        channel: resound::recording::index_from_1("channel", channel).map_err(err)?,
        resample_hz,
    };
    let select = resound::recording::TakeSelection {
        every_strike,
        every_channel,
    };
    let report = py
        .detach(|| {
            resound::joint::analyze_joint(
                &paths,
                &rec,
                &params,
                select,
                &Default::default(),
                &|_| {},
            )
            .map(|(r, _)| r)
        })
        .map_err(err)?;
    crate::report(py, &report)
}

/// Analyses samples (float64, one channel, full scale 1): (modes (n, 4), report dict).
#[pyfunction]
#[pyo3(signature = (samples, sample_rate, strike=None, max_modes=64, min_db=60.0, highpass_hz=None))]
fn analyze_array<'py>(
    py: Python<'py>,
    samples: PyReadonlyArray1<'py, f64>,
    sample_rate: f64,
    strike: Option<usize>,
    max_modes: usize,
    min_db: f64,
    highpass_hz: Option<f64>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyAny>)> {
    let params = analyze_params(strike, max_modes, min_db, highpass_hz)?;
    let x = samples.as_slice().map_err(err)?;
    let report = py
        .detach(|| {
            resound::recording::analyze_samples(x, sample_rate, &params)
                .map(|a| resound::recording::AnalysisReport::new("<array>", "array", &a))
        })
        .map_err(err)?;
    Ok((modes_array(py, &report.modes)?, crate::report(py, &report)?))
}

/// Estimates a material from a recording (file, or float64 samples with `sample_rate`) of
/// `model` struck at `hit`: (material, report dict).
#[pyfunction]
#[pyo3(signature = (model, hit, path=None, samples=None, sample_rate=None, channel=None, strike=None, name="estimated", residual=true, allow_implausible=false, mic=None, highpass_hz=None))]
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
    highpass_hz: Option<f64>,
) -> PyResult<(PyMaterial, Bound<'py, PyAny>)> {
    let ap = analyze_params(strike, 64, 60.0, highpass_hz)?;
    let params = resound::material::EstimateMaterialParams {
        name: name.to_string(),
        residual,
        allow_implausible,
        mic_m: mic,
        object_name: model.source.clone(),
        ..Default::default()
    };
    let slice = match &samples {
        Some(s) => Some(s.as_slice().map_err(err)?),
        None => None,
    };
    let m = &model.inner;
    let out = py.detach(|| -> anyhow::Result<_> {
        let take = match (&path, slice, sample_rate) {
            (Some(p), None, None) => {
                let rec = resound::recording::RecordingParams {
                    channel: resound::recording::index_from_1("channel", channel)?,
                    resample_hz: None,
                };
                resound::recording::AnalysedTake {
                    label: p.display().to_string(),
                    analysis: resound::recording::analyze_file(p, &rec, &ap)?.1,
                }
            }
            (None, Some(x), Some(fs)) => resound::recording::AnalysedTake {
                label: "<array>".into(),
                analysis: resound::recording::analyze_samples(x, fs, &ap)?,
            },
            _ => anyhow::bail!("give a path, or samples with sample_rate"),
        };
        let o =
            resound::material::estimate_on_model(vec![take], (**m).clone(), hit, &params, &|_| {})?;
        Ok((o.material, o.info))
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
    let mut s = py
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
    resound::strike::warn_if_faint(&mut s);
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
        .detach(|| resound::scene::render_scene(&path, &params, &|_| {}))
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
) -> PyResult<(Bound<'py, PyArray1<f32>>, f64, Bound<'py, PyAny>)> {
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
    let r = py.detach(|| render_scrape(&job)).map_err(err)?;
    let info = report(py, &r.info)?;
    Ok((r.samples.into_pyarray(py), r.info.path_m, info))
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
        .detach(|| resound::scene::render_scene_value(scene, "scene", &base_dir, &params, &|_| {}))
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
    m.add_function(wrap_pyfunction!(analyze_joint, m)?)?;
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
