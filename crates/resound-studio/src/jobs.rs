//! Long steps as jobs: run on the blocking pool (requests are never blocked by them), their
//! [`Progress`] kept as the job's status (polled, or streamed as server-sent events), and
//! cancellable.
//!
//! Cancelling: the library's progress callback has no return value, so the job's callback
//! unwinds out of the step with a private payload when the job was cancelled; the job catches
//! it and reports `cancelled`. Every step reports progress at least per stage (the eigen-solve
//! per restart), so a cancel takes effect at the next report. The same catch turns a panic in
//! a step into a failed job with a message instead of a dropped connection.

use crate::AppState;
use resound::Progress;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use tokio::sync::watch;

/// Where a job is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    /// Working.
    Running,
    /// Finished with a result.
    Done,
    /// Finished with an error.
    Failed,
    /// Cancelled by a request.
    Cancelled,
}

/// A job as the page sees it.
#[derive(Clone, Debug, Serialize)]
pub struct JobStatus {
    /// The job's id.
    pub id: u64,
    /// What it does (`solve`, `estimate`, `render`).
    pub kind: &'static str,
    /// Where it is.
    pub state: JobState,
    /// The latest progress report.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub progress: Option<Progress>,
    /// The latest progress as a line of text.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    /// Warnings heard so far.
    pub warnings: Vec<resound::Warning>,
    /// The step's report (when done).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub result: Option<serde_json::Value>,
    /// Why it failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The step's report when it failed with one (an estimate refused as not credible).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<String>,
    /// Seconds since it started.
    pub elapsed_s: f64,
}

impl JobStatus {
    /// Whether the job has finished (done, failed or cancelled).
    pub fn is_finished(&self) -> bool {
        self.state != JobState::Running
    }
}

pub(crate) struct Job {
    pub(crate) status: watch::Sender<JobStatus>,
    cancel: AtomicBool,
}

impl Job {
    pub(crate) fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }
}

/// The payload a cancelled job's progress callback unwinds with.
struct Cancelled;

/// Keeps cancellation unwinds out of the panic message (other panics print as before).
pub(crate) fn quiet_cancellation() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !info.payload().is::<Cancelled>() {
                previous(info);
            }
        }));
    });
}

/// A step's failure as the page shows it: why, and the step's report when it has one (an
/// estimate refused as not credible carries its fit report, as the CLI prints it).
#[derive(Debug)]
pub(crate) struct StepError {
    pub message: String,
    pub report: Option<String>,
}

impl From<String> for StepError {
    fn from(message: String) -> Self {
        Self {
            message,
            report: None,
        }
    }
}

/// A step's outcome.
pub(crate) type StepResult = Result<serde_json::Value, StepError>;

/// Starts `step` as a job and returns its first status.
pub(crate) fn spawn<F>(state: &Arc<AppState>, kind: &'static str, step: F) -> JobStatus
where
    F: FnOnce(&Arc<AppState>, resound::ProgressFn<'_>) -> StepResult + Send + 'static,
{
    let id = state.next_id();
    let status = JobStatus {
        id,
        kind,
        state: JobState::Running,
        progress: None,
        message: None,
        warnings: Vec::new(),
        result: None,
        error: None,
        report: None,
        elapsed_s: 0.0,
    };
    let (tx, _) = watch::channel(status.clone());
    let job = Arc::new(Job {
        status: tx,
        cancel: AtomicBool::new(false),
    });
    if let Ok(mut jobs) = state.jobs.lock() {
        jobs.insert(id, job.clone());
    }
    let st = state.clone();
    tokio::task::spawn_blocking(move || {
        let t0 = std::time::Instant::now();
        let progress = |p: Progress| {
            if job.cancel.load(Ordering::Relaxed) {
                std::panic::panic_any(Cancelled);
            }
            job.status.send_modify(|s| {
                s.elapsed_s = t0.elapsed().as_secs_f64();
                match &p {
                    Progress::Warning(w) => s.warnings.push(w.clone()),
                    _ => {
                        s.message = Some(p.to_string());
                        s.progress = Some(p.clone());
                    }
                }
            });
        };
        let outcome =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| step(&st, &progress)));
        job.status.send_modify(|s| {
            s.elapsed_s = t0.elapsed().as_secs_f64();
            match outcome {
                Ok(Ok(v)) => {
                    s.state = JobState::Done;
                    s.result = Some(v);
                }
                Ok(Err(e)) => {
                    s.state = JobState::Failed;
                    s.error = Some(e.message);
                    s.report = e.report;
                }
                Err(payload) if payload.is::<Cancelled>() => s.state = JobState::Cancelled,
                Err(payload) => {
                    let what = payload
                        .downcast_ref::<String>()
                        .map(String::as_str)
                        .or_else(|| payload.downcast_ref::<&str>().copied())
                        .unwrap_or("unknown");
                    s.state = JobState::Failed;
                    s.error = Some(format!("internal error ({what}); please report it"));
                }
            }
        });
    });
    status
}
