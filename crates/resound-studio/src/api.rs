//! The HTTP API: each endpoint is one library call and its typed report as JSON.

use crate::jobs::{self, JobStatus};
use crate::AppState;
use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{delete, get, post};
use axum::{Json, Router};
use resound::core::{Material, SoundMaterial};
use resound::io::{write_wav, WavFormat};
use resound::mesh::{write_primitive, PrimitiveInfo, PrimitiveKind};
use resound::object::{solve_object, ModalReport, SolveJob};
use resound::recording::{analyze_file, AnalysisReport, RecordingParams};
use resound::signal::{Analysis, AnalyzeParams};
use resound::strike::{render_strike_from, StrikeParams, StrikeSource};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;

/// An error as the page shows it: a status and `{"error": message}`.
#[derive(Debug)]
pub(crate) struct ApiError {
    status: StatusCode,
    message: String,
}

impl ApiError {
    pub(crate) fn new(status: StatusCode, message: impl Into<String>) -> Self {
        Self {
            status,
            message: message.into(),
        }
    }

    fn bad(message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, message)
    }

    fn missing(what: &str, id: u64) -> Self {
        Self::new(
            StatusCode::NOT_FOUND,
            format!("no {what} {id} in this session"),
        )
    }
}

impl From<resound::Error> for ApiError {
    fn from(e: resound::Error) -> Self {
        let status = match e.root() {
            resound::Error::Exists(_) => StatusCode::CONFLICT,
            resound::Error::Missing(_) => StatusCode::NOT_FOUND,
            _ => StatusCode::UNPROCESSABLE_ENTITY,
        };
        Self::new(status, error_text(&e))
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (
            self.status,
            Json(serde_json::json!({ "error": self.message })),
        )
            .into_response()
    }
}

/// A library error with its causes, as one line.
fn error_text(e: &resound::Error) -> String {
    let mut s = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(c) = source {
        let t = c.to_string();
        if !s.contains(&t) {
            s += &format!(": {t}");
        }
        source = c.source();
    }
    s
}

type ApiResult<T> = Result<T, ApiError>;

fn get_entry<T>(
    map: &std::sync::Mutex<std::collections::HashMap<u64, Arc<T>>>,
    id: u64,
    what: &str,
) -> ApiResult<Arc<T>> {
    map.lock()
        .ok()
        .and_then(|m| m.get(&id).cloned())
        .ok_or_else(|| ApiError::missing(what, id))
}

/// A loaded recording and its latest analysis.
pub(crate) struct RecordingEntry {
    name: String,
    path: PathBuf,
    mime: &'static str,
    analysis: std::sync::Mutex<Arc<(AnalysisReport, Analysis)>>,
}

/// A solved object.
pub(crate) struct ObjectEntry {
    model_path: PathBuf,
}

/// An estimated material, not yet saved.
pub(crate) struct EstimateEntry {
    material: SoundMaterial,
    /// What the picture is drawn from (on first request: the job itself does only what
    /// `resound estimate` does).
    outcome: resound::material::EstimateOutcome,
    settings: resound::estimate::EstimateParams,
    title: String,
    plot: std::sync::Mutex<Option<PathBuf>>,
}

/// An uploaded mesh file.
pub(crate) struct MeshEntry {
    path: PathBuf,
}

/// A rendered strike.
pub(crate) struct RenderEntry {
    wav: PathBuf,
}

pub(crate) fn routes(state: Arc<AppState>) -> Router {
    let limit = state.max_upload_bytes;
    Router::new()
        .route("/api/info", get(info))
        .route("/api/samples", get(samples))
        .route("/api/samples/{name}", post(open_sample))
        .route(
            "/api/recordings",
            post(upload).layer(DefaultBodyLimit::max(limit)),
        )
        .route("/api/recordings/{id}", get(recording))
        .route("/api/recordings/{id}/analyze", post(reanalyze))
        .route("/api/recordings/{id}/audio", get(recording_audio))
        .route("/api/recordings/{id}/plot.png", get(recording_plot))
        .route("/api/recordings/{id}/part/{part}", get(recording_part))
        .route("/api/recordings/{id}/mode/{k}", get(recording_mode))
        .route(
            "/api/meshes",
            post(upload_mesh).layer(DefaultBodyLimit::max(limit)),
        )
        .route("/api/objects", post(solve))
        .route("/api/objects/{id}/surface", get(surface))
        .route("/api/objects/{id}/model.rmodal", get(object_model))
        .route("/api/objects/{id}/mode/{k}", post(object_mode))
        .route("/api/estimate", post(estimate))
        .route("/api/estimates/{id}/material.json", get(estimate_material))
        .route("/api/estimates/{id}/plot.png", get(estimate_plot))
        .route("/api/render", post(render))
        .route("/api/renders/{id}", get(render_wav))
        .route("/api/renders/{id}/plot.png", get(render_plot))
        .route("/api/compare", get(compare))
        .route("/api/scene", post(scene))
        .route("/api/jobs/{id}", get(job).delete(cancel_job))
        .route("/api/jobs/{id}/events", get(job_events))
        .route("/api/materials", get(materials).post(save_material))
        .route(
            "/api/materials/import",
            post(import_material).layer(DefaultBodyLimit::max(limit)),
        )
        .route("/api/materials/{name}/rename", post(rename_material))
        .route(
            "/api/library/files",
            post(store_kept_file).layer(DefaultBodyLimit::max(limit)),
        )
        .route(
            "/api/library/files/{kind}/{name}",
            get(kept_file).delete(remove_kept_file),
        )
        .route(
            "/api/materials/{name}",
            delete(remove_material).get(material_json),
        )
        .with_state(state)
}

/// What the page needs to start: version, limits, shapes, bundled recordings.
async fn info(State(s): State<Arc<AppState>>) -> Json<serde_json::Value> {
    Json(serde_json::json!({
        "version": env!("CARGO_PKG_VERSION"),
        "max_upload_bytes": s.max_upload_bytes,
        "primitives": PrimitiveKind::NAMES.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
        "samples": SAMPLES.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
    }))
}

/// Recordings bundled with Resound (their licences are beside them in assets/recordings).
const SAMPLES: [(&str, &[u8]); 2] = [
    (
        "steel_nut_M4_2.wav",
        include_bytes!("../../../assets/recordings/steel_nut_M4_2.wav"),
    ),
    (
        "default_place_node_metal.1.ogg",
        include_bytes!("../../../assets/recordings/default_place_node_metal.1.ogg"),
    ),
];

async fn samples() -> Json<Vec<&'static str>> {
    Json(SAMPLES.iter().map(|(n, _)| *n).collect())
}

/// The recording as the page sees it: its id, name and analysis report.
#[derive(Serialize)]
struct RecordingView {
    id: u64,
    name: String,
    report: AnalysisReport,
    /// The analysis as `resound analyze` prints it.
    text: String,
}

fn view(id: u64, e: &RecordingEntry) -> RecordingView {
    let a = analysis_of(e);
    RecordingView {
        id,
        name: e.name.clone(),
        report: a.0.clone(),
        text: a.1.to_string(),
    }
}

/// A name for showing only: the last path component, printable, at most 120 characters.
fn display_name(name: &str) -> String {
    let last = name.rsplit(['/', '\\']).next().unwrap_or("");
    let clean: String = last.chars().filter(|c| !c.is_control()).take(120).collect();
    if clean.is_empty() {
        "recording".into()
    } else {
        clean
    }
}

/// The audio formats we decode, by extension.
fn audio_kind(name: &str) -> Option<(&'static str, &'static str)> {
    let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
    Some(match ext.as_str() {
        "wav" => ("wav", "audio/wav"),
        "flac" => ("flac", "audio/flac"),
        "ogg" => ("ogg", "audio/ogg"),
        "mp3" => ("mp3", "audio/mpeg"),
        _ => return None,
    })
}

fn analysis_params(strike: Option<usize>, highpass_hz: Option<f64>) -> ApiResult<AnalyzeParams> {
    Ok(AnalyzeParams {
        strike: match strike {
            Some(0) => return Err(ApiError::bad("strikes count from 1")),
            k => k.map(|k| k - 1),
        },
        highpass_hz,
        ..AnalyzeParams::default()
    })
}

async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> ApiResult<T> + Send + 'static,
) -> ApiResult<T> {
    tokio::task::spawn_blocking(f).await.map_err(|e| {
        ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("internal error: {e}"),
        )
    })?
}

/// Stores `bytes` as a recording of this session and analyses it.
async fn add_recording(
    s: Arc<AppState>,
    name: &str,
    bytes: &[u8],
) -> ApiResult<Json<RecordingView>> {
    let name = display_name(name);
    let Some((ext, mime)) = audio_kind(&name) else {
        return Err(ApiError::bad(format!(
            "{name}: not a recording we read (WAV, FLAC, OGG Vorbis or MP3)"
        )));
    };
    if bytes.is_empty() {
        return Err(ApiError::bad(format!("{name} is empty")));
    }
    let id = s.next_id();
    let path = s.file(&format!("recording-{id}.{ext}"));
    std::fs::write(&path, bytes).map_err(|e| {
        ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("cannot store the upload: {e}"),
        )
    })?;
    let p = path.clone();
    let shown = name.clone();
    let analysed = blocking(move || {
        let (rec, res) = analyze_file(&p, &RecordingParams::default(), &AnalyzeParams::default())?;
        Ok(Arc::new((
            AnalysisReport::new(&shown, &rec.codec, &res),
            res,
        )))
    })
    .await;
    let analysed = match analysed {
        Ok(a) => a,
        Err(e) => {
            let _ = std::fs::remove_file(&path);
            return Err(e);
        }
    };
    let entry = Arc::new(RecordingEntry {
        name,
        path,
        mime,
        analysis: std::sync::Mutex::new(analysed),
    });
    let v = view(id, &entry);
    if let Ok(mut m) = s.recordings.lock() {
        m.insert(id, entry);
    }
    Ok(Json(v))
}

#[derive(Deserialize)]
struct UploadQuery {
    name: String,
}

/// `POST /api/recordings?name=x.wav` with the file as the body.
async fn upload(
    State(s): State<Arc<AppState>>,
    Query(q): Query<UploadQuery>,
    body: Bytes,
) -> ApiResult<Json<RecordingView>> {
    add_recording(s, &q.name, &body).await
}

async fn open_sample(
    State(s): State<Arc<AppState>>,
    Path(name): Path<String>,
) -> ApiResult<Json<RecordingView>> {
    let (n, bytes) = SAMPLES.iter().find(|(n, _)| *n == name).ok_or_else(|| {
        ApiError::new(
            StatusCode::NOT_FOUND,
            format!("no bundled recording {name:?}"),
        )
    })?;
    add_recording(s, n, bytes).await
}

async fn recording(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
) -> ApiResult<Json<RecordingView>> {
    let e = get_entry(&s.recordings, id, "recording")?;
    Ok(Json(view(id, &e)))
}

#[derive(Deserialize)]
struct AnalyzeBody {
    /// The strike to analyse, from 1 (`None`: the strongest clean one).
    strike: Option<usize>,
    /// High-pass corner, Hz (`None`: chosen from the rumble measured).
    highpass_hz: Option<f64>,
}

/// Analyses a recording again with another strike or high-pass.
async fn reanalyze(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
    Json(b): Json<AnalyzeBody>,
) -> ApiResult<Json<RecordingView>> {
    let e = get_entry(&s.recordings, id, "recording")?;
    let params = analysis_params(b.strike, b.highpass_hz)?;
    let e2 = e.clone();
    let analysed = blocking(move || {
        let (rec, res) = analyze_file(&e2.path, &RecordingParams::default(), &params)?;
        Ok(Arc::new((
            AnalysisReport::new(&e2.name, &rec.codec, &res),
            res,
        )))
    })
    .await?;
    if let Ok(mut a) = e.analysis.lock() {
        *a = analysed;
    }
    Ok(Json(view(id, &e)))
}

fn file_response(
    path: &std::path::Path,
    mime: &'static str,
    download: Option<&str>,
) -> ApiResult<Response> {
    let bytes = std::fs::read(path).map_err(|e| {
        ApiError::new(
            StatusCode::NOT_FOUND,
            format!("cannot read {}: {e}", path.display()),
        )
    })?;
    Ok(bytes_response(bytes, mime, download))
}

/// `bytes` as a response of type `mime`, offered for download as `download` when given.
fn bytes_response(bytes: Vec<u8>, mime: &'static str, download: Option<&str>) -> Response {
    let mut res = ([(header::CONTENT_TYPE, mime)], bytes).into_response();
    if let Some(name) = download {
        let value = format!(
            "attachment; filename=\"{}\"",
            name.replace(['"', '\\'], "_")
        );
        if let Ok(v) = header::HeaderValue::from_str(&value) {
            res.headers_mut().insert(header::CONTENT_DISPOSITION, v);
        }
    }
    res
}

async fn recording_audio(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
) -> ApiResult<Response> {
    let e = get_entry(&s.recordings, id, "recording")?;
    file_response(&e.path, e.mime, None)
}

fn analysis_of(e: &RecordingEntry) -> Arc<(AnalysisReport, Analysis)> {
    e.analysis
        .lock()
        .map(|a| a.clone())
        .unwrap_or_else(|p| p.into_inner().clone())
}

/// The analysis picture: the strike's spectrogram with the fitted modes.
async fn recording_plot(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
) -> ApiResult<Response> {
    let e = get_entry(&s.recordings, id, "recording")?;
    let a = analysis_of(&e);
    let out = s.file(&format!("recording-{id}-{}.png", s.next_id()));
    let name = e.name.clone();
    let o = out.clone();
    blocking(move || {
        Ok(resound::plot::analysis_png(&o, &a.1, &name).map_err(resound::Error::from)?)
    })
    .await?;
    let res = file_response(&out, "image/png", None);
    let _ = std::fs::remove_file(&out);
    res
}

/// A WAV of float samples in memory, written through the library's writer.
fn wav_response(s: &AppState, samples: &[f32], fs: u32, download: &str) -> ApiResult<Response> {
    let path = s.file(&format!("tmp-{}.wav", s.next_id()));
    write_wav(&path, samples, fs, WavFormat::Float32).map_err(resound::Error::from)?;
    let res = file_response(&path, "audio/wav", Some(download));
    let _ = std::fs::remove_file(&path);
    res
}

/// The analysed strike (`recording`), its modes resynthesized (`modes`) or what they miss
/// (`residual`), aligned at the onset, as WAV.
async fn recording_part(
    State(s): State<Arc<AppState>>,
    Path((id, part)): Path<(u64, String)>,
) -> ApiResult<Response> {
    let e = get_entry(&s.recordings, id, "recording")?;
    let a = analysis_of(&e);
    let parts = resound::recording::resynthesis(&a.1);
    let x = match part.trim_end_matches(".wav") {
        "recording" => parts.recording,
        "modes" => parts.modes,
        "residual" => parts.residual,
        other => {
            return Err(ApiError::new(
                StatusCode::NOT_FOUND,
                format!("no part {other:?} (recording, modes or residual)"),
            ))
        }
    };
    let y: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    wav_response(
        &s,
        &y,
        a.1.sample_rate_hz as u32,
        &format!("{}-{part}", e.name),
    )
}

/// Mode `k` (from 1, by frequency) alone, normalized to −6 dBFS to be heard.
async fn recording_mode(
    State(s): State<Arc<AppState>>,
    Path((id, k)): Path<(u64, String)>,
) -> ApiResult<Response> {
    let e = get_entry(&s.recordings, id, "recording")?;
    let a = analysis_of(&e);
    let k: usize = k
        .trim_end_matches(".wav")
        .parse()
        .map_err(|_| ApiError::bad("a mode is a number from 1"))?;
    let x = resound::recording::one_mode(&a.1, k)?;
    wav_response(&s, &x, a.1.sample_rate_hz as u32, &format!("mode-{k}.wav"))
}

/// An object: a primitive with its sizes, solved with a reference material.
#[derive(Deserialize)]
struct ObjectBody {
    /// Primitive kind (`bar`, `plate`, `box`, `cylinder`, `sphere`, `bowl`), or `mesh`.
    kind: String,
    /// Its sizes, m (primitives).
    #[serde(default)]
    sizes_m: Vec<f64>,
    /// An uploaded mesh (`kind` = `mesh`).
    mesh: Option<u64>,
    /// Scale of the uploaded mesh's coordinates (0.001 for millimetres).
    #[serde(default = "one")]
    scale: f64,
    /// Segments around round shapes.
    #[serde(default = "default_segments")]
    segments: usize,
    /// Elastic modes to solve.
    #[serde(default = "default_modes")]
    modes: usize,
    /// Reference material of the solve (only E/ρ's ratio and ν matter for estimation).
    #[serde(default = "default_reference")]
    reference: String,
}

fn default_segments() -> usize {
    32
}
fn default_modes() -> usize {
    60
}
fn default_reference() -> String {
    "aluminium".into()
}

/// Most modes the page may ask for (more belongs in the CLI, with a mesh of its own).
const MAX_STUDIO_MODES: usize = 400;

#[derive(Serialize)]
struct SolvedObject {
    object: u64,
    primitive: Option<PrimitiveInfo>,
    report: ModalReport,
    /// The report as `resound modal` prints it.
    text: String,
}

/// Starts a modal solve of a primitive; the job's result is the [`ModalReport`].
async fn solve(
    State(s): State<Arc<AppState>>,
    Json(b): Json<ObjectBody>,
) -> ApiResult<Json<JobStatus>> {
    let source = match (b.kind.as_str(), b.mesh) {
        ("mesh", Some(id)) => Err(get_entry(&s.meshes, id, "mesh")?.path.clone()),
        ("mesh", None) => return Err(ApiError::bad("kind mesh needs an uploaded mesh")),
        (k, _) => Ok(PrimitiveKind::from_name(k)
            .ok_or_else(|| ApiError::bad(format!("no primitive {k:?}")))?),
    };
    if b.modes == 0 || b.modes > MAX_STUDIO_MODES {
        return Err(ApiError::bad(format!("modes must be 1–{MAX_STUDIO_MODES}")));
    }
    let reference = Material::parse(&b.reference).map_err(|e| ApiError::bad(e.to_string()))?;
    Ok(Json(jobs::spawn(&s, "solve", move |s, progress| {
        let id = s.next_id();
        let (mesh, scale, primitive) = match source {
            Ok(kind) => {
                let mesh = s.file(&format!("object-{id}.obj"));
                let p = write_primitive(kind, &b.sizes_m, b.segments, &mesh)
                    .map_err(|e| error_text(&e))?;
                (mesh, 1.0, Some(p))
            }
            Err(uploaded) => (uploaded, b.scale, None),
        };
        let job = SolveJob {
            mesh: mesh.clone(),
            scale,
            material: reference,
            modal: resound::modal::ModalParams {
                n_modes: Some(b.modes),
                ..Default::default()
            },
            transfer: None,
            hit_m: None,
            export_matrices: None,
        };
        let solved = solve_object(&job, progress).map_err(|e| error_text(&e))?;
        let model_path = s.file(&format!("object-{id}.rmodal"));
        resound::io::model_file::save(&model_path, &solved.model).map_err(|e| e.to_string())?;
        if let Ok(mut m) = s.objects.lock() {
            m.insert(id, Arc::new(ObjectEntry { model_path }));
        }
        serde_json::to_value(SolvedObject {
            object: id,
            primitive,
            text: solved.report.to_string(),
            report: solved.report,
        })
        .map_err(|e| e.to_string().into())
    })))
}

#[derive(Deserialize)]
struct SurfaceQuery {
    /// Colour by this mode's displacement (from 1).
    mode: Option<usize>,
}

/// The object's surface for the 3-D view, with a mode's displacement per vertex (0–1).
async fn surface(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
    Query(q): Query<SurfaceQuery>,
) -> ApiResult<Json<resound::object::SurfaceView>> {
    let e = get_entry(&s.objects, id, "object")?;
    let path = e.model_path.clone();
    blocking(move || {
        let model = resound::io::model_file::load(&path).map_err(resound::Error::from)?;
        Ok(Json(resound::object::SurfaceView::new(&model, q.mode)?))
    })
    .await
}

#[derive(Deserialize)]
struct ObjectModeBody {
    material: String,
    hit_m: [f64; 3],
    #[serde(default = "two")]
    duration_s: f64,
}

#[derive(Serialize)]
struct ObjectModeView {
    /// The sound, served as a render (`/api/renders/{id}`).
    render: u64,
    info: resound::strike::ObjectModeInfo,
}

/// Mode `k` of the object alone as `material` makes it sound at the hit
/// ([`resound::strike::object_mode`]), kept as a render.
async fn object_mode(
    State(s): State<Arc<AppState>>,
    Path((id, k)): Path<(u64, usize)>,
    Json(b): Json<ObjectModeBody>,
) -> ApiResult<Json<ObjectModeView>> {
    let obj = get_entry(&s.objects, id, "object")?;
    let material = material_name(&b.material)?.to_string();
    blocking(move || {
        let source = StrikeSource::Object {
            material,
            library: s.library.clone(),
            object: obj.model_path.clone(),
            object_params: Default::default(),
            hit_m: b.hit_m,
        };
        let fs = StrikeParams::default().sample_rate_hz;
        let (x, info) = resound::strike::object_mode(&source, k, b.duration_s, fs)?;
        let render = s.next_id();
        let wav = s.file(&format!("render-{render}.wav"));
        write_wav(&wav, &x, fs, WavFormat::Float32).map_err(resound::Error::from)?;
        if let Ok(mut m) = s.renders.lock() {
            m.insert(render, Arc::new(RenderEntry { wav }));
        }
        Ok(Json(ObjectModeView { render, info }))
    })
    .await
}

async fn object_model(State(s): State<Arc<AppState>>, Path(id): Path<u64>) -> ApiResult<Response> {
    let e = get_entry(&s.objects, id, "object")?;
    file_response(
        &e.model_path,
        "application/octet-stream",
        Some("object.rmodal"),
    )
}

#[derive(Deserialize)]
struct EstimateBody {
    recording: u64,
    object: u64,
    hit_m: [f64; 3],
    /// Keep a fit that is not credible (as `--allow-implausible`); refused otherwise.
    #[serde(default)]
    allow_implausible: bool,
}

#[derive(Serialize)]
struct EstimateView {
    estimate: u64,
    material: SoundMaterial,
    info: resound::material::EstimateInfo,
    /// The report as `resound estimate` prints it.
    text: String,
    notes: Vec<String>,
}

/// Starts an estimate of the material from a recording of the object struck at `hit_m`.
async fn estimate(
    State(s): State<Arc<AppState>>,
    Json(b): Json<EstimateBody>,
) -> ApiResult<Json<JobStatus>> {
    let rec = get_entry(&s.recordings, b.recording, "recording")?;
    let obj = get_entry(&s.objects, b.object, "object")?;
    let strike = analysis_of(&rec).1.strike;
    Ok(Json(jobs::spawn(&s, "estimate", move |s, progress| {
        let job = resound::material::EstimateFiles {
            recordings: vec![rec.path.clone()],
            recording: RecordingParams::default(),
            analyze: AnalyzeParams {
                strike: Some(strike),
                ..AnalyzeParams::default()
            },
            select: Default::default(),
            object: obj.model_path.clone(),
            object_params: Default::default(),
            hit_m: b.hit_m,
            params: resound::material::EstimateMaterialParams {
                name: rec
                    .name
                    .rsplit_once('.')
                    .map_or(rec.name.as_str(), |p| p.0)
                    .to_string(),
                recording_name: rec.name.clone(),
                allow_implausible: b.allow_implausible,
                ..Default::default()
            },
        };
        let out = resound::material::estimate_files(&job, progress).map_err(|e| match &e {
            // Refused: why, how to keep it, and the fit report the CLI prints before refusing.
            resound::Error::Implausible(_, info) => jobs::StepError {
                message: format!(
                    "{}; tick \"keep a fit that is not credible\" to keep it",
                    error_text(&e)
                ),
                report: info.as_ref().map(|i| i.to_string()),
            },
            _ => error_text(&e).into(),
        })?;
        let id = s.next_id();
        let view = EstimateView {
            estimate: id,
            material: out.material.clone(),
            text: out.info.to_string(),
            info: out.info.clone(),
            notes: out.notes.clone(),
        };
        if let Ok(mut m) = s.estimates.lock() {
            m.insert(
                id,
                Arc::new(EstimateEntry {
                    material: out.material.clone(),
                    outcome: out,
                    settings: job.params.estimate.clone(),
                    title: rec.name.clone(),
                    plot: std::sync::Mutex::new(None),
                }),
            );
        }
        serde_json::to_value(view).map_err(|e| e.to_string().into())
    })))
}

async fn estimate_material(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
) -> ApiResult<Response> {
    let e = get_entry(&s.estimates, id, "estimate")?;
    let json = serde_json::to_string_pretty(&e.material)
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?;
    let mut res = ([(header::CONTENT_TYPE, "application/json")], json).into_response();
    let value = format!(
        "attachment; filename=\"{}.json\"",
        safe_file_name(&e.material.name)
    );
    if let Ok(v) = header::HeaderValue::from_str(&value) {
        res.headers_mut().insert(header::CONTENT_DISPOSITION, v);
    }
    Ok(res)
}

fn safe_file_name(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

async fn estimate_plot(State(s): State<Arc<AppState>>, Path(id): Path<u64>) -> ApiResult<Response> {
    let e = get_entry(&s.estimates, id, "estimate")?;
    let path = s.file(&format!("estimate-{id}.png"));
    let (e2, p) = (e.clone(), path.clone());
    blocking(move || {
        let mut made = e2.plot.lock().unwrap_or_else(|p| p.into_inner());
        if made.is_none() {
            e2.outcome.plot(&p, &e2.title, &e2.settings)?;
            *made = Some(p);
        }
        Ok(())
    })
    .await?;
    file_response(&path, "image/png", None)
}

/// A material name from the page: a name (library, built-in or `preset:NAME`), never a path.
fn material_name(name: &str) -> ApiResult<&str> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || " _-.:".contains(c))
        && !name.contains("..")
        && !name.to_ascii_lowercase().ends_with(".json");
    if ok {
        Ok(name)
    } else {
        Err(ApiError::bad(format!(
            "{name:?} is not a material name (letters, digits, space, _ - . :; at most 64)"
        )))
    }
}

#[derive(Deserialize)]
struct SaveBody {
    estimate: u64,
    name: String,
    #[serde(default)]
    replace: bool,
}

/// Saves an estimated material in the library under a name; an existing name is refused
/// (409) unless `replace`.
async fn save_material(
    State(s): State<Arc<AppState>>,
    Json(b): Json<SaveBody>,
) -> ApiResult<Json<serde_json::Value>> {
    let e = get_entry(&s.estimates, b.estimate, "estimate")?;
    let name = material_name(b.name.trim())?.to_string();
    if name.contains(':') {
        return Err(ApiError::bad("a saved material's name has no ':'"));
    }
    let mut m = e.material.clone();
    m.name = name.clone();
    let lib = s.library.clone();
    blocking(move || {
        Ok(resound::material::store_material(
            lib.as_deref(),
            &m,
            b.replace,
        )?)
    })
    .await?;
    Ok(Json(serde_json::json!({ "saved": name })))
}

async fn materials(State(s): State<Arc<AppState>>) -> ApiResult<Json<resound::material::Listing>> {
    let lib = s.library.clone();
    blocking(move || Ok(Json(resound::material::list_library(lib.as_deref())?))).await
}

async fn material_json(
    State(s): State<Arc<AppState>>,
    Path(name): Path<String>,
) -> ApiResult<Json<SoundMaterial>> {
    let name = material_name(&name)?.to_string();
    let lib = s.library.clone();
    blocking(move || {
        let l = resound::material::read_library(lib.as_deref())?;
        Ok(Json(resound::material::library_material(
            l.as_ref(),
            &name,
        )?))
    })
    .await
}

async fn remove_material(
    State(s): State<Arc<AppState>>,
    Path(name): Path<String>,
) -> ApiResult<Json<serde_json::Value>> {
    let name = material_name(&name)?.to_string();
    let lib = s.library.clone();
    blocking(move || {
        resound::material::remove_material(lib.as_deref(), &name)?;
        Ok(Json(serde_json::json!({ "removed": name })))
    })
    .await
}

#[derive(Deserialize)]
struct RenderBody {
    material: String,
    object: u64,
    hit_m: [f64; 3],
    #[serde(default = "one")]
    speed_m_s: f64,
    #[serde(default = "two")]
    duration_s: f64,
    /// Where the microphone is (model coordinates, m): each mode weighted by what it radiates
    /// there (`resound synth --mic`).
    mic_m: Option<[f64; 3]>,
    /// The impactor's material (a preset name: steel, glass, wood, …).
    #[serde(default = "steel")]
    impactor: String,
    /// The impactor's radius at the contact, m (its mass: a sphere of that radius).
    #[serde(default = "five_mm")]
    impactor_radius_m: f64,
}

fn steel() -> String {
    "steel".into()
}
fn five_mm() -> f64 {
    0.005
}

fn one() -> f64 {
    1.0
}
fn two() -> f64 {
    2.0
}

#[derive(Serialize)]
struct RenderView {
    render: u64,
    info: resound::strike::StrikeInfo,
    notes: Vec<String>,
}

/// Starts a render of one strike of a material on an object; the WAV is what `resound synth`
/// writes for the same inputs (24-bit, turned down only when it would clip).
async fn render(
    State(s): State<Arc<AppState>>,
    Json(b): Json<RenderBody>,
) -> ApiResult<Json<JobStatus>> {
    let obj = get_entry(&s.objects, b.object, "object")?;
    let material = material_name(&b.material)?.to_string();
    let impactor = Material::preset(&b.impactor).map_err(|e| ApiError::bad(e.to_string()))?;
    Ok(Json(jobs::spawn(&s, "render", move |s, progress| {
        let source = StrikeSource::Object {
            material,
            library: s.library.clone(),
            object: obj.model_path.clone(),
            object_params: Default::default(),
            hit_m: b.hit_m,
        };
        let params = StrikeParams {
            speed_m_s: b.speed_m_s,
            duration_s: b.duration_s,
            mic_m: b.mic_m,
            impactor,
            impactor_radius_m: b.impactor_radius_m,
            ..StrikeParams::default()
        };
        let (mut strike, mut notes) =
            render_strike_from(&source, &params, progress).map_err(|e| error_text(&e))?;
        notes.extend(resound::strike::level_for_file(&mut strike).map_err(|e| error_text(&e))?);
        let id = s.next_id();
        let wav = s.file(&format!("render-{id}.wav"));
        write_wav(
            &wav,
            &strike.samples,
            params.sample_rate_hz,
            WavFormat::Pcm24,
        )
        .map_err(|e| e.to_string())?;
        if let Ok(mut m) = s.renders.lock() {
            m.insert(id, Arc::new(RenderEntry { wav }));
        }
        serde_json::to_value(RenderView {
            render: id,
            info: strike.info,
            notes,
        })
        .map_err(|e| e.to_string().into())
    })))
}

async fn render_wav(State(s): State<Arc<AppState>>, Path(id): Path<String>) -> ApiResult<Response> {
    let id: u64 = id
        .trim_end_matches(".wav")
        .parse()
        .map_err(|_| ApiError::bad("a render is a number"))?;
    let e = get_entry(&s.renders, id, "render")?;
    file_response(&e.wav, "audio/wav", Some(&format!("render-{id}.wav")))
}

#[derive(Deserialize)]
struct CompareQuery {
    recording: u64,
    render: u64,
}

/// The log-mel distance between a recording and a render (`resound compare`).
async fn compare(
    State(s): State<Arc<AppState>>,
    Query(q): Query<CompareQuery>,
) -> ApiResult<Json<resound::signal::compare::LogMelDistance>> {
    let a = get_entry(&s.recordings, q.recording, "recording")?;
    let b = get_entry(&s.renders, q.render, "render")?;
    blocking(move || {
        Ok(Json(resound::recording::compare_files(
            &a.path,
            None,
            &b.wav,
            None,
            &Default::default(),
        )?))
    })
    .await
}

fn job_entry(s: &AppState, id: u64) -> ApiResult<Arc<jobs::Job>> {
    get_entry(&s.jobs, id, "job")
}

async fn job(State(s): State<Arc<AppState>>, Path(id): Path<u64>) -> ApiResult<Json<JobStatus>> {
    let j = job_entry(&s, id)?;
    let status = j.status.borrow().clone();
    Ok(Json(status))
}

async fn cancel_job(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
) -> ApiResult<Json<JobStatus>> {
    let j = job_entry(&s, id)?;
    j.cancel();
    let status = j.status.borrow().clone();
    Ok(Json(status))
}

/// The job's status as server-sent events: one per change, the last when it finishes.
async fn job_events(
    State(s): State<Arc<AppState>>,
    Path(id): Path<u64>,
) -> ApiResult<Sse<impl futures_util::Stream<Item = Result<Event, std::convert::Infallible>>>> {
    let rx = job_entry(&s, id)?.status.subscribe();
    let stream =
        futures_util::stream::unfold((rx, true, false), |(mut rx, first, done)| async move {
            if done {
                return None;
            }
            if !first && rx.changed().await.is_err() {
                return None;
            }
            let status = rx.borrow_and_update().clone();
            let event = Event::default()
                .json_data(&status)
                .unwrap_or_else(|_| Event::default().data("{}"));
            Some((Ok(event), (rx, false, status.is_finished())))
        });
    Ok(Sse::new(stream).keep_alive(KeepAlive::default()))
}

#[derive(Deserialize)]
struct MeshQuery {
    name: String,
    /// Scale of its coordinates (0.001 for millimetres).
    #[serde(default = "one")]
    scale: f64,
}

#[derive(Serialize)]
struct MeshView {
    mesh: u64,
    name: String,
    report: resound::mesh::MeshReport,
    /// The check as `resound mesh check` prints it.
    text: String,
}

/// `POST /api/meshes?name=cup.obj&scale=0.001` with the file as the body: stored under a
/// generated name and checked (`resound mesh check`).
async fn upload_mesh(
    State(s): State<Arc<AppState>>,
    Query(q): Query<MeshQuery>,
    body: Bytes,
) -> ApiResult<Json<MeshView>> {
    let name = display_name(&q.name);
    let ext = name
        .rsplit_once('.')
        .map(|p| p.1.to_ascii_lowercase())
        .filter(|e| ["obj", "stl", "ply"].contains(&e.as_str()))
        .ok_or_else(|| {
            ApiError::bad(format!("{name}: not a mesh we read here (OBJ, STL or PLY)"))
        })?;
    if body.is_empty() {
        return Err(ApiError::bad(format!("{name} is empty")));
    }
    let id = s.next_id();
    let path = s.file(&format!("mesh-{id}.{ext}"));
    std::fs::write(&path, &body).map_err(|e| {
        ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("cannot store the upload: {e}"),
        )
    })?;
    let p = path.clone();
    let scale = q.scale;
    let checked = blocking(move || Ok(resound::mesh::check_mesh(&p, scale, 0)?)).await;
    let report = match checked {
        Ok(r) => r,
        Err(e) => {
            let _ = std::fs::remove_file(&path);
            return Err(e);
        }
    };
    if let Ok(mut m) = s.meshes.lock() {
        m.insert(id, Arc::new(MeshEntry { path }));
    }
    Ok(Json(MeshView {
        mesh: id,
        name,
        text: report.to_string(),
        report,
    }))
}

/// The render's analysis picture (its spectrogram with the modes found), to set beside the
/// recording's.
async fn render_plot(State(s): State<Arc<AppState>>, Path(id): Path<u64>) -> ApiResult<Response> {
    let e = get_entry(&s.renders, id, "render")?;
    let out = s.file(&format!("render-{id}-{}.png", s.next_id()));
    let (wav, o) = (e.wav.clone(), out.clone());
    blocking(move || {
        // The analysis without its "no modes is an error" rule: a render that is mostly
        // residual still gets its spectrogram (with no modes marked).
        let rec = resound::recording::load_recording(&wav, &RecordingParams::default())?;
        let fs = f64::from(rec.sample_rate_hz);
        let res = resound::signal::analyze(&rec.samples, fs, &AnalyzeParams::default())
            .map_err(resound::Error::from)?;
        resound::plot::analysis_png(&o, &res, &format!("render {id}"))
            .map_err(resound::Error::from)?;
        Ok(())
    })
    .await?;
    let res = file_response(&out, "image/png", None);
    let _ = std::fs::remove_file(&out);
    res
}

#[derive(Deserialize)]
struct ReplaceQuery {
    #[serde(default)]
    replace: bool,
}

/// Imports a material file (the JSON `materials export` and the page's download write) into
/// the library, with the file's own checks; an existing name needs `?replace=true`.
async fn import_material(
    State(s): State<Arc<AppState>>,
    Query(q): Query<ReplaceQuery>,
    body: Bytes,
) -> ApiResult<Json<serde_json::Value>> {
    let path = s.file(&format!("import-{}.json", s.next_id()));
    std::fs::write(&path, &body).map_err(|e| {
        ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("cannot store the upload: {e}"),
        )
    })?;
    let lib = s.library.clone();
    let p = path.clone();
    let stored = blocking(move || {
        let m = resound::io::library::read_material(&p).map_err(resound::Error::from)?;
        material_name(&m.name)?;
        resound::material::store_material(lib.as_deref(), &m, q.replace)?;
        Ok(m.name)
    })
    .await;
    let _ = std::fs::remove_file(&path);
    Ok(Json(serde_json::json!({ "imported": stored? })))
}

#[derive(Deserialize)]
struct RenameBody {
    to: String,
    #[serde(default)]
    replace: bool,
}

/// Renames a library entry; an existing target name needs `replace`.
async fn rename_material(
    State(s): State<Arc<AppState>>,
    Path(name): Path<String>,
    Json(b): Json<RenameBody>,
) -> ApiResult<Json<serde_json::Value>> {
    let from = material_name(&name)?.to_string();
    let to = material_name(b.to.trim())?.to_string();
    if to.contains(':') {
        return Err(ApiError::bad("a saved material's name has no ':'"));
    }
    let lib = s.library.clone();
    blocking(move || {
        resound::material::rename_material(lib.as_deref(), &from, &to, b.replace)?;
        Ok(Json(serde_json::json!({ "renamed": from, "to": to })))
    })
    .await
}

#[derive(Serialize)]
struct SceneView {
    render: u64,
    summary: resound::scene::SceneSummary,
    /// The summary as `resound scene` prints it.
    text: String,
    events: Vec<resound::physics::Event>,
}

/// The scene file's fields that name files: a scene from the page names materials only.
fn scene_names_no_files(scene: &resound::io::scene::SceneFile) -> ApiResult<()> {
    use resound::io::scene::{MaterialSpec, ShapeFile, SoundFile};
    for b in &scene.body {
        let who = &b.name;
        if matches!(b.shape, ShapeFile::Mesh(_)) {
            return Err(ApiError::bad(format!(
                "body {who:?}: the studio's scenes use primitive shapes (solve a mesh as an object)"
            )));
        }
        if let MaterialSpec::Name(n) = &b.material {
            material_name(n).map_err(|e| ApiError::bad(format!("body {who:?}: {}", e.message)))?;
        }
        if b.stats.is_some() || b.surface.is_some() || !matches!(b.sound, SoundFile::Flag(_)) {
            return Err(ApiError::bad(format!(
                "body {who:?}: statistics, grains and surface files are not taken from the page"
            )));
        }
    }
    Ok(())
}

/// Renders a scene sent as the scene file's document (JSON): the scene file's checks and
/// messages, the offline renderer, a WAV and the event log.
async fn scene(State(s): State<Arc<AppState>>, body: Bytes) -> ApiResult<Json<JobStatus>> {
    let scene: resound::io::scene::SceneFile =
        serde_json::from_slice(&body).map_err(|e| ApiError::bad(format!("scene: {e}")))?;
    scene_names_no_files(&scene)?;
    Ok(Json(jobs::spawn(&s, "scene", move |s, progress| {
        let params = resound::scene::SceneRenderParams {
            library: s.library.clone(),
            cache_dir: Some(s.file("models")),
            keep_level: false,
            live: None,
        };
        let r = resound::scene::render_scene_value(scene, "scene", &s.work, &params, progress)
            .map_err(|e| error_text(&e))?;
        let id = s.next_id();
        let wav = s.file(&format!("render-{id}.wav"));
        let refs: Vec<&[f32]> = r.channels.iter().map(|c| c.as_slice()).collect();
        resound::io::write_wav_channels(&wav, &refs, r.sample_rate_hz, WavFormat::Pcm24)
            .map_err(|e| e.to_string())?;
        if let Ok(mut m) = s.renders.lock() {
            m.insert(id, Arc::new(RenderEntry { wav }));
        }
        serde_json::to_value(SceneView {
            render: id,
            text: r.summary.to_string(),
            summary: r.summary,
            events: r.events,
        })
        .map_err(|e| e.to_string().into())
    })))
}

#[derive(Deserialize)]
struct KeptFileQuery {
    name: String,
    #[serde(default)]
    replace: bool,
}

/// Keeps a statistics file or a grain dictionary (the body) in the library under `?name=`,
/// after reading it back as one; an existing one of that kind and name needs `&replace=true`.
async fn store_kept_file(
    State(s): State<Arc<AppState>>,
    Query(q): Query<KeptFileQuery>,
    body: Bytes,
) -> ApiResult<Json<resound::io::library::LibraryFile>> {
    let name = material_name(q.name.trim())?.to_string();
    let lib = s.library.clone();
    blocking(move || {
        Ok(Json(resound::material::store_file(
            lib.as_deref(),
            &name,
            &body,
            q.replace,
        )?))
    })
    .await
}

fn kept_kind(kind: &str) -> ApiResult<resound::io::library::FileKind> {
    resound::io::library::FileKind::from_name(kind).ok_or_else(|| {
        ApiError::new(
            StatusCode::NOT_FOUND,
            format!("no kind {kind:?} (statistics or grains)"),
        )
    })
}

/// A kept file's bytes, offered as `name.stats.json` or `name.grains`.
async fn kept_file(
    State(s): State<Arc<AppState>>,
    Path((kind, name)): Path<(String, String)>,
) -> ApiResult<Response> {
    let kind = kept_kind(&kind)?;
    let name = material_name(&name)?.to_string();
    let lib = s.library.clone();
    blocking(move || {
        let bytes = resound::material::kept_file(lib.as_deref(), kind, &name)?;
        let mime = match kind {
            resound::io::library::FileKind::Statistics => "application/json",
            resound::io::library::FileKind::Grains => "application/octet-stream",
        };
        Ok(bytes_response(bytes, mime, Some(&kind.file_name(&name))))
    })
    .await
}

async fn remove_kept_file(
    State(s): State<Arc<AppState>>,
    Path((kind, name)): Path<(String, String)>,
) -> ApiResult<Json<serde_json::Value>> {
    let kind = kept_kind(&kind)?;
    let name = material_name(&name)?.to_string();
    let lib = s.library.clone();
    blocking(move || {
        resound::material::remove_file(lib.as_deref(), kind, &name)?;
        Ok(Json(serde_json::json!({ "removed": name, "kind": kind })))
    })
    .await
}
