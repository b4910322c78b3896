//! Grain dictionaries (Picard 2009): analysis and resynthesis.

use super::*;

pub(crate) fn kind_rule(kind: &str) -> PyResult<resound::grain_files::KindRule> {
    resound::grain_files::parse_kind(kind).ok_or_else(|| {
        ResoundError::new_err(format!(
            "unknown contact kind {kind:?} (auto, impact, rolling, sliding, continuous)"
        ))
    })
}

pub(crate) fn grain_params(
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
pub(crate) fn grains_analyze<'py>(
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
        .detach(|| analyze_to_file(&recs, fs, &params, prune, &output, &|_| {}))
        .map_err(err)?;
    report(py, &made)
}

/// A recording of a dictionary, by index or name.
#[derive(FromPyObject)]
pub(crate) enum RecordingRef {
    Index(usize),
    Name(String),
}

/// A grain dictionary (`resound grains analyze`): grains and correlation patterns of
/// recordings (Picard 2009).
#[pyclass(frozen, module = "resound")]
pub(crate) struct GrainDictionary {
    pub(crate) inner: Arc<resound::grains::Dictionary>,
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
        let p = resound::grains::resynth::ResynthParams {
            time_scale,
            variation,
            seed,
        };
        let d = &self.inner;
        let y = py
            .detach(|| resound::grain_files::resynthesize_recording(d, &spec, &p))
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
