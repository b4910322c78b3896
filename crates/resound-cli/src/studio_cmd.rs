//! `resound studio`: the local web app (crates/resound-studio).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `studio`.
#[derive(Args, Debug)]
pub struct StudioArgs {
    /// Port to listen on (0: any free one; the address is printed).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Address to listen on. Anything but loopback makes the studio (and the material library
    /// it writes) reachable by anyone who can reach this machine.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: std::net::IpAddr,
    /// Open the page in the default browser.
    #[arg(long)]
    pub open: bool,
    /// Material library (default: $RESOUND_LIBRARY or ~/.local/share/resound/materials.sqlite).
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Keep the session's files (uploads, models, renders) in this folder instead of a
    /// temporary one that is removed at exit.
    #[arg(long)]
    pub work_dir: Option<PathBuf>,
    /// Largest upload, MB.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u64).range(1..=4096))]
    pub max_upload_mb: u64,
}

/// Runs `studio` until interrupted.
pub fn run(a: StudioArgs) -> Result<()> {
    let params = resound_studio::StudioParams {
        host: a.host,
        port: a.port,
        library: a.library,
        max_upload_bytes: (a.max_upload_mb << 20) as usize,
        work_dir: a.work_dir,
    };
    if let Some(w) = params.exposure_warning() {
        eprintln!("warning: {w}");
    }
    resound_studio::serve(&params, |addr| {
        let url = format!("http://{addr}/");
        println!("Resound Studio at {url} (Ctrl-C stops it)");
        if a.open {
            if let Err(e) = resound_studio::open_in_browser(&url) {
                eprintln!("note: could not open a browser ({e}); open {url} yourself");
            }
        }
    })?;
    Ok(())
}
