//! Matrix Market output, so other tools can be compared on the very same K and M.

use crate::atomic::write_atomic;
use crate::Result;
use faer::sparse::SparseColMatRef;
use std::path::Path;

/// Writes a symmetric sparse matrix as `%%MatrixMarket matrix coordinate real symmetric`
/// (lower triangle, 1-based, 17 significant digits).
///
/// # Errors
/// I/O errors.
pub fn write_symmetric(
    path: &Path,
    a: SparseColMatRef<'_, usize, f64>,
    comment: &str,
) -> Result<()> {
    write_atomic(path, |w| {
        let n = a.nrows();
        let mut nnz = 0usize;
        for j in 0..a.ncols() {
            nnz += a.row_idx_of_col(j).filter(|&i| i >= j).count();
        }
        writeln!(w, "%%MatrixMarket matrix coordinate real symmetric")?;
        for line in comment.lines() {
            writeln!(w, "% {line}")?;
        }
        writeln!(w, "{n} {n} {nnz}")?;
        for j in 0..a.ncols() {
            for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                if i >= j {
                    writeln!(w, "{} {} {:.17e}", i + 1, j + 1, v)?;
                }
            }
        }
        Ok(())
    })
}
