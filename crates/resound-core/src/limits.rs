//! One home for the facts every stage and front end shares: the sample rates we process, the
//! most modes a model may ask for, the speed of sound, when a render is inaudible and when an
//! acoustic transfer fits poorly. Each crate checks against these, so a value accepted by one
//! front end is accepted by all (the CLI, Python, Bevy and the studio only translate).

use std::ops::RangeInclusive;

/// Sample rates that analysis, synthesis, scenes and grains work at, Hz. Files may hold other
/// rates (decoding takes [`DECODE_SAMPLE_RATE_HZ`]); they are resampled into this range.
pub const SAMPLE_RATE_HZ: RangeInclusive<f64> = 8_000.0..=192_000.0;

/// The rate every file Resound writes has unless asked otherwise (strikes, scrapes, scenes,
/// grains, batches), Hz; with [`DEFAULT_WAV_BITS`]-bit PCM.
pub const DEFAULT_SAMPLE_RATE_HZ: u32 = 48_000;

/// Bits of the PCM files written unless asked otherwise.
pub const DEFAULT_WAV_BITS: u32 = 24;

/// Sample rates a decoder accepts in a file, Hz (anything wider is a corrupt header).
pub const DECODE_SAMPLE_RATE_HZ: RangeInclusive<f64> = 1_000.0..=768_000.0;

/// Whether `fs` (Hz) is a rate we process ([`SAMPLE_RATE_HZ`]); false for NaN.
pub fn sample_rate_ok(fs: f64) -> bool {
    fs.is_finite() && SAMPLE_RATE_HZ.contains(&fs)
}

/// The message for a rate outside [`SAMPLE_RATE_HZ`] (the same words from every stage).
pub fn sample_rate_message(fs: f64) -> String {
    format!(
        "sample rate {fs} Hz is outside the supported {}–{} Hz; resample it first",
        SAMPLE_RATE_HZ.start(),
        SAMPLE_RATE_HZ.end()
    )
}

/// Most elastic modes a modal model may be asked for.
pub const MAX_MODES: usize = 2000;

/// Speed of sound in air at 20 °C, m/s (propagation delay, radiation's wavenumber).
pub const SPEED_OF_SOUND_M_S: f64 = 343.0;

/// Density of air at 20 °C, kg/m³ (radiation's ρc).
pub const AIR_DENSITY_KG_M3: f64 = 1.204;

/// A render whose peak (before any gain) lies below this, dBFS, is reported as inaudible:
/// 16-bit PCM holds zeros there, and at any sane monitoring gain nobody hears it.
pub const INAUDIBLE_DBFS: f64 = -90.0;

/// A strike whose peak lies below this, dBFS, is faint: heard only turned up (a struck
/// object at the default impact, heard at its physical level, peaks well above it).
pub const FAINT_DBFS: f64 = -40.0;

/// An acoustic transfer whose relative misfit at a mode's frequency exceeds this is not
/// credible for that mode (warned about wherever it sounds).
pub const POOR_TRANSFER_MISFIT: f64 = 0.9;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_rates_at_the_ends_are_accepted_and_nan_is_not() {
        assert!(sample_rate_ok(8000.0) && sample_rate_ok(192_000.0) && sample_rate_ok(44_100.0));
        assert!(!sample_rate_ok(7999.0) && !sample_rate_ok(192_001.0));
        assert!(!sample_rate_ok(f64::NAN) && !sample_rate_ok(f64::INFINITY));
        assert!(sample_rate_message(4000.0).contains("8000–192000 Hz"));
    }
}
