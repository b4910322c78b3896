//! Radiation in the pipeline: a model's acoustic transfer (fitted when the model file holds
//! none) turned into each mode's radiation factor at a microphone.
//!
//! A mode's gain at a hit (`a⁰`, displacement per N·s) times its factor
//! ([`resound_core::AcousticTransfer::factor`]: `ω |p| r / (ρ c²)`) is the pressure it
//! radiates to the microphone, times the distance, in units of `ρc²` per N·s: modes that
//! radiate poorly (a small object's low modes, a mode whose lobes miss the microphone) are
//! quieter than their surface motion alone says.

use crate::error::{invalid, Result};
use resound_core::progress::{Warning, WarningKind};
use resound_core::radiation::FieldScratch;
use resound_core::{AcousticTransfer, ModalModel};
use resound_modal::radiation::{model_transfer, TransferInfo, TransferParams};
use std::borrow::Cow;

/// Fits and stores `model`'s acoustic transfer (replacing any).
///
/// # Errors
/// A surface the fit cannot use.
pub fn add_transfer(model: &mut ModalModel, params: &TransferParams) -> Result<TransferInfo> {
    let (t, info) = model_transfer(model, params).map_err(|e| invalid(e.to_string()))?;
    model.transfer = Some(t);
    Ok(info)
}

/// The model's transfer, fitted with the default settings when it holds none (the info then
/// says what the fit did).
///
/// # Errors
/// As [`add_transfer`].
pub fn transfer_of(
    model: &ModalModel,
) -> Result<(Cow<'_, AcousticTransfer>, Option<TransferInfo>)> {
    match &model.transfer {
        Some(t) if t.modes.len() == model.n_modes() => Ok((Cow::Borrowed(t), None)),
        _ => {
            let (t, info) = model_transfer(model, &TransferParams::default())
                .map_err(|e| invalid(e.to_string()))?;
            Ok((Cow::Owned(t), Some(info)))
        }
    }
}

/// Each mode's radiation factor at `mic` (model coordinates, m) when mode j sounds at
/// `freqs_hz[j]`, with warnings for what is not credible: a microphone inside the sphere that
/// holds the object (the field is evaluated on that sphere), modes moved outside their stored
/// frequency range by the material, modes the fit represents poorly.
///
/// # Errors
/// A non-finite microphone position or a frequency list of the wrong length.
pub fn mic_factors(
    transfer: &AcousticTransfer,
    freqs_hz: &[f64],
    mic: [f64; 3],
) -> Result<(Vec<f64>, Vec<Warning>)> {
    if mic.iter().any(|c| !c.is_finite()) {
        return Err(invalid(format!(
            "microphone position {mic:?} is not finite"
        )));
    }
    if freqs_hz.len() != transfer.modes.len() {
        return Err(invalid(format!(
            "{} frequencies for a transfer of {} modes",
            freqs_hz.len(),
            transfer.modes.len()
        )));
    }
    let mut warnings = Vec::new();
    let d = (0..3)
        .map(|c| (mic[c] - transfer.centre_m[c]).powi(2))
        .sum::<f64>()
        .sqrt();
    if d < transfer.radius_m {
        warnings.push(Warning::new(
            WarningKind::Geometry,
            format!(
            "the microphone is {d:.3} m from the object's centre, inside the {:.3} m sphere that \
             holds it: its radiation is evaluated on that sphere",
            transfer.radius_m
        ),
        ));
    }
    let mut scratch = FieldScratch::new(transfer.max_order());
    let mut out_of_range = 0;
    let mut poor = 0;
    let mut missing = 0;
    let factors = freqs_hz
        .iter()
        .enumerate()
        .map(|(j, &f)| {
            if let Some((lo, hi)) = transfer.range_hz(j) {
                if f < lo * 0.999 || f > hi * 1.001 {
                    out_of_range += 1;
                }
            }
            if transfer
                .misfit_at(j, f)
                .is_some_and(|r| f64::from(r) > resound_core::limits::POOR_TRANSFER_MISFIT)
            {
                poor += 1;
            }
            if transfer.modes[j].orders.is_empty() {
                missing += 1;
            }
            transfer.factor(j, f, mic, &mut scratch).unwrap_or(0.0)
        })
        .collect::<Vec<f64>>();
    if out_of_range > 0 {
        warnings.push(Warning::new(
            WarningKind::PoorTransfer,
            format!(
                "{out_of_range} modes sound outside the frequency range their transfer was fitted \
             for (the material moves them more than the stored octaves): their radiation is \
             taken at the nearest stored frequency"
            ),
        ));
    }
    if missing > 0 {
        warnings.push(Warning::new(
            WarningKind::PoorTransfer,
            format!(
            "{missing} modes have no stored transfer (above the fit's top frequency): they are \
             left out"
        ),
        ));
    }
    if poor > 0 {
        warnings.push(Warning::new(
            WarningKind::PoorTransfer,
            format!(
                "{poor} modes' surface velocity is fitted with more than 90 % misfit (a shape far \
             from a sphere or a high frequency): their radiation is approximate"
            ),
        ));
    }
    if factors.iter().any(|f| !f.is_finite()) {
        return Err(invalid("a radiation factor is not finite"));
    }
    Ok((factors, warnings))
}

/// The frequencies (Hz) of `model`'s modes in a material of stiffness-to-density ratio `gamma`.
pub fn freqs_in(model: &ModalModel, gamma: f64) -> Vec<f64> {
    let gamma0 = model.gamma0();
    model
        .eigenvalues
        .iter()
        .map(|&l| (l.max(0.0) * gamma / gamma0).sqrt() / (2.0 * std::f64::consts::PI))
        .collect()
}
