//! Reading 1-D float arrays from NumPy `.npy` files (version 1–3, little-endian f8 or f4, C
//! order): the PyImpact scrape surfaces are height profiles in this format.

use crate::{io_err, parse_err, Result};
use std::path::Path;

/// Reads a 1-D `<f8` or `<f4` array.
pub fn read_npy_f64(path: &Path) -> Result<Vec<f64>> {
    let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
    parse_npy_f64(&bytes).map_err(|m| parse_err(path, m))
}

/// Parses `.npy` bytes holding a 1-D `<f8` or `<f4` array.
pub fn parse_npy_f64(bytes: &[u8]) -> std::result::Result<Vec<f64>, String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy file (bad magic)".into());
    }
    let (header_len, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let header = bytes
        .get(start..start + header_len)
        .ok_or("truncated .npy header")?;
    let header = String::from_utf8_lossy(header);
    let width = if header.contains("'<f8'") {
        8
    } else if header.contains("'<f4'") {
        4
    } else {
        return Err(format!(
            "only little-endian float arrays are supported, header {header}"
        ));
    };
    if header.contains("'fortran_order': True") {
        return Err("Fortran-ordered arrays are not supported".into());
    }
    let shape = header
        .split("'shape':")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .ok_or("no shape in the .npy header")?;
    let dims: Vec<usize> = shape
        .trim()
        .trim_start_matches('(')
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse::<usize>().map_err(|e| e.to_string()))
        .collect::<std::result::Result<_, _>>()?;
    if dims.len() != 1 {
        return Err(format!("expected a 1-D array, shape is {dims:?}"));
    }
    let data = &bytes[start + header_len..];
    let want = dims[0]
        .checked_mul(width)
        .ok_or_else(|| format!("the .npy shape ({},) is too large", dims[0]))?;
    if data.len() < want {
        return Err(format!(
            "truncated .npy data: {} of {want} bytes",
            data.len()
        ));
    }
    let out: Vec<f64> = data[..want]
        .chunks_exact(width)
        .map(|c| {
            if width == 8 {
                f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])
            } else {
                f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            }
        })
        .collect();
    if let Some(i) = out.iter().position(|v| !v.is_finite()) {
        return Err(format!("non-finite value at index {i}"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(values: &[f64]) -> Vec<u8> {
        let mut header = format!(
            "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
            values.len()
        );
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&(header.len() as u16).to_le_bytes());
        b.extend_from_slice(header.as_bytes());
        for v in values {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    #[test]
    fn round_trip_and_bad_files() {
        let v = [1.5, -2.25, 3e-6];
        assert_eq!(parse_npy_f64(&npy(&v)).unwrap(), v);
        let mut b = npy(&v);
        b.truncate(b.len() - 3);
        assert!(parse_npy_f64(&b).unwrap_err().contains("truncated"));
        assert!(parse_npy_f64(b"hello world").is_err());
    }
}
