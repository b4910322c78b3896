//! Psychoacoustic scales: ISO 226:2003 equal-loudness contours, loudness in sone, and the
//! critical-band rate (Bark).
//!
//! # SPL calibration
//! A digital recording has no absolute level. We assume a full-scale sine (amplitude 1.0) plays
//! at 100 dB SPL (`FULL_SCALE_DB_SPL`), so a level of L dBFS (re a full-scale sine) is
//! L + 100 dB SPL — a loud but plausible listening level for a close-miked strike, which keeps
//! the modes of interest (down to about −80 dBFS) above the threshold of hearing.

/// Sound pressure level of a full-scale sine, dB SPL (see the module docs).
pub const FULL_SCALE_DB_SPL: f64 = 100.0;

/// ISO 226:2003 Table 1: preferred frequencies (Hz), exponent α_f, transfer magnitude L_U (dB)
/// and threshold of hearing T_f (dB SPL).
const F_HZ: [f64; 29] = [
    20.0, 25.0, 31.5, 40.0, 50.0, 63.0, 80.0, 100.0, 125.0, 160.0, 200.0, 250.0, 315.0, 400.0,
    500.0, 630.0, 800.0, 1000.0, 1250.0, 1600.0, 2000.0, 2500.0, 3150.0, 4000.0, 5000.0, 6300.0,
    8000.0, 10000.0, 12500.0,
];
const ALPHA_F: [f64; 29] = [
    0.532, 0.506, 0.480, 0.455, 0.432, 0.409, 0.387, 0.367, 0.349, 0.330, 0.315, 0.301, 0.288,
    0.276, 0.267, 0.259, 0.253, 0.250, 0.246, 0.244, 0.243, 0.243, 0.243, 0.242, 0.242, 0.245,
    0.254, 0.271, 0.301,
];
const L_U: [f64; 29] = [
    -31.6, -27.2, -23.0, -19.1, -15.9, -13.0, -10.3, -8.1, -6.2, -4.5, -3.1, -2.0, -1.1, -0.4, 0.0,
    0.3, 0.5, 0.0, -2.7, -4.1, -1.0, 1.7, 2.5, 1.2, -2.1, -7.1, -11.2, -10.7, -3.1,
];
const T_F: [f64; 29] = [
    78.5, 68.7, 59.5, 51.1, 44.0, 37.5, 31.5, 26.5, 22.1, 17.9, 14.4, 11.4, 8.6, 6.2, 4.4, 3.0,
    2.2, 2.4, 3.5, 1.7, -1.3, -4.2, -6.0, -5.4, -1.5, 6.0, 12.6, 13.9, 12.3,
];

/// Table parameters (α_f, L_U, T_f) at `freq_hz`, interpolated linearly in log-frequency between
/// the standard's frequencies and held constant below 20 Hz. Above 12.5 kHz (the standard's
/// range ends there) α_f and L_U are held and the threshold T_f follows the rise of Terhardt's
/// threshold-in-quiet approximation from its 12.5 kHz value: hearing fades fast up there (about
/// 65 dB SPL at 16 kHz, over 100 dB at 18 kHz), and a near-Nyquist click of a strike must not
/// count as loud.
fn params_at(freq_hz: f64) -> (f64, f64, f64) {
    let f = freq_hz.clamp(F_HZ[0], F_HZ[28]);
    let i = F_HZ.partition_point(|&x| x <= f).clamp(1, 28);
    let t = (f.ln() - F_HZ[i - 1].ln()) / (F_HZ[i].ln() - F_HZ[i - 1].ln());
    let lerp = |a: &[f64; 29]| a[i - 1] + t * (a[i] - a[i - 1]);
    let mut tf = lerp(&T_F);
    if freq_hz > F_HZ[28] {
        tf += terhardt_threshold_db(freq_hz) - terhardt_threshold_db(F_HZ[28]);
    }
    (lerp(&ALPHA_F), lerp(&L_U), tf)
}

/// Terhardt's (1979) threshold in quiet, dB SPL: `3.64 f^−0.8 − 6.5 e^(−0.6 (f − 3.3)²) +
/// 1e−3 f⁴` with `f` in kHz.
fn terhardt_threshold_db(freq_hz: f64) -> f64 {
    let f = freq_hz / 1000.0;
    3.64 * f.powf(-0.8) - 6.5 * (-0.6 * (f - 3.3).powi(2)).exp() + 1e-3 * f.powi(4)
}

/// Sound pressure level (dB SPL) of a pure tone at `freq_hz` that sounds as loud as
/// `phon` (ISO 226:2003 eq. 1).
pub fn spl_for_phon(freq_hz: f64, phon: f64) -> f64 {
    let (af, lu, tf) = params_at(freq_hz);
    let a = 4.47e-3 * (10f64.powf(0.025 * phon) - 1.15)
        + (0.4 * 10f64.powf((tf + lu) / 10.0 - 9.0)).powf(af);
    10.0 / af * a.max(1e-300).log10() - lu + 94.0
}

/// Loudness level (phon) of a pure tone at `freq_hz` and `spl_db` dB SPL: the exact inverse of
/// [`spl_for_phon`] (the standard's own eq. 2 inverts it only to about 0.1 phon). Tones at or
/// below the threshold of hearing get 0.
pub fn phon_for_spl(freq_hz: f64, spl_db: f64) -> f64 {
    let (af, lu, tf) = params_at(freq_hz);
    let a = 10f64.powf(af * (spl_db + lu - 94.0) / 10.0);
    let threshold = (0.4 * 10f64.powf((tf + lu) / 10.0 - 9.0)).powf(af);
    let x = (a - threshold) / 4.47e-3 + 1.15;
    if !(x > 0.0) {
        return 0.0;
    }
    (40.0 * x.log10()).max(0.0)
}

/// Loudness in sone from loudness level in phon: 2^((P − 40)/10) from 40 phon up (Stevens'
/// rule, 1 sone = 40 phon), (P/40)^2.642 below, so both meet at 1 sone and reach 0 at 0 phon.
pub fn sone_for_phon(phon: f64) -> f64 {
    if phon >= 40.0 {
        2f64.powf((phon - 40.0) / 10.0)
    } else if phon > 0.0 {
        (phon / 40.0).powf(2.642)
    } else {
        0.0
    }
}

/// Critical-band rate in Bark (Zwicker & Terhardt 1980).
pub fn bark(freq_hz: f64) -> f64 {
    13.0 * (7.6e-4 * freq_hz).atan() + 3.5 * (freq_hz / 7500.0).powi(2).atan()
}

/// Loudness in sone of a sine of amplitude `amplitude` (full scale = 1) at `freq_hz`.
pub fn sine_sone(freq_hz: f64, amplitude: f64) -> f64 {
    if !(amplitude > 0.0) {
        return 0.0;
    }
    let spl = FULL_SCALE_DB_SPL + 20.0 * amplitude.log10();
    sone_for_phon(phon_for_spl(freq_hz, spl))
}

/// A mode's perceptual weight, sone · s: its initial loudness times its e-folding duration
/// `1/d`, the duration capped at `max_duration_s` (itself kept within 1 ms – 1 s) — what a
/// listener integrates. The estimator ranks and weights features by it, and the residual
/// transfer pairs the dominant modes by it.
pub fn perceptual_weight(mode: &resound_core::DampedMode, max_duration_s: f64) -> f64 {
    let duration = (1.0 / mode.damping_per_s.max(1e-6)).min(max_duration_s.clamp(1e-3, 1.0));
    sine_sone(mode.freq_hz, mode.amplitude) * duration
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_kilohertz_is_the_reference() {
        // By definition a 1 kHz tone at L dB SPL has a loudness level of L phon (to the
        // standard's rounding).
        for phon in [20.0, 40.0, 60.0, 80.0, 90.0] {
            assert!((spl_for_phon(1000.0, phon) - phon).abs() < 0.3, "{phon}");
        }
    }

    #[test]
    fn contours_round_trip_and_have_the_known_shape() {
        for &f in &[
            20.0, 63.0, 315.0, 1000.0, 3150.0, 4000.0, 8000.0, 12500.0, 2222.0,
        ] {
            for phon in [20.0, 50.0, 80.0] {
                let spl = spl_for_phon(f, phon);
                assert!(
                    (phon_for_spl(f, spl) - phon).abs() < 1e-6,
                    "{f} Hz {phon} phon"
                );
            }
        }
        // The ear is least sensitive at 20 Hz and most around 3–4 kHz.
        assert!(spl_for_phon(20.0, 40.0) > spl_for_phon(100.0, 40.0) + 30.0);
        assert!(spl_for_phon(3150.0, 40.0) < spl_for_phon(1000.0, 40.0) - 3.0);
        // Low-frequency contours crowd together (loudness grows faster with level there).
        let low = spl_for_phon(31.5, 80.0) - spl_for_phon(31.5, 40.0);
        let mid = spl_for_phon(1000.0, 80.0) - spl_for_phon(1000.0, 40.0);
        assert!(low < 0.75 * mid, "{low} vs {mid}");
    }

    #[test]
    fn hearing_fades_above_the_standards_range() {
        let threshold = |f: f64| spl_for_phon(f, 0.0);
        // Continuous at 12.5 kHz, then rising steeply and monotonically.
        assert!((threshold(12_500.0) - threshold(12_499.0)).abs() < 0.1);
        let mut last = threshold(12_500.0);
        for f in [
            13_000.0, 14_000.0, 15_000.0, 16_000.0, 17_000.0, 18_000.0, 20_000.0,
        ] {
            let t = threshold(f);
            assert!(t > last, "{f} Hz: {t} dB after {last} dB");
            last = t;
        }
        assert!(
            (50.0..80.0).contains(&threshold(16_000.0)),
            "{}",
            threshold(16_000.0)
        );
        // A −10 dBFS tone at 19 kHz is inaudible; at 3 kHz it is loud.
        assert_eq!(phon_for_spl(19_000.0, FULL_SCALE_DB_SPL - 10.0), 0.0);
        assert!(phon_for_spl(3_000.0, FULL_SCALE_DB_SPL - 10.0) > 80.0);
    }

    #[test]
    fn sone_and_bark_reference_points() {
        assert!((sone_for_phon(40.0) - 1.0).abs() < 1e-12);
        assert!((sone_for_phon(50.0) - 2.0).abs() < 1e-12);
        assert!((sone_for_phon(39.999) - 1.0).abs() < 1e-3);
        assert_eq!(sone_for_phon(-3.0), 0.0);
        // Zwicker's table: 1 kHz ≈ 8.5 Bark, 4 kHz ≈ 17.3, 100 Hz ≈ 1.
        assert!((bark(1000.0) - 8.5).abs() < 0.2, "{}", bark(1000.0));
        assert!((bark(4000.0) - 17.3).abs() < 0.3, "{}", bark(4000.0));
        assert!((bark(100.0) - 1.0).abs() < 0.1, "{}", bark(100.0));
        assert!((bark(15500.0) - 24.0).abs() < 0.5, "{}", bark(15500.0));
    }
}
