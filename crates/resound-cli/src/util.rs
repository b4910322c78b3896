//! Small helpers shared by subcommands: value parsers, progress, output.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Parses comma-separated numbers (`what` names the expected form in the error).
fn numbers(s: &str, what: &str) -> Result<Vec<f64>> {
    let v = s.split(',').map(|p| p.trim().parse::<f64>());
    v.collect::<std::result::Result<_, _>>()
        .with_context(|| format!("'{s}' is not {what}"))
}

/// Parses `x,y,z`.
pub fn parse_vec3(s: &str) -> Result<[f64; 3]> {
    let v = numbers(s, "x,y,z")?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("'{s}' must be three finite numbers x,y,z");
    }
    Ok([v[0], v[1], v[2]])
}

/// Parses a comma-separated list of positive numbers.
pub fn parse_list(s: &str) -> Result<Vec<f64>> {
    let v = numbers(s, "a comma-separated list of numbers")?;
    if v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        bail!("'{s}': every value must be a positive number");
    }
    Ok(v)
}

/// The library's progress reports ([`resound::Progress`]) on stderr: an indicatif spinner, or a
/// bar while a stage reports its fraction, on a terminal; plain `label: stage …` lines (the
/// first at once, then at most one every 2 s) in a log, where indicatif would draw nothing and
/// a 30 s estimate would look hung. Warnings are left to the step's report, which each
/// command prints once at the end (and `--json` includes).
pub struct Bar {
    pb: ProgressBar,
    label: String,
    /// Whether the bar style (not the spinner) is shown.
    barred: std::sync::atomic::AtomicBool,
    /// `Some` in plain mode: when the last line was printed.
    plain: Option<std::sync::Mutex<std::time::Instant>>,
}

impl Bar {
    /// A spinner labelled `label` that turns into a bar while a stage reports its fraction.
    pub fn new(label: &str) -> Self {
        use std::io::IsTerminal;
        let pb = ProgressBar::new(1000);
        pb.set_style(spinner_style());
        pb.set_prefix(label.to_string());
        pb.enable_steady_tick(Duration::from_millis(120));
        let plain = (!std::io::stderr().is_terminal())
            .then(|| std::sync::Mutex::new(std::time::Instant::now() - Duration::from_secs(10)));
        Self {
            pb,
            label: label.to_string(),
            barred: std::sync::atomic::AtomicBool::new(false),
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

    /// Shows one report.
    pub fn show(&self, p: &resound::Progress) {
        use std::sync::atomic::Ordering;
        let resound::Progress::Stage {
            stage,
            fraction,
            label,
            ..
        } = p
        else {
            return;
        };
        self.line(&p.to_string());
        let barred = fraction.is_some();
        if self.barred.swap(barred, Ordering::Relaxed) != barred {
            self.pb
                .set_style(if barred { bar_style() } else { spinner_style() });
        }
        match fraction {
            Some(f) => {
                self.pb
                    .set_prefix(format!("{} {}", self.label, stage.describe()));
                self.pb.set_position((f * 1000.0).round() as u64);
                self.pb.set_message(label.clone().unwrap_or_default());
            }
            None => {
                self.pb.set_prefix(self.label.clone());
                self.pb.set_message(p.to_string());
            }
        }
    }

    /// A callback for a library step.
    pub fn callback(&self) -> impl Fn(resound::Progress) + Sync + '_ {
        move |p| self.show(&p)
    }

    /// Removes the spinner or bar.
    pub fn finish_and_clear(&self) {
        self.pb.finish_and_clear();
    }
}

/// Runs `f` with a progress bar labelled `label` (removed afterwards).
pub fn with_bar<T>(label: &str, f: impl FnOnce(resound::ProgressFn<'_>) -> T) -> T {
    let pb = Bar::new(label);
    let out = f(&pb.callback());
    pb.finish_and_clear();
    out
}

fn spinner_style() -> ProgressStyle {
    ProgressStyle::with_template("{spinner} {prefix} [{elapsed}] {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_spinner())
}

fn bar_style() -> ProgressStyle {
    ProgressStyle::with_template("{prefix} [{elapsed}] {bar:30} {percent}% {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
}

/// Parses a flag value as a library enum by the name its files use (serde's), so the CLI
/// keeps no copy of the library's enums; the error lists the names.
pub fn named<T: serde::de::DeserializeOwned>(s: &str) -> std::result::Result<T, String> {
    serde_json::from_value(serde_json::Value::String(s.into())).map_err(|e| e.to_string())
}

/// Prints a step's report as JSON with the file it wrote (`"output"`) beside its fields.
pub fn print_written<T: Serialize>(output: &Path, report: &T) -> Result<()> {
    #[derive(Serialize)]
    struct Written<'a, T> {
        output: String,
        #[serde(flatten)]
        report: &'a T,
    }
    let output = output.display().to_string();
    print_json(&Written { output, report })
}

/// Prints notes on stderr.
pub fn notes<S: std::fmt::Display>(notes: &[S]) {
    for n in notes {
        eprintln!("note: {n}");
    }
}

/// Prints a report: pretty JSON on stdout when `json`, else its table.
pub fn show<T: Serialize + std::fmt::Display>(json: bool, v: &T) -> Result<()> {
    if json {
        return print_json(v);
    }
    let text = v.to_string();
    print!("{text}{}", if text.ends_with('\n') { "" } else { "\n" });
    Ok(())
}

/// Prints `v` as pretty JSON on stdout.
pub fn print_json<T: Serialize>(v: &T) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

/// Prints the library's warnings on stderr.
pub fn warn_all(warnings: &[resound::Warning]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// Checks output paths before any work ([`resound::files::check_outputs`]).
pub fn check_paths<I: AsRef<Path>, O: AsRef<Path>>(
    inputs: impl IntoIterator<Item = I>,
    outputs: impl IntoIterator<Item = O>,
) -> Result<()> {
    let (i, o): (Vec<I>, Vec<O>) = (inputs.into_iter().collect(), outputs.into_iter().collect());
    let i: Vec<&Path> = i.iter().map(AsRef::as_ref).collect();
    let o: Vec<&Path> = o.iter().map(AsRef::as_ref).collect();
    Ok(resound::files::check_outputs(&i, &o)?)
}

/// Which part of a recording to take (shared by `analyze` and `estimate`).
#[derive(clap::Args, Debug, Clone)]
pub struct TakeArgs {
    /// Use channel K (1 = the first, the left of a stereo file) instead of the mix of all
    /// channels.
    #[arg(long, value_name = "K")]
    pub channel: Option<usize>,
    /// Resample to this rate first (rubato; e.g. 48000 for a 384 kHz file).
    #[arg(long, value_name = "HZ")]
    pub resample_hz: Option<u32>,
    /// Which strike to use when the file holds several (1 = first). Default: the loudest clean
    /// one (not clipped, not cut short by the next); the report says which and why.
    #[arg(long, value_name = "K")]
    pub strike: Option<usize>,
    /// Use every strike of each file as a take of its own (strikes that give no modes are
    /// skipped with a note).
    #[arg(long, conflicts_with = "strike")]
    pub every_strike: bool,
    /// Use every channel of each file as a take of its own (the microphones of a
    /// multichannel recording).
    #[arg(long, conflicts_with = "channel")]
    pub every_channel: bool,
}

impl TakeArgs {
    /// The library's recording parameters.
    pub fn recording(&self) -> Result<resound::recording::RecordingParams> {
        Ok(resound::recording::RecordingParams {
            channel: resound::recording::index_from_1("channel", self.channel)?,
            resample_hz: self.resample_hz,
        })
    }

    /// The library's take selection.
    pub fn selection(&self) -> resound::recording::TakeSelection {
        resound::recording::TakeSelection {
            every_strike: self.every_strike,
            every_channel: self.every_channel,
        }
    }

    /// The strike, 0-based (`None`: the loudest clean one).
    pub fn strike_index(&self) -> Result<Option<usize>> {
        Ok(resound::recording::index_from_1("strike", self.strike)?)
    }
}

/// The struck or scraped object of `synth` and `scrape`: a material on a mesh at a hit point,
/// analysed modes, or mode statistics.
#[derive(clap::Args, Debug, Clone)]
pub struct ObjectSourceArgs {
    /// Material: a library name or a material file (JSON); needs --mesh and --hit.
    #[arg(long, requires_all = ["mesh", "hit"])]
    pub material: Option<String>,
    /// The object: a surface or tet mesh, or a saved modal model (.rmodal) (with --material).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Hit point x,y,z in metres, snapped to the nearest surface point (with --material).
    #[arg(long, allow_hyphen_values = true)]
    pub hit: Option<String>,
    /// The object as analysed modes (the JSON of `resound analyze --json`) instead.
    #[arg(long, conflicts_with_all = ["material", "mesh", "hit"])]
    pub modes: Option<PathBuf>,
    /// The object as mode statistics (`resound stats`) instead: a sampled impulse response.
    #[arg(long, conflicts_with_all = ["material", "mesh", "hit", "modes"])]
    pub stats: Option<PathBuf>,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
}

impl ObjectSourceArgs {
    /// The files read: the object, the modes or statistics, the library and a material
    /// given as a file (`synth --material m.json -o m.json` turned the material into a WAV).
    pub fn inputs(&self) -> Vec<&std::path::Path> {
        let material = self.material.iter().map(std::path::Path::new);
        let files = [&self.mesh, &self.modes, &self.stats, &self.library];
        let paths = files.into_iter().flatten().map(|p| p.as_path());
        paths.chain(material.filter(|p| p.is_file())).collect()
    }

    /// The library's strike source (`seed`: of a statistics draw).
    pub fn source(
        &self,
        seed: u64,
        object_params: resound::object::ObjectParams,
    ) -> Result<resound::strike::StrikeSource> {
        use resound::strike::StrikeSource;
        Ok(match self {
            Self { modes: Some(p), .. } => StrikeSource::Modes(p.clone()),
            Self { stats: Some(p), .. } => StrikeSource::Stats {
                path: p.clone(),
                seed,
            },
            Self {
                material: Some(material),
                mesh: Some(mesh),
                hit: Some(hit),
                ..
            } => StrikeSource::Object {
                material: material.clone(),
                library: self.library.clone(),
                object: mesh.clone(),
                object_params,
                hit_m: parse_vec3(hit)?,
            },
            _ => bail!("give the object: --material with --mesh and --hit, or --modes, or --stats"),
        })
    }
}
