//! What every long step says while it runs and what it warns about, as typed values.
//!
//! One [`Progress`] value reaches every front end from every long step (modal solve, material
//! fit, scene build, grains, batch): the CLI draws it as a bar or plain log lines, Python and
//! the studio receive it as a document (`{"type": "stage", "stage": "lanczos", "count": 120}`).
//! A [`Warning`] is a value with a [`WarningKind`] so a front end can sort, count or highlight
//! warnings without reading their words; its message never names a command-line flag.
//!
//! ```
//! use resound_core::progress::{Progress, Stage, Warning, WarningKind};
//! let p = Progress::fraction(Stage::Estimating, 0.5);
//! assert_eq!(p.fraction_done(), Some(0.5));
//! let w = Warning::new(WarningKind::Quiet, "the render peaks at -95 dBFS");
//! assert_eq!(w.to_string(), "the render peaks at -95 dBFS");
//! ```

use serde::{Deserialize, Serialize};
use std::fmt;

/// A long step's stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Analysing recordings (their modes); `label` names the file.
    Analyzing,
    /// Reading or meshing the object and assembling its FEM matrices.
    Assembling,
    /// Factorizing K − σM for the shift-invert eigen-solve.
    Factorizing,
    /// Lanczos iterations; `count` is operator applications so far.
    Lanczos,
    /// Checking the number of modes below the band edge (Sturm count).
    SturmCheck,
    /// Fitting the acoustic transfer (radiation) of the modes.
    Transfer,
    /// Fitting a material; `fraction` of its starting points (or takes) done.
    Estimating,
    /// Splitting continuous recordings into deterministic and stochastic parts (grains).
    Splitting,
    /// Cutting grains.
    Grains,
    /// Correlating grains into patterns.
    Patterns,
    /// Building a scene body's model; `label` names the body, `fraction` is bodies done.
    Building,
    /// Simulating and rendering a scene; `fraction` of its duration done.
    Simulating,
    /// Rendering a batch of strikes; `count` is the job line just done, `fraction` jobs done.
    Batch,
}

impl Stage {
    /// A short description for a progress line.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Analyzing => "analysing",
            Self::Assembling => "assembling the FEM model",
            Self::Factorizing => "factorizing K - sigma*M",
            Self::Lanczos => "Lanczos",
            Self::SturmCheck => "checking the mode count (Sturm)",
            Self::Transfer => "fitting the acoustic transfer",
            Self::Estimating => "estimating",
            Self::Splitting => "SMS",
            Self::Grains => "grains",
            Self::Patterns => "patterns",
            Self::Building => "building",
            Self::Simulating => "simulating",
            Self::Batch => "batch",
        }
    }
}

/// What kind of doubt a [`Warning`] raises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarningKind {
    /// A render or recording is too quiet to be heard in context.
    Quiet,
    /// The acoustic transfer fits some modes poorly.
    PoorTransfer,
    /// A fitted value is undetermined, at a bound or outside its plausible range.
    Implausible,
    /// The input recording is clipped, noisy, cut short or holds several strikes.
    Input,
    /// The mesh or the modal model is questionable (size, unit, convergence, rigid modes).
    Model,
    /// A hit point, microphone or listener position is questionable.
    Geometry,
    /// A live render fell behind real time.
    Realtime,
}

/// A result that deserves a second look: returned in every report's `warnings` and sent as
/// [`Progress::Warning`] while a step runs.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Warning {
    /// What kind of doubt.
    pub kind: WarningKind,
    /// What is doubtful and what to do, in words (no command-line flag names).
    pub message: String,
}

impl Warning {
    /// A warning of `kind`.
    pub fn new(kind: WarningKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            message: message.into(),
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// One report from a running step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Progress {
    /// Work in `stage`.
    Stage {
        /// The stage.
        stage: Stage,
        /// Share of the stage done, 0–1, when it is known.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fraction: Option<f64>,
        /// Units of work so far when the total is unknown (operator applications, lines).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        count: Option<u64>,
        /// What the stage works on (a body's name, a file).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        label: Option<String>,
    },
    /// A warning, also kept in the step's report.
    Warning(Warning),
}

impl Progress {
    /// `stage` began (nothing measured yet).
    pub fn begin(stage: Stage) -> Self {
        Self::Stage {
            stage,
            fraction: None,
            count: None,
            label: None,
        }
    }

    /// `fraction` (0–1) of `stage` is done.
    pub fn fraction(stage: Stage, fraction: f64) -> Self {
        Self::Stage {
            stage,
            fraction: Some(fraction.clamp(0.0, 1.0)),
            count: None,
            label: None,
        }
    }

    /// `count` units of `stage`'s work are done (total unknown).
    pub fn count(stage: Stage, count: u64) -> Self {
        Self::Stage {
            stage,
            fraction: None,
            count: Some(count),
            label: None,
        }
    }

    /// The same report, naming what the stage works on.
    pub fn with_label(mut self, text: impl Into<String>) -> Self {
        if let Self::Stage { label, .. } = &mut self {
            *label = Some(text.into());
        }
        self
    }

    /// The stage, if this is a stage report.
    pub fn stage(&self) -> Option<Stage> {
        match self {
            Self::Stage { stage, .. } => Some(*stage),
            Self::Warning(_) => None,
        }
    }

    /// The share done, if this is a stage report that knows it.
    pub fn fraction_done(&self) -> Option<f64> {
        match self {
            Self::Stage { fraction, .. } => *fraction,
            Self::Warning(_) => None,
        }
    }
}

impl fmt::Display for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Stage {
                stage,
                fraction,
                count,
                label,
            } => {
                f.write_str(stage.describe())?;
                if let Some(l) = label {
                    write!(f, " {l}")?;
                }
                if let Some(c) = count {
                    write!(f, ": {c}")?;
                    if *stage == Stage::Lanczos {
                        f.write_str(" operator applications")?;
                    }
                }
                if let Some(x) = fraction {
                    write!(f, " {:.0}%", x * 100.0)?;
                }
                Ok(())
            }
            Self::Warning(w) => write!(f, "warning: {w}"),
        }
    }
}

/// The callback every long step takes.
pub type ProgressFn<'a> = &'a (dyn Fn(Progress) + Sync);

/// A callback that ignores every report.
pub fn ignore(_: Progress) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_round_trips_as_a_tagged_document() {
        let p = Progress::count(Stage::Lanczos, 120).with_label("bowl");
        let json = serde_json::to_value(&p).unwrap();
        assert_eq!(json["type"], "stage");
        assert_eq!(json["stage"], "lanczos");
        assert_eq!(json["count"], 120);
        assert!(json.get("fraction").is_none());
        assert_eq!(serde_json::from_value::<Progress>(json).unwrap(), p);
        let w = Progress::Warning(Warning::new(WarningKind::PoorTransfer, "3 modes"));
        let json = serde_json::to_value(&w).unwrap();
        assert_eq!(json["type"], "warning");
        assert_eq!(json["kind"], "poor_transfer");
        assert_eq!(json["message"], "3 modes");
        assert_eq!(serde_json::from_value::<Progress>(json).unwrap(), w);
    }

    #[test]
    fn fractions_are_clamped_and_described() {
        let p = Progress::fraction(Stage::Simulating, 1.7);
        assert_eq!(p.fraction_done(), Some(1.0));
        assert_eq!(p.to_string(), "simulating 100%");
        assert_eq!(
            Progress::count(Stage::Lanczos, 7).to_string(),
            "Lanczos: 7 operator applications"
        );
    }
}
