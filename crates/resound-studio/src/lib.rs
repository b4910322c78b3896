//! Resound Studio: a local web app where a sound designer sees and hears the pipeline.
//!
//! `resound studio` serves a single page (bundled into the binary: no CDN, no build step) and an
//! HTTP API that only translates: each endpoint calls one library step and returns its typed
//! report as JSON ([`resound::recording::AnalysisReport`], [`resound::object::ModalReport`],
//! [`resound::material::EstimateInfo`], [`resound::strike::StrikeInfo`], …). Long steps run as
//! jobs on the blocking pool; their [`resound::Progress`] reaches the page by server-sent
//! events, and a job can be cancelled.
//!
//! Safety (it is a server): it binds 127.0.0.1 unless told otherwise; every request's `Host`
//! (and `Origin`, when sent) must be the server's own, which defeats DNS rebinding; uploads
//! are size-limited and stored under generated names in a per-session work folder; material
//! names are names, never paths; errors are JSON messages, never a stack trace.

mod api;
mod jobs;
mod web;

use axum::http::{header, HeaderValue, Request, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

pub use jobs::{JobState, JobStatus};

/// How to run the studio.
#[derive(Clone, Debug)]
pub struct StudioParams {
    /// Address to bind (127.0.0.1 by default; anything else is reachable from the network).
    pub host: IpAddr,
    /// Port (0: any free one).
    pub port: u16,
    /// Material library (`None`: the default one).
    pub library: Option<PathBuf>,
    /// Largest upload, bytes.
    pub max_upload_bytes: usize,
    /// Work folder of this session (`None`: a temporary one, removed at exit).
    pub work_dir: Option<PathBuf>,
}

impl Default for StudioParams {
    fn default() -> Self {
        Self {
            host: IpAddr::from([127, 0, 0, 1]),
            port: 8765,
            library: None,
            max_upload_bytes: 64 << 20,
            work_dir: None,
        }
    }
}

impl StudioParams {
    /// What to tell the user when the address is reachable from the network.
    pub fn exposure_warning(&self) -> Option<String> {
        (!self.host.is_loopback()).then(|| {
            format!(
                "listening on {}: anyone who can reach this machine can use the studio and \
                 change the material library",
                self.host
            )
        })
    }
}

/// Asks the desktop to open `url` (`xdg-open`, `open` on macOS).
///
/// # Errors
/// The opener cannot be started.
pub fn open_in_browser(url: &str) -> std::io::Result<()> {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else {
        "xdg-open"
    };
    std::process::Command::new(opener)
        .arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .map(|_| ())
}

/// Why the studio could not start.
#[derive(Debug, thiserror::Error)]
pub enum StudioError {
    /// The address could not be bound (in use, not permitted).
    #[error("cannot listen on {addr}: {error}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// Why.
        error: std::io::Error,
    },
    /// The work folder or the runtime could not be made.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// What the server keeps for a session: files in the work folder, by id.
pub(crate) struct AppState {
    pub(crate) work: PathBuf,
    _temp: Option<tempfile::TempDir>,
    pub(crate) library: Option<PathBuf>,
    pub(crate) max_upload_bytes: usize,
    allowed_hosts: Vec<String>,
    next_id: AtomicU64,
    pub(crate) recordings: Mutex<HashMap<u64, Arc<api::RecordingEntry>>>,
    pub(crate) objects: Mutex<HashMap<u64, Arc<api::ObjectEntry>>>,
    pub(crate) estimates: Mutex<HashMap<u64, Arc<api::EstimateEntry>>>,
    pub(crate) renders: Mutex<HashMap<u64, Arc<api::RenderEntry>>>,
    pub(crate) meshes: Mutex<HashMap<u64, Arc<api::MeshEntry>>>,
    pub(crate) jobs: Mutex<HashMap<u64, Arc<jobs::Job>>>,
}

impl AppState {
    pub(crate) fn next_id(&self) -> u64 {
        self.next_id.fetch_add(1, Ordering::Relaxed)
    }

    /// A path in the work folder for a generated name (never one a request chose).
    pub(crate) fn file(&self, name: &str) -> PathBuf {
        self.work.join(name)
    }
}

/// A studio ready to serve: its router and the address it answers to.
pub struct Studio {
    state: Arc<AppState>,
}

impl Studio {
    /// Makes the session (its work folder) for a server that will answer at `addr`.
    ///
    /// # Errors
    /// The work folder cannot be made.
    pub fn new(params: &StudioParams, addr: SocketAddr) -> Result<Self, StudioError> {
        let (work, temp) = match &params.work_dir {
            Some(d) => {
                std::fs::create_dir_all(d)?;
                (d.clone(), None)
            }
            None => {
                let t = tempfile::Builder::new()
                    .prefix("resound-studio-")
                    .tempdir()?;
                (t.path().to_path_buf(), Some(t))
            }
        };
        let port = addr.port();
        let mut allowed_hosts = vec![format!("localhost:{port}")];
        allowed_hosts.push(match addr.ip() {
            IpAddr::V4(ip) => format!("{ip}:{port}"),
            IpAddr::V6(ip) => format!("[{ip}]:{port}"),
        });
        if addr.ip().is_loopback() {
            allowed_hosts.push(format!("127.0.0.1:{port}"));
            allowed_hosts.push(format!("[::1]:{port}"));
        }
        jobs::quiet_cancellation();
        Ok(Self {
            state: Arc::new(AppState {
                work,
                _temp: temp,
                library: params.library.clone(),
                max_upload_bytes: params.max_upload_bytes,
                allowed_hosts,
                next_id: AtomicU64::new(1),
                recordings: Mutex::default(),
                objects: Mutex::default(),
                estimates: Mutex::default(),
                renders: Mutex::default(),
                meshes: Mutex::default(),
                jobs: Mutex::default(),
            }),
        })
    }

    /// The `Host` values this studio answers to.
    pub fn allowed_hosts(&self) -> &[String] {
        &self.state.allowed_hosts
    }

    /// The router: the page, the API, and the Host/Origin guard in front of both.
    pub fn router(&self) -> axum::Router {
        api::routes(self.state.clone()).merge(web::routes()).layer(
            axum::middleware::from_fn_with_state(self.state.clone(), guard),
        )
    }
}

/// Refuses a request whose `Host` is not the server's own or whose `Origin` (when sent) is
/// not the server's page: a page elsewhere cannot drive the studio, even through a DNS name
/// that resolves to 127.0.0.1.
async fn guard(
    axum::extract::State(s): axum::extract::State<Arc<AppState>>,
    req: Request<axum::body::Body>,
    next: Next,
) -> Response {
    let host = req
        .headers()
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    if !s.allowed_hosts.iter().any(|a| a.eq_ignore_ascii_case(host)) {
        return api::ApiError::new(
            StatusCode::FORBIDDEN,
            format!("Host {host:?} is not this studio's address"),
        )
        .into_response();
    }
    if let Some(origin) = req.headers().get(header::ORIGIN) {
        let origin = origin.to_str().unwrap_or("");
        let ours = s
            .allowed_hosts
            .iter()
            .any(|a| origin.eq_ignore_ascii_case(&format!("http://{a}")));
        if !ours {
            return api::ApiError::new(
                StatusCode::FORBIDDEN,
                format!(
                    "requests from {origin:?} are refused (only this studio's page may call it)"
                ),
            )
            .into_response();
        }
    }
    let mut res = next.run(req).await;
    let h = res.headers_mut();
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(
            "default-src 'self'; img-src 'self' blob: data:; media-src 'self' blob:; \
             frame-ancestors 'none'",
        ),
    );
    res
}

/// Serves the studio until the process ends; `ready` hears the address once it listens.
///
/// # Errors
/// The address cannot be bound; the runtime or work folder cannot be made.
pub fn serve(params: &StudioParams, ready: impl FnOnce(SocketAddr)) -> Result<(), StudioError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    rt.block_on(async {
        let want = SocketAddr::new(params.host, params.port);
        let listener = tokio::net::TcpListener::bind(want)
            .await
            .map_err(|error| StudioError::Bind { addr: want, error })?;
        let addr = listener.local_addr()?;
        let studio = Studio::new(params, addr)?;
        ready(addr);
        axum::serve(listener, studio.router()).await?;
        Ok(())
    })
}
