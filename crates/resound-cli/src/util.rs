//! Small helpers shared by subcommands: value parsers, progress, output.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use resound::modal::Stage;
use serde::Serialize;
use std::time::Duration;

/// Parses `x,y,z`.
pub fn parse_vec3(s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("'{s}' is not x,y,z"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("'{s}' must be three finite numbers x,y,z");
    }
    Ok([v[0], v[1], v[2]])
}

/// Parses a comma-separated list of positive numbers.
pub fn parse_list(s: &str) -> Result<Vec<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("'{s}' is not a comma-separated list of numbers"))?;
    if v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        bail!("'{s}': every value must be a positive number");
    }
    Ok(v)
}

/// Progress on stderr: an indicatif spinner or bar on a terminal, and plain `label: message`
/// lines (the first at once, then at most one every 2 s) in a log, where indicatif would draw nothing
/// and a 30 s estimate would look hung.
pub struct Progress {
    pb: ProgressBar,
    label: String,
    /// `Some` in plain mode: when the last line was printed.
    plain: Option<std::sync::Mutex<std::time::Instant>>,
}

impl Progress {
    fn new(pb: ProgressBar, label: &str) -> Self {
        use std::io::IsTerminal;
        let plain = (!std::io::stderr().is_terminal())
            .then(|| std::sync::Mutex::new(std::time::Instant::now() - Duration::from_secs(10)));
        Self {
            pb,
            label: label.to_string(),
            plain,
        }
    }

    fn line(&self, msg: &str) {
        if let Some(last) = &self.plain {
            if let Ok(mut t) = last.lock() {
                if t.elapsed() >= Duration::from_secs(2) {
                    *t = std::time::Instant::now();
                    eprintln!("{}: {msg}", self.label);
                }
            }
        }
    }

    /// Sets the message. A message that starts with `warning:` (the library's build steps
    /// say so) is printed as a line of its own instead, on a terminal and in a log alike: a
    /// spinner's next message or the log's rate limit would otherwise hide it.
    pub fn set_message(&self, msg: impl Into<String>) {
        let msg = msg.into();
        if msg.starts_with("warning:") {
            self.pb.suspend(|| eprintln!("{msg}"));
            return;
        }
        self.line(&msg);
        self.pb.set_message(msg);
    }

    /// Advances a bar by `n`.
    pub fn inc(&self, n: u64) {
        self.pb.inc(n);
        if self.plain.is_some() {
            let len = self.pb.length().unwrap_or(0);
            self.line(&format!("{}/{len}", self.pb.position()));
        }
    }

    /// Moves a bar of 1000 steps to `pos` under the stage name `prefix`.
    pub fn set_stage(&self, prefix: &'static str, pos: u64) {
        self.pb.set_prefix(prefix);
        self.pb.set_position(pos);
        self.line(&format!("{prefix} {:.0}%", pos as f64 / 10.0));
    }

    /// Removes the spinner or bar.
    pub fn finish_and_clear(&self) {
        self.pb.finish_and_clear();
    }
}

/// A spinner on stderr that follows solver stages.
pub fn spinner(label: &str) -> Progress {
    let pb = ProgressBar::new_spinner();
    pb.set_style(
        ProgressStyle::with_template("{spinner} {prefix} [{elapsed}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    pb.set_prefix(label.to_string());
    pb.enable_steady_tick(Duration::from_millis(120));
    Progress::new(pb, label)
}

/// A bar of `len` steps on stderr: `{pos}/{len} {unit}`.
pub fn bar(label: &str, len: u64, unit: &str) -> Progress {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(&format!(
            "{{prefix}} [{{elapsed}}] {{bar:30}} {{pos}}/{{len}} {unit}"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_prefix(label.to_string());
    Progress::new(pb, label)
}

/// A bar of 1000 steps whose prefix names the stage.
pub fn stages(label: &str) -> Progress {
    let pb = ProgressBar::new(1000);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>9} [{elapsed}] {bar:30} {percent}%")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    Progress::new(pb, label)
}

/// Maps solver stages onto a spinner message.
pub fn stage_message(pb: &Progress, s: Stage) {
    match s {
        Stage::Factorizing => pb.set_message("factorizing K - sigma*M"),
        Stage::Lanczos { applications } => {
            pb.set_message(format!("Lanczos: {applications} operator applications"))
        }
        Stage::SturmCheck => pb.set_message("checking the mode count (Sturm)"),
        _ => {}
    }
}

/// Prints `v` as pretty JSON on stdout.
pub fn print_json<T: Serialize>(v: &T) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

/// Prints the library's warnings on stderr.
pub fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// Checks output paths before any work ([`resound::files::check_outputs`]).
pub fn check_paths(inputs: &[&std::path::Path], outputs: &[&std::path::Path]) -> Result<()> {
    Ok(resound::files::check_outputs(inputs, outputs)?)
}

/// Which part of a recording to take (shared by `analyze` and `estimate`).
#[derive(clap::Args, Debug, Clone)]
pub struct TakeArgs {
    /// Use channel K (0-based) instead of the mix of all channels.
    #[arg(long, value_name = "K")]
    pub channel: Option<usize>,
    /// Resample to this rate first (rubato; e.g. 48000 for a 384 kHz file).
    #[arg(long, value_name = "HZ")]
    pub resample_hz: Option<u32>,
    /// Which strike to use when the file holds several (1 = first). Default: the loudest clean
    /// one (not clipped, not cut short by the next); the report says which and why.
    #[arg(long, value_name = "K")]
    pub strike: Option<usize>,
}

impl TakeArgs {
    /// The library's recording parameters.
    pub fn recording(&self) -> resound::recording::RecordingParams {
        resound::recording::RecordingParams {
            channel: self.channel,
            resample_hz: self.resample_hz,
        }
    }

    /// The strike, 0-based (`None`: the loudest clean one).
    pub fn strike_index(&self) -> Result<Option<usize>> {
        match self.strike {
            Some(0) => anyhow::bail!("--strike counts from 1"),
            Some(k) => Ok(Some(k - 1)),
            None => Ok(None),
        }
    }
}
