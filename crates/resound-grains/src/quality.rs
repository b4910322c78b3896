//! How close a resynthesis is to its original.

use resound_signal::sine_stft::{window_len_for, Stft};

/// Spectral convergence in dB: `20 log10(‖ |X| − |Y| ‖_F / ‖ |X| ‖_F)` over STFT magnitudes
/// (sine window of about 43 ms, hop a quarter of it). `estimate` is cut or zero-padded to the
/// reference's length. −∞ for identical signals, 0 dB for silence against the reference.
pub fn spectral_convergence_db(reference: &[f32], estimate: &[f32], sample_rate_hz: f64) -> f64 {
    let w = 2 * window_len_for(sample_rate_hz);
    let mut stft = Stft::with_hop(w, w / 4);
    let mut y = estimate.to_vec();
    y.resize(reference.len(), 0.0);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    stft.forward(reference, &mut a);
    stft.forward(&y, &mut b);
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (x, e) in a.iter().zip(&b) {
        let (mx, me) = (f64::from(x.norm()), f64::from(e.norm()));
        num += (mx - me).powi(2);
        den += mx * mx;
    }
    10.0 * (num / den.max(1e-300)).log10()
}
