//! Atomic file writes: never leave a half-written output behind.

use crate::{io_err, Result};
use std::io::Write;
use std::path::Path;

/// Writes `path` by calling `f` on a buffered temporary file in the same directory, then renames
/// it over `path`. On any error the temporary file is removed and `path` is untouched. The file
/// gets the usual permissions of a new file (0666 less the process umask, like `File::create`),
/// not the temporary file's private 0600.
///
/// # Errors
/// [`crate::IoError::Io`] from creating, writing or renaming.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    // An output that is a symlink is written through (to its target), not replaced by a file.
    let resolved;
    let path = if path.is_symlink() {
        resolved = std::fs::canonicalize(path).map_err(|e| io_err(path, e))?;
        resolved.as_path()
    } else {
        path
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".resound-tmp-");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The mode given to open(2), which the kernel masks with the umask.
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    if !dir.is_dir() {
        return Err(io_err(
            path,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("the directory {} does not exist", dir.display()),
            ),
        ));
    }
    // tempfile names its own (temporary) path in its errors; the user's path is the one to name.
    let tmp = builder
        .tempfile_in(dir)
        .map_err(|e| io_err(path, std::io::Error::new(e.kind(), e.kind().to_string())))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        f(&mut w).map_err(|e| io_err(path, e))?;
        w.flush().map_err(|e| io_err(path, e))?;
    }
    tmp.persist(path).map_err(|e| io_err(path, e.error))?;
    Ok(())
}

#[cfg(all(test, unix))]
mod tests {
    use super::write_atomic;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn outputs_get_the_permissions_of_a_new_file() {
        let dir = tempfile::tempdir().unwrap();
        let reference = dir.path().join("plain");
        std::fs::File::create(&reference).unwrap();
        let atomic = dir.path().join("atomic");
        write_atomic(&atomic, |w| w.write_all(b"x")).unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&atomic), mode(&reference));
        assert_ne!(
            mode(&atomic),
            0o600,
            "the umask would have to be 0177 for this"
        );
    }

    #[test]
    fn issue_15_an_output_symlink_is_written_through_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.txt");
        std::fs::write(&target, b"old").unwrap();
        let link = dir.path().join("link.txt");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomic(&link, |w| w.write_all(b"new")).unwrap();
        assert!(link.is_symlink(), "the link was replaced by a file");
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
    }
}
