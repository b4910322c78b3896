//! The facade's error: every stage's error, plus what the pipeline itself checks.

/// Why a pipeline step failed. Each variant keeps the stage's own error (with its numbers);
/// [`Error::In`] adds which file or step it happened in.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file.
    #[error(transparent)]
    Io(#[from] resound_io::IoError),
    /// A scene file.
    #[error(transparent)]
    SceneFile(#[from] resound_io::scene::SceneFileError),
    /// A material's constants.
    #[error(transparent)]
    Material(#[from] resound_core::MaterialError),
    /// A modal model (hit off the surface, inconsistent file).
    #[error(transparent)]
    Model(#[from] resound_core::ModalModelError),
    /// Discretization or the eigen-solve.
    #[error("modal analysis: {0}")]
    Modal(#[from] resound_modal::ModelError),
    /// Recording analysis.
    #[error(transparent)]
    Analyze(#[from] resound_signal::AnalyzeError),
    /// Material estimation.
    #[error(transparent)]
    Estimate(#[from] resound_estimate::EstimateError),
    /// Synthesis.
    #[error(transparent)]
    Synth(#[from] resound_synth::SynthError),
    /// A scene simulation.
    #[error(transparent)]
    Scene(#[from] resound_physics::SceneError),
    /// Grains.
    #[error(transparent)]
    Grains(#[from] resound_grains::GrainError),
    /// Mode statistics.
    #[error(transparent)]
    Stats(#[from] resound_stats::StatsError),
    /// A picture.
    #[cfg(feature = "plot")]
    #[error(transparent)]
    Plot(#[from] resound_plot::PlotError),
    /// A value the pipeline refuses, with the reason.
    #[error("{0}")]
    Invalid(String),
    /// A parameter out of its range. `field` is the Params struct's field name (the Python
    /// keyword): front ends name their own flag for it (`speed_m_s` → `--velocity`).
    #[error("{message}")]
    Param {
        /// The field of the Params struct.
        field: &'static str,
        /// What is wrong, with the value.
        message: String,
    },
    /// The material library already has an entry of this name (and replacing it was not
    /// asked for). Front ends add how to ask (`--force`, `replace=True`).
    #[error("the library already has a material named {0:?}")]
    Exists(String),
    /// A named thing that is not there (a library entry to remove, a mode of a model).
    #[error("{0}")]
    Missing(String),
    /// A fitted result that is not credible (a value at its bound or outside physical
    /// ranges): not returned unless asked for. Front ends add how to ask
    /// (`--allow-implausible`, `allow_implausible=True`).
    #[error("the estimate is not credible: {0}")]
    Implausible(String, Option<Box<crate::material::EstimateInfo>>),
    /// The audio device failed (live playback).
    #[error("audio device: {0}")]
    Device(String),
    /// This build has no live audio (the `live` feature).
    #[error("this build has no live audio (the `live` feature; needs ALSA headers, libasound2-dev, on Linux)")]
    NoLiveAudio,
    /// `cause` happened while working on `what` (a file, a body, a step). The message holds
    /// the cause's; it is not also reported as [`std::error::Error::source`], so a chain
    /// printer (anyhow's `{:#}`) says it once.
    #[error("{what}: {cause}")]
    In {
        /// The file or step.
        what: String,
        /// The cause.
        cause: Box<Error>,
    },
}

impl Error {
    /// Wraps `self` with the file or step it happened in.
    pub fn context(self, what: impl Into<String>) -> Self {
        Error::In {
            what: what.into(),
            cause: Box::new(self),
        }
    }

    /// The same for a path.
    pub fn at(self, path: &std::path::Path) -> Self {
        self.context(path.display().to_string())
    }

    /// The error under every [`Error::In`] context: the variant a front end maps to its
    /// own advice (a flag, a keyword).
    pub fn root(&self) -> &Error {
        match self {
            Error::In { cause, .. } => cause.root(),
            e => e,
        }
    }

    /// Whether the eigen-solve did not converge (front ends say how to ask for fewer modes).
    pub fn is_no_convergence(&self) -> bool {
        matches!(
            self.root(),
            Error::Modal(resound_modal::ModelError::Eigen(
                resound_modal::ModalError::NoConvergence { .. }
            ))
        )
    }

    /// The report of an estimate refused as not credible ([`Error::Implausible`]), which a
    /// front end still shows.
    pub fn refused_report(&self) -> Option<&crate::material::EstimateInfo> {
        match self.root() {
            Error::Implausible(_, Some(info)) => Some(info),
            _ => None,
        }
    }

    /// Whether a modal solve found no elastic mode in its band.
    pub fn is_no_modes(&self) -> bool {
        matches!(
            self.root(),
            Error::Modal(resound_modal::ModelError::NoModes(_))
        )
    }

    /// Whether the eigen-solve found more modes below the band edge than it may keep (a
    /// mesh in the wrong unit, or a band too wide): front ends name their settings for it.
    pub fn is_too_many_modes(&self) -> bool {
        matches!(
            self.root(),
            Error::Modal(resound_modal::ModelError::Eigen(
                resound_modal::ModalError::TooManyModes { .. }
            ))
        )
    }
}

/// `Result` with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// Shorthand for [`Error::Invalid`].
pub(crate) fn invalid(msg: impl Into<String>) -> Error {
    Error::Invalid(msg.into())
}
