//! Offline rendering: one strike of an object, and output-level safety.

use crate::bank::{BankMode, ModalBank};
use crate::SynthError;
use resound_core::progress::{Warning, WarningKind};
use resound_core::DampedMode;

/// The impulse of the reference impact a material's σ is calibrated to: a 5 mm steel ball
/// (4.11 g) meeting an immovable object at 1 m/s, J = 2mv. A material's modes at σ·a⁰ sound at
/// the recording's level for this impact; other impacts scale with their impulse.
pub const REFERENCE_IMPULSE_N_S: f64 =
    2.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.005 * 0.005 * 0.005 * 7850.0;

/// Bank modes from damped sinusoids given per unit impulse (`amplitude` with `phase_rad` 0 or
/// π as the sign, as [`resound_core::SoundMaterial::modes`] returns them). Other phases are
/// projected onto the sine (a struck object at rest starts each mode as a sine).
pub fn bank_modes(modes: &[DampedMode]) -> Vec<BankMode> {
    modes
        .iter()
        .map(|m| BankMode {
            freq_hz: m.freq_hz,
            damping_per_s: m.damping_per_s,
            gain: m.amplitude * m.phase_rad.cos(),
        })
        .collect()
}

/// Renders `modes` struck by `force` (N per sample) for `samples` samples.
pub fn render_strike(
    modes: &[BankMode],
    force: &[f32],
    sample_rate_hz: f64,
    samples: usize,
) -> Result<Vec<f32>, SynthError> {
    let mut bank = ModalBank::new(sample_rate_hz, modes, 0.0)?;
    let mut out = vec![0.0f32; samples];
    let n = force.len().min(samples);
    let (head, tail) = out.split_at_mut(n);
    bank.process(&force[..n], head);
    bank.ring(tail);
    Ok(out)
}

/// −1 dBFS, the ceiling every rendered file is kept under.
pub const CEILING: f32 = 0.891;

/// What [`set_level`] does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Only turn down a peak above the ceiling (keep the physical level otherwise).
    Guard,
    /// Bring the peak to the ceiling, up or down (silence stays silent).
    Normalize,
}

/// What [`set_level`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelReport {
    /// Peak before, full scale = 1.
    pub peak_before: f32,
    /// Gain applied, dB (0 if none).
    pub gain_db: f32,
}

/// Renders whose peak lies below this (dBFS) are reported as inaudible
/// ([`resound_core::limits::INAUDIBLE_DBFS`]).
pub const QUIET_DBFS: f32 = resound_core::limits::INAUDIBLE_DBFS as f32;

impl LevelReport {
    /// What a front end says when the gain turned the render down (none when it did not).
    pub fn note(&self) -> Option<String> {
        (self.gain_db < 0.0).then(|| {
            format!(
                "peak {:.2} of full scale; turned down by {:.1} dB to −1 dBFS (no clipping)",
                self.peak_before, -self.gain_db
            )
        })
    }

    /// Peak before any gain, dBFS (−∞ for silence).
    pub fn peak_dbfs(&self) -> f32 {
        20.0 * self.peak_before.log10()
    }

    /// A warning when the render, as it came out of the physics (before any gain), peaks below
    /// [`QUIET_DBFS`]: a material or scale in the wrong units, or an impact too soft to hear.
    pub fn quiet_warning(&self) -> Option<Warning> {
        if self.peak_before == 0.0 {
            Some(Warning::new(
                WarningKind::Quiet,
                "the render is silent (every sample is 0)",
            ))
        } else if self.peak_dbfs() < QUIET_DBFS {
            Some(Warning::new(
                WarningKind::Quiet,
                format!(
                    "the render peaks at {:.0} dBFS, below {QUIET_DBFS:.0} dBFS: inaudible, and \
                 zeros in 16-bit PCM (a material in the wrong units, e.g. γ or σ in mesh units?)",
                    self.peak_dbfs()
                ),
            ))
        } else {
            None
        }
    }
}

/// The one output-level function: one gain for all `channels` (keeps a stereo image), never
/// clipping silently — the caller reports the gain. NaN or infinite samples are an error.
///
/// # Errors
/// [`SynthError::Parameter`] for a non-finite signal.
pub fn set_level<C: AsMut<[f32]>>(
    channels: &mut [C],
    ceiling: f32,
    mode: Level,
) -> Result<LevelReport, SynthError> {
    let mut peak = 0.0f32;
    for c in channels.iter_mut() {
        for v in c.as_mut().iter() {
            if !v.is_finite() {
                return Err(SynthError::Parameter(
                    "the rendered signal is not finite (absurd parameters?)".into(),
                ));
            }
            peak = peak.max(v.abs());
        }
    }
    let change = match mode {
        Level::Guard => peak > ceiling,
        Level::Normalize => peak > 0.0,
    };
    if !change {
        return Ok(LevelReport {
            peak_before: peak,
            gain_db: 0.0,
        });
    }
    let g = ceiling / peak;
    for c in channels.iter_mut() {
        c.as_mut().iter_mut().for_each(|v| *v *= g);
    }
    Ok(LevelReport {
        peak_before: peak,
        gain_db: 20.0 * g.log10(),
    })
}

/// Keeps one signal from clipping ([`set_level`] with [`Level::Guard`]).
///
/// # Errors
/// As [`set_level`].
pub fn normalize(x: &mut [f32], ceiling: f32) -> Result<LevelReport, SynthError> {
    set_level(&mut [x], ceiling, Level::Guard)
}
