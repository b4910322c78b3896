//! Materials as Python values: the `Material` class over `SoundMaterial`, and the library.

use super::*;

pub(crate) fn checked(m: SoundMaterial) -> PyResult<SoundMaterial> {
    m.validate()
        .map_err(|e| ResoundError::new_err(format!("material {:?}: {e}", m.name)))?;
    Ok(m)
}

/// A material from a reference (library name, file, `preset:NAME`).
pub(crate) fn resolve(spec: &str, library: Option<&Path>) -> PyResult<SoundMaterial> {
    let lib = resound::material::read_library(library).map_err(err)?;
    resound::material::resolve_material(spec, Path::new("."), lib.as_ref()).map_err(err)
}

/// A material argument: a [`PyMaterial`], or a reference (str or path-like) to resolve.
pub(crate) fn material_arg(
    obj: &Bound<'_, PyAny>,
    library: Option<&Path>,
) -> PyResult<SoundMaterial> {
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
pub(crate) struct PyMaterial {
    pub(crate) inner: SoundMaterial,
    pub(crate) origin: String,
}

impl PyMaterial {
    pub(crate) fn new_from(inner: SoundMaterial, origin: &str) -> Self {
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

/// One material by reference (library name, file, built-in name, `preset:NAME`).
#[pyfunction]
#[pyo3(signature = (spec, library=None))]
pub(crate) fn get_material(spec: PathBuf, library: Option<PathBuf>) -> PyResult<PyMaterial> {
    PyMaterial::load(spec, library)
}

/// Every material (library first, then built-ins), each with its origin.
#[pyfunction]
#[pyo3(signature = (library=None))]
pub(crate) fn list_materials(library: Option<PathBuf>) -> PyResult<Vec<PyMaterial>> {
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
pub(crate) fn save_material(
    material: &PyMaterial,
    library: Option<PathBuf>,
    replace: bool,
) -> PyResult<()> {
    resound::material::store_material(library.as_deref(), &material.inner, replace).map_err(err)
}
