//! File formats at the edge of Resound: meshes in, modal models in and out, matrices out.
//! Every writer is atomic: it writes a temporary file beside the target and renames it.
//!
//! # Formats
//! | kind | extensions | notes |
//! |---|---|---|
//! | surface mesh | `.obj`, `.stl` (ASCII/binary), `.ply` (ASCII/binary LE/BE) | read; OBJ/STL/PLY written |
//! | tet mesh | `.msh` (gmsh 2.2 and 4.1, ASCII and binary), `.node`+`.ele` (TetGen), `.mesh` (MEDIT) | read; surface-only files load as surfaces |
//! | modal model | `.rmodal` | versioned little-endian binary with a checksum ([`model_file`]) |
//! | matrices | Matrix Market `.mtx` | `coordinate real symmetric` (lower triangle) |
//! | material | `.json` material files; SQLite material library ([`library`]) |
//! | grain dictionary | `.grains` | grains (16-bit) and correlation patterns, checksummed ([`grains_file`]) |
//! | audio | `.wav` (PCM 8/16/24/32, float 32/64), `.flac`, `.ogg` (Vorbis), `.mp3` | read via Symphonia; WAV written via hound |
#![warn(missing_docs)]

pub mod atomic;
pub mod audio;
pub mod grains_file;
pub mod library;
pub mod mesh;
pub mod model_file;
pub mod mtx;
pub mod npy;
mod ply;
pub mod scene;
mod tetfile;

pub use audio::{load_audio, write_wav, write_wav_channels, AudioClip, WavFormat};
pub use mesh::{load_mesh, save_surface, LoadedMesh};

use std::path::PathBuf;

/// Errors of file I/O.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IoError {
    /// The OS refused.
    // Not a `source` field: `{:#}` chains would print the OS message twice.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        error: std::io::Error,
    },
    /// The content is malformed.
    #[error("{path}: {msg}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line number where known.
        msg: String,
    },
    /// Unknown extension.
    #[error("{path}: unsupported file type (known: .obj .stl .ply .msh .node .ele .mesh .rmodal)")]
    Unsupported {
        /// The file.
        path: PathBuf,
    },
}

/// `Result` with [`IoError`].
pub type Result<T> = std::result::Result<T, IoError>;

pub(crate) fn parse_err(path: &std::path::Path, msg: impl Into<String>) -> IoError {
    IoError::Parse {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

pub(crate) fn io_err(path: &std::path::Path, error: std::io::Error) -> IoError {
    IoError::Io {
        path: path.to_path_buf(),
        error,
    }
}
