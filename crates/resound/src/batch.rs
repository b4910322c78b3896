//! Dataset generation: a JSON-lines file of jobs (mesh × material × hit points × impact speeds)
//! rendered to content-addressed files, one shard of the jobs per process, resumable.
//!
//! - **Jobs.** One JSON object per line ([`Job`]); blank lines and lines starting with `#` are
//!   skipped. A line that does not parse, or whose job fails, is reported with its line number
//!   and the other jobs go on.
//! - **Outputs** are content-addressed: each rendered strike (one job, one hit, one speed) is
//!   named by a BLAKE3 hash of what determines it — the job's settings, the bytes of the mesh
//!   file, the resolved material, the hit, the speed, and this program's version — and written
//!   atomically (a temporary file, then a rename) to `OUT/<2 hex>/<hash>.wav` (and `.json`).
//! - **Shards.** Shard `i` of `N` takes the jobs whose model — mesh path as written, scale,
//!   mode count, reference material — hashes to `i` modulo `N` (lines that do not parse: their
//!   line number modulo `N`). The mesh path is part of every output's hash, so two jobs that
//!   would write the same file share a model and fall in the same shard: shards never write the
//!   same file, every model is solved in one shard only, and the shards together make exactly
//!   the files of one unsharded run. A strike listed twice is rendered once.
//! - **Manifest.** Each shard appends one JSON line per finished strike to
//!   `OUT/manifest-<i>-of-<N>.jsonl` after its files are in place. A rerun reads it and skips
//!   what it lists (whose files exist), so a killed shard resumes where it stopped; a line cut
//!   short by the kill is dropped.
//! - **Models** are solved once per mesh content, scale, mode count and reference material
//!   within a shard, and kept across runs in an optional cache directory.

use crate::error::{invalid, Error, Result};
use crate::model_cache::{KeyBuilder, ModelCache};
use crate::strike::{render_strike, StrikeParams, Struck};
use resound_core::progress::{Progress, ProgressFn, Stage, Warning, WarningKind};
use resound_core::{Material, ModalModel};
use resound_io::library::Library;
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Bumped when the same job would render differently; part of every output's hash.
pub const OUTPUT_FORMAT: u32 = 1;
pub use resound_core::limits::SPEED_OF_SOUND_M_S;

fn default_scale() -> f64 {
    1.0
}
fn default_speeds() -> Vec<f64> {
    vec![1.0]
}
fn default_modes() -> usize {
    60
}
fn default_duration() -> f64 {
    1.0
}
fn default_rate() -> u32 {
    48_000
}
fn default_format() -> resound_io::WavFormat {
    resound_io::WavFormat::Pcm24
}
fn default_reference() -> String {
    "ceramic".into()
}
fn default_outputs() -> Vec<OutputKind> {
    vec![OutputKind::Wav]
}
fn default_true() -> bool {
    true
}

/// What a job writes for each strike.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OutputKind {
    /// The sound: 32-bit float WAV, physical scale (not normalized), heard at 1 m unless a
    /// listener is given.
    Wav,
    /// The labels: the strike's figures and its modes (frequency, damping, gain at the hit).
    Json,
}

impl OutputKind {
    fn extension(self) -> &'static str {
        match self {
            Self::Wav => "wav",
            Self::Json => "json",
        }
    }
}

/// One line of a jobs file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    /// A label copied to the manifest (not part of the outputs' hash).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The object: a surface or tet mesh, or a `.rmodal` model (relative to the jobs file).
    pub mesh: PathBuf,
    /// Scale applied to the mesh coordinates (0.001 for millimetres).
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Material: a library name, a material file (relative to the jobs file) or `preset:NAME`.
    pub material: String,
    /// Hit points, m (snapped to the surface).
    pub hits: Vec<[f64; 3]>,
    /// Impact speeds, m/s; every hit is struck at every speed.
    #[serde(default = "default_speeds")]
    pub speeds_m_s: Vec<f64>,
    /// Listener position in the mesh's frame, m: the sound is scaled by 1 m / r and delayed by
    /// r / 343 m/s (r from the hit point). None: the strike as heard at 1 m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub listener: Option<[f64; 3]>,
    /// Elastic modes of the model solved from a mesh.
    #[serde(default = "default_modes")]
    pub modes: usize,
    /// Reference material of the modal solve (preset name or E,nu,rho).
    #[serde(default = "default_reference")]
    pub reference_material: String,
    /// Length of each strike, s.
    #[serde(default = "default_duration")]
    pub duration_s: f64,
    /// Sample rate, Hz.
    #[serde(default = "default_rate")]
    pub sample_rate: u32,
    /// Sample format of the WAV files (`pcm16`, `pcm24`, `float`): 24-bit PCM by default, as
    /// every command writes; `float` keeps the quietest strikes' physical level exactly.
    #[serde(default = "default_format")]
    pub format: resound_io::WavFormat,
    /// Add the material's residual.
    #[serde(default = "default_true")]
    pub residual: bool,
    /// Files written per strike.
    #[serde(default = "default_outputs")]
    pub outputs: Vec<OutputKind>,
}

/// Settings of [`run_batch`].
#[derive(Clone, Debug, Default)]
pub struct BatchParams {
    /// Output directory.
    pub out_dir: PathBuf,
    /// This process's shard: (index, count), index < count.
    pub shard: (usize, usize),
    /// Material library (`None`: the default one, if it exists).
    pub library: Option<PathBuf>,
    /// Directory of cached modal models shared across runs (`None`: solved per run).
    pub cache_dir: Option<PathBuf>,
}

/// One finished strike, as the manifest lists it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestEntry {
    /// Line of the job in the jobs file (from 1).
    pub line: usize,
    /// The job's label.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The content hash naming the files.
    pub key: String,
    /// The hit point asked for, m.
    pub hit: [f64; 3],
    /// The surface point struck, m.
    pub surface_point: [f64; 3],
    /// Impact speed, m/s.
    pub speed_m_s: f64,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
    /// Largest absolute sample.
    pub peak: f32,
    /// Modes rendered.
    pub modes: usize,
    /// What is doubtful about this strike (e.g. below audibility).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<resound_core::Warning>,
}

/// A job that failed, by line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JobFailure {
    /// Line in the jobs file (from 1).
    pub line: usize,
    /// Why.
    pub message: String,
}

/// Figures of a batch run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BatchInfo {
    /// Job lines in the file.
    pub jobs: usize,
    /// Job lines of this shard.
    pub shard_jobs: usize,
    /// Strikes rendered in this run.
    pub rendered: usize,
    /// Strikes already in the manifest (a resumed run).
    pub skipped: usize,
    /// Job lines of this shard that repeat an earlier one exactly (same job): skipped at
    /// once, before any file is read.
    pub duplicate_lines: usize,
    /// Modal models solved (the rest came from memory or the cache).
    pub models_solved: usize,
    /// Failed jobs.
    pub failures: Vec<JobFailure>,
    /// Warnings about rendered strikes (`line N: …`), also in their manifest entries.
    pub warnings: Vec<resound_core::Warning>,
    /// The shard's manifest.
    pub manifest: PathBuf,
    /// Seconds to the first file written in this run.
    pub first_output_s: Option<f64>,
    /// Wall time, s.
    pub elapsed_s: f64,
}

impl std::fmt::Display for BatchInfo {
    /// What the shard did, and where its manifest is.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let repeated = if self.duplicate_lines > 0 {
            format!(" ({} repeated lines skipped)", self.duplicate_lines)
        } else {
            String::new()
        };
        write!(
            f,
            "{} of {} jobs{repeated}; {} strikes rendered, {} already done; {} models solved; \
             {:.1} s\nmanifest: {}",
            self.shard_jobs,
            self.jobs,
            self.rendered,
            self.skipped,
            self.models_solved,
            self.elapsed_s,
            self.manifest.display()
        )
    }
}

impl BatchInfo {
    /// The error a front end ends with when jobs of this shard failed: one line per failed
    /// job (`jobs` is the jobs file), then the count. `None` when every job ran.
    pub fn failure_report(&self, jobs: &std::path::Path) -> Option<String> {
        if self.failures.is_empty() {
            return None;
        }
        let mut out = String::new();
        for f in &self.failures {
            out += &format!("{}: line {}: {}\n", jobs.display(), f.line, f.message);
        }
        let lines: Vec<String> = self.failures.iter().map(|f| f.line.to_string()).collect();
        out += &format!(
            "{} of {} jobs of this shard failed (lines {})",
            self.failures.len(),
            self.shard_jobs,
            lines.join(", ")
        );
        Some(out)
    }
}

/// Parses `i/N` (index from 0).
///
/// # Errors
/// Not two integers with i < N.
pub fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let bad = || {
        invalid(format!(
            "shard must be i/N with 0 ≤ i < N (e.g. 0/4), got {s:?}"
        ))
    };
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

fn hash_u64(bytes: &[u8]) -> u64 {
    let h = blake3::hash(bytes);
    let mut b = [0u8; 8];
    b.copy_from_slice(&h.as_bytes()[..8]);
    u64::from_le_bytes(b)
}

/// What decides a job's shard: the model it needs, named by path (no file is read).
fn shard_key(job: &Job) -> Vec<u8> {
    let mut k = job.mesh.to_string_lossy().as_bytes().to_vec();
    k.push(0);
    k.extend_from_slice(&job.scale.to_le_bytes());
    k.extend_from_slice(&(job.modes as u64).to_le_bytes());
    k.extend_from_slice(job.reference_material.as_bytes());
    k
}

fn check_job(job: &Job) -> Result<()> {
    if job.hits.is_empty() || job.speeds_m_s.is_empty() || job.outputs.is_empty() {
        return Err(invalid("hits, speeds_m_s and outputs must not be empty"));
    }
    if job.hits.iter().flatten().any(|c| !c.is_finite()) {
        return Err(invalid("hit coordinates must be finite"));
    }
    if job.modes == 0 || job.modes > 2000 {
        return Err(invalid(format!(
            "modes must be within 1–2000, got {}",
            job.modes
        )));
    }
    if let Some(l) = job.listener {
        if l.iter().any(|c| !c.is_finite()) {
            return Err(invalid("listener coordinates must be finite"));
        }
    }
    Ok(())
}

/// Models kept in memory (the most recently solved or loaded); jobs of one mesh usually come
/// together, and a large jobs file must not hold every model at once.
const MODELS_IN_MEMORY: usize = 8;

/// The model of `job`'s mesh (`path`, whose bytes hash to `bytes_hash`) from the cache, solved
/// when it is in neither memory nor the cache directory.
fn job_model(
    models: &mut ModelCache,
    path: &Path,
    bytes_hash: &blake3::Hash,
    job: &Job,
) -> Result<Arc<ModalModel>> {
    let key = KeyBuilder::new()
        .bytes(bytes_hash.as_bytes())
        .f64s(&[job.scale])
        .count(job.modes)
        .bytes(job.reference_material.as_bytes())
        .finish();
    let solve = || {
        let params = crate::object::ObjectParams {
            scale: job.scale,
            modal: resound_modal::ModalParams {
                n_modes: Some(job.modes),
                ..Default::default()
            },
            reference_material: Material::parse(&job.reference_material)?,
        };
        crate::object::load_object(path, &params, &|_| {})
    };
    Ok(models.get_or_solve(key, solve)?.0)
}

/// Reads a manifest, dropping a last line cut short; rewrites it (atomically) without that
/// line so that appends start on a fresh line.
fn read_manifest(path: &Path) -> Result<Vec<ManifestEntry>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => {
            return Err(Error::from(resound_io::IoError::Io {
                path: path.to_path_buf(),
                error: e,
            }))
        }
    };
    let mut entries = Vec::new();
    let mut clean = true;
    let last = text.lines().count();
    for (k, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match serde_json::from_str::<ManifestEntry>(line) {
            Ok(e) => entries.push(e),
            // Only the last line can be cut short by a kill.
            Err(_) if k + 1 == last => clean = false,
            Err(e) => {
                return Err(invalid(format!(
                    "{}: line {}: not a manifest entry ({e})",
                    path.display(),
                    k + 1
                )))
            }
        }
    }
    if !clean || !(text.is_empty() || text.ends_with('\n')) {
        crate::files::write_json_lines(path, &entries)?;
    }
    Ok(entries)
}

/// Runs shard `params.shard` of the jobs in `jobs_path`. Failed jobs are listed in the
/// returned figures (by line); the call itself fails only when nothing can be done (the jobs
/// file or the output directory unusable).
///
/// # Errors
/// Unreadable jobs file, output directory or manifest; a bad shard.
pub fn run_batch(
    jobs_path: &Path,
    params: &BatchParams,
    progress: ProgressFn<'_>,
) -> Result<BatchInfo> {
    let t0 = std::time::Instant::now();
    let (shard, shards) = params.shard;
    if shards == 0 || shard >= shards {
        return Err(invalid(format!("shard {shard}/{shards}: need 0 ≤ i < N")));
    }
    let text = std::fs::read_to_string(jobs_path).map_err(|e| {
        Error::from(resound_io::IoError::Io {
            path: jobs_path.to_path_buf(),
            error: e,
        })
    })?;
    // A file without one job is a mistake (the wrong file, or an export that failed), not a
    // finished dataset: said before the output folder is made.
    if text
        .lines()
        .all(|l| l.trim().is_empty() || l.trim().starts_with('#'))
    {
        return Err(invalid(format!(
            "{}: no jobs (one JSON object per line; blank lines and # comments are skipped)",
            jobs_path.display()
        )));
    }
    let base = jobs_path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let out = &params.out_dir;
    crate::files::make_output_dir(out)?;
    let manifest_path = out.join(format!("manifest-{shard}-of-{shards}.jsonl"));
    let mut done: HashSet<String> = read_manifest(&manifest_path)?
        .into_iter()
        .filter(|e| e.files.iter().all(|f| out.join(f).is_file()))
        .map(|e| e.key)
        .collect();
    let mut info = BatchInfo {
        manifest: manifest_path.clone(),
        ..Default::default()
    };
    // This shard's lines: parsed jobs by their hash, the rest by line number.
    let mut mine: Vec<(usize, std::result::Result<Job, String>)> = Vec::new();
    // Lines that repeat a job (by its parsed value, so spacing and key order do not matter)
    // cost nothing: 100 000 copies of one job took 5.5 min of reading and hashing.
    let mut seen_jobs: HashSet<Vec<u8>> = HashSet::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        info.jobs += 1;
        let parsed: std::result::Result<Job, String> =
            serde_json::from_str(t).map_err(|e| format!("not a job: {e}"));
        let owner = match &parsed {
            Ok(job) => (hash_u64(&shard_key(job)) % shards as u64) as usize,
            Err(_) => line % shards,
        };
        if owner == shard {
            if let Ok(job) = &parsed {
                let canonical = serde_json::to_vec(job).unwrap_or_default();
                if !seen_jobs.insert(canonical) {
                    info.duplicate_lines += 1;
                    continue;
                }
            }
            mine.push((line, parsed));
        }
    }
    info.shard_jobs = mine.len();
    let library = crate::material::read_library(params.library.as_deref())?;
    let mut models = ModelCache::new(params.cache_dir.clone(), MODELS_IN_MEMORY);
    let mut manifest = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&manifest_path)
        .map_err(|e| {
            Error::from(resound_io::IoError::Io {
                path: manifest_path.clone(),
                error: e,
            })
        })?;
    let total = mine.len();
    for (n, (line, parsed)) in mine.into_iter().enumerate() {
        let result = parsed.map_err(invalid).and_then(|job| {
            run_job(
                line,
                &job,
                &base,
                out,
                library.as_ref(),
                &mut models,
                &mut done,
                &mut info,
                &mut manifest,
                &manifest_path,
                t0,
            )
        });
        if let Err(e) = result {
            info.failures.push(JobFailure {
                line,
                message: e.to_string(),
            });
        }
        // `count` is the line just handled; `fraction` the shard's jobs handled.
        progress(Progress::Stage {
            stage: Stage::Batch,
            fraction: Some((n + 1) as f64 / total.max(1) as f64),
            count: Some(line as u64),
            label: None,
        });
    }
    info.models_solved = models.solved();
    info.elapsed_s = t0.elapsed().as_secs_f64();
    Ok(info)
}

#[allow(clippy::too_many_arguments)]
fn run_job(
    line: usize,
    job: &Job,
    base: &Path,
    out: &Path,
    library: Option<&Library>,
    models: &mut ModelCache,
    done: &mut HashSet<String>,
    info: &mut BatchInfo,
    manifest: &mut std::fs::File,
    manifest_path: &Path,
    t0: std::time::Instant,
) -> Result<()> {
    check_job(job)?;
    let mesh_path = base.join(&job.mesh);
    let bytes = std::fs::read(&mesh_path).map_err(|e| {
        Error::from(resound_io::IoError::Io {
            path: mesh_path.clone(),
            error: e,
        })
    })?;
    let mesh_hash = blake3::hash(&bytes);
    drop(bytes);
    let material = crate::material::resolve_material(&job.material, base, library)?;
    let material_json = serde_json::to_vec(&material).map_err(|e| invalid(e.to_string()))?;
    // What every strike of the job shares.
    let mut common = blake3::Hasher::new();
    common.update(
        format!(
            "resound {} batch {OUTPUT_FORMAT}\n",
            env!("CARGO_PKG_VERSION")
        )
        .as_bytes(),
    );
    common.update(&shard_key(job));
    common.update(mesh_hash.as_bytes());
    common.update(&material_json);
    let settings = serde_json::to_vec(&(
        job.scale,
        job.listener,
        job.modes,
        &job.reference_material,
        job.duration_s,
        job.sample_rate,
        job.residual,
        &job.outputs,
        job.format,
    ))
    .map_err(|e| invalid(e.to_string()))?;
    common.update(&settings);
    let mut model = None;
    for &hit in &job.hits {
        for &speed in &job.speeds_m_s {
            let mut h = common.clone();
            for c in hit {
                h.update(&c.to_le_bytes());
            }
            h.update(&speed.to_le_bytes());
            let key = h.finalize().to_hex()[..32].to_string();
            let files: Vec<String> = job
                .outputs
                .iter()
                .map(|k| format!("{}/{key}.{}", &key[..2], k.extension()))
                .collect();
            if done.contains(&key) {
                info.skipped += 1;
                continue;
            }
            let m: &Arc<ModalModel> = match &model {
                Some(m) => m,
                None => model.insert(job_model(models, &mesh_path, &mesh_hash, job)?),
            };
            let at = m.hit(hit)?;
            let params = StrikeParams {
                speed_m_s: speed,
                residual: job.residual,
                duration_s: job.duration_s,
                sample_rate_hz: job.sample_rate,
                ..Default::default()
            };
            let mut strike = render_strike(
                Struck::Object {
                    material: &material,
                    model: m,
                    hit: &at,
                    same_object: false,
                },
                &params,
            )?;
            let mut warnings = Vec::new();
            if let Some(l) = job.listener {
                let r = (0..3)
                    .map(|c| (l[c] - at.at.point[c]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                if r < 0.01 {
                    return Err(invalid(format!(
                        "the listener is {:.1} mm from the hit point; it must be at least 1 cm away",
                        r * 1e3
                    )));
                }
                let fs = f64::from(job.sample_rate);
                let delay = (r / SPEED_OF_SOUND_M_S * fs).round() as usize;
                let g = (1.0 / r) as f32;
                let n = strike.samples.len();
                let mut moved = vec![0.0f32; n];
                for (d, s) in moved.iter_mut().skip(delay).zip(&strike.samples) {
                    *d = s * g;
                }
                if delay >= n {
                    warnings.push(Warning::new(
                        WarningKind::Geometry,
                        format!(
                            "the listener is {r:.1} m away: the sound arrives after the {} s \
                             rendered",
                            job.duration_s
                        ),
                    ));
                }
                strike.samples = moved;
            }
            // The strike's report measures its level (and warns below audibility); at a
            // listener, again as heard there.
            if job.listener.is_some() {
                crate::strike::measure_level(&mut strike);
            }
            warnings.extend(strike.info.warnings.iter().cloned());
            for (kind, file) in job.outputs.iter().zip(&files) {
                let path = out.join(file);
                if let Some(d) = path.parent() {
                    std::fs::create_dir_all(d).map_err(|e| {
                        Error::from(resound_io::IoError::Io {
                            path: d.to_path_buf(),
                            error: e,
                        })
                    })?;
                }
                match kind {
                    OutputKind::Wav => {
                        resound_io::write_wav(&path, &strike.samples, job.sample_rate, job.format)?
                    }
                    OutputKind::Json => {
                        #[derive(Serialize)]
                        struct Labels {
                            #[serde(flatten)]
                            info: crate::strike::StrikeInfo,
                            speed_m_s: f64,
                            /// (frequency Hz, damping 1/s, gain per N·s at the hit).
                            bank_modes: Vec<[f64; 3]>,
                        }
                        let labels = Labels {
                            info: strike.info.without_timings(),
                            speed_m_s: speed,
                            bank_modes: strike
                                .modes
                                .iter()
                                .map(|b| [b.freq_hz, b.damping_per_s, b.gain])
                                .collect(),
                        };
                        crate::files::write_json(&path, &labels)?;
                    }
                }
            }
            info.first_output_s
                .get_or_insert(t0.elapsed().as_secs_f64());
            info.warnings.extend(warnings.iter().map(|w| Warning {
                kind: w.kind,
                message: format!("line {line}: {w}"),
            }));
            let entry_key = key.clone();
            let entry = ManifestEntry {
                line,
                name: job.name.clone(),
                key,
                hit,
                surface_point: at.at.point,
                speed_m_s: speed,
                files,
                peak: strike.info.peak,
                modes: strike.info.modes,
                warnings,
            };
            let mut text = serde_json::to_string(&entry).map_err(|e| invalid(e.to_string()))?;
            text.push('\n');
            // One write per line: a kill leaves at most the last line cut short.
            manifest
                .write_all(text.as_bytes())
                .and_then(|()| manifest.flush())
                .map_err(|e| {
                    Error::from(resound_io::IoError::Io {
                        path: manifest_path.to_path_buf(),
                        error: e,
                    })
                })?;
            info.rendered += 1;
            done.insert(entry_key);
        }
    }
    Ok(())
}
