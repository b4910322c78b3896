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
    /// Largest upload, MB.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u64).range(1..=4096))]
    pub max_upload_mb: u64,
}

/// Runs `studio` until interrupted.
pub fn run(a: StudioArgs) -> Result<()> {
    if !a.host.is_loopback() {
        eprintln!(
            "warning: listening on {}: anyone who can reach this machine can use the studio and \
             change the material library",
            a.host
        );
    }
    let params = resound_studio::StudioParams {
        host: a.host,
        port: a.port,
        library: a.library,
        max_upload_bytes: (a.max_upload_mb << 20) as usize,
        work_dir: None,
    };
    resound_studio::serve(&params, |addr| {
        let url = format!("http://{addr}/");
        println!("Resound Studio at {url} (Ctrl-C stops it)");
        if a.open {
            open_browser(&url);
        }
    })?;
    Ok(())
}

/// Asks the desktop to open `url`; says so when it cannot.
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else {
        "xdg-open"
    };
    if let Err(e) = std::process::Command::new(opener)
        .arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
    {
        eprintln!("note: could not open a browser ({opener}: {e}); open {url} yourself");
    }
}
