//! `ModeStatistics` (Traer 2019) and impacts drawn from them.

use super::*;

/// Per-material mode statistics (Traer 2019): fitted by `resound stats fit`, or a PyImpact
/// table.
#[pyclass(frozen, module = "resound")]
pub(crate) struct ModeStatistics {
    pub(crate) inner: Arc<resound::stats::ModeStatistics>,
    pub(crate) name: String,
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
                resound::files::fit_stats(&recordings, material, modes, highpass_hz, &|_| {})
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
pub(crate) fn render_impact<'py>(
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
