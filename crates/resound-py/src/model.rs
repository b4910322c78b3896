//! `ModalModel`: a solved or loaded modal model, its report and modes.

use super::*;

/// A modal model: frequencies and surface mode shapes of an object (Ren 2013 §3).
#[pyclass(frozen, module = "resound")]
pub(crate) struct ModalModel {
    pub(crate) inner: Arc<resound::core::ModalModel>,
    /// The file it came from (a material estimated on it names it, as the CLI's does).
    pub(crate) source: String,
}

pub(crate) fn object_params(
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
