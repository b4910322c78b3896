//! Sample-rate conversion with rubato's synchronous FFT resampler.

use rubato::{FftFixedIn, Resampler};

/// Resamples `x` from `from_hz` to `to_hz`; the output has `round(len · to/from)` samples and no
/// delay (the resampler's latency is removed).
///
/// # Errors
/// A message when a rate is zero or rubato refuses the ratio.
pub fn resample(x: &[f64], from_hz: u32, to_hz: u32) -> Result<Vec<f64>, String> {
    if from_hz == 0 || to_hz == 0 {
        return Err("sample rates must be positive".into());
    }
    if from_hz == to_hz || x.is_empty() {
        return Ok(x.to_vec());
    }
    let mut r = FftFixedIn::<f64>::new(from_hz as usize, to_hz as usize, 1024, 2, 1)
        .map_err(|e| format!("cannot resample {from_hz} Hz → {to_hz} Hz: {e}"))?;
    let want = (x.len() as f64 * f64::from(to_hz) / f64::from(from_hz)).round() as usize;
    let delay = r.output_delay();
    let mut out: Vec<f64> = Vec::with_capacity(want + delay + 2048);
    let err = |e: rubato::ResampleError| format!("resampling failed: {e}");
    let mut pos = 0;
    while pos + r.input_frames_next() <= x.len() {
        let need = r.input_frames_next();
        let o = r.process(&[&x[pos..pos + need]], None).map_err(err)?;
        out.extend_from_slice(&o[0]);
        pos += need;
    }
    // The rest, then zeros until the delayed output is complete.
    // (rubato refuses an empty partial chunk: a length that is a multiple of the chunk has none.)
    if pos < x.len() {
        let o = r.process_partial(Some(&[&x[pos..]]), None).map_err(err)?;
        out.extend_from_slice(&o[0]);
    }
    while out.len() < want + delay {
        let o = r.process_partial::<&[f64]>(None, None).map_err(err)?;
        if o[0].is_empty() {
            break;
        }
        out.extend_from_slice(&o[0]);
    }
    let end = (delay + want).min(out.len());
    Ok(out[delay.min(end)..end].to_vec())
}

#[cfg(test)]
mod tests {
    #[test]
    fn empty_signals_resample_to_empty() {
        // A material whose residual is empty (a recording fully explained by its modes) used
        // to fail here with rubato's "insufficient buffer size 0".
        assert_eq!(super::resample(&[], 44_100, 48_000), Ok(Vec::new()));
        // A whole number of rubato's 1024-sample chunks (a residual of 2 × 512-sample hops)
        // failed the same way.
        let x: Vec<f64> = (0..2048).map(|i| (0.01 * i as f64).sin()).collect();
        let y = super::resample(&x, 44_100, 48_000).unwrap();
        assert_eq!(y.len(), (2048.0f64 * 48_000.0 / 44_100.0).round() as usize);
    }

    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn tone_keeps_frequency_amplitude_and_timing() {
        let (from, to) = (48000u32, 44100u32);
        let x: Vec<f64> = (0..48000)
            .map(|i| 0.5 * (TAU * 1000.0 * i as f64 / 48000.0).sin())
            .collect();
        let y = resample(&x, from, to).unwrap();
        assert_eq!(y.len(), 44100);
        // Away from the edges the output is the same tone at the new rate, in phase.
        for i in (2000..42000).step_by(1234) {
            let expect = 0.5 * (TAU * 1000.0 * i as f64 / 44100.0).sin();
            assert!(
                (y[i] - expect).abs() < 2e-3,
                "sample {i}: {} vs {expect}",
                y[i]
            );
        }
    }
}
