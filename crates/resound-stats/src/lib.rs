//! Statistical impulse responses (Traer, Cusimano & McDermott 2019, eqs. 2–4, 9): sound for
//! objects nobody meshed or recorded.
//!
//! A material's impulse response is `M` modes, each with a frequency, an onset level and a decay
//! rate. Each mode is described by three coordinates: `ln f` (Hz), the onset level in dB re full
//! scale, and the decay in dB/s. Over a set of recordings of one material, the `M` modes are the
//! `M` strongest of each recording by level, ordered by frequency. Their `3M` coordinates are
//! modelled as one multivariate Gaussian (mean, covariance), as Traer fits μ_M, Σ_M.
//!
//! - [`ModeStatistics::fit`] estimates the Gaussian from analysed recordings (our analysis
//!   replaces Traer's spectrogram matching). The sample covariance gets a small ridge so it can
//!   be sampled even from few recordings.
//! - [`ModeStatistics::sample`] draws one object's IR. Rejection sampling keeps the mean spacing
//!   of the sampled frequencies within 10 % of the mean's spacing.
//! - [`perturb`] varies the mode powers by ±20 % per impact (location variation, Traer §2.1).
//! - [`ModeStatistics::from_pyimpact_json`] imports the TDW PyImpact per-material tables: `cf` in
//!   Hz, `op` as onset power in dB, `rt` as RT60 in s. Their modes become the mean with zero
//!   spread, so sampling reproduces their frequencies exactly.
//!
//! The transient (eq. 3: N = 30 ERB-spaced noise bands with onset level and decay) is fitted
//! from each recording's residual after its modes ([`transient`]) and kept as per-band means and
//! spreads ([`TransientStats`]).

#![warn(missing_docs)]

pub mod transient;

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use resound_core::DampedMode;
use serde::{Deserialize, Serialize};

/// dB per second of decay for an amplitude decay rate d (1/s): 20 log10(e) · d.
const DB_PER_NEPER: f64 = 8.685_889_638_065_035;

/// Why statistics cannot be made or used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StatsError {
    /// Too little data.
    #[error("{0}")]
    Data(String),
    /// A malformed table.
    #[error("not a PyImpact mode table: {0}")]
    Table(String),
    /// Sampling failed.
    #[error("{0}")]
    Sampling(String),
}

/// A per-material Gaussian over the coordinates of `modes` modes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModeStatistics {
    /// Material name.
    pub material: String,
    /// Modes per impulse response (M).
    pub modes: usize,
    /// Mean of the 3M coordinates, mode-major: `[ln f, level dB, decay dB/s]` per mode.
    pub mean: Vec<f64>,
    /// Covariance, 3M × 3M row-major.
    pub covariance: Vec<f64>,
    /// Recordings (or tables) the statistics come from.
    pub sources: usize,
    /// Statistics of the transient noise bands (Traer eq. 3), when fitted from recordings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transient: Option<TransientStats>,
}

/// The highest credible band onset level, dB re full scale (RMS; a band of a signal within
/// ±1 stays below 0 dB, the margin allows floating-point recordings a little over).
pub const MAX_ONSET_DB: f64 = 6.0;

/// Per-band mean and spread of the transient's onset level and decay over recordings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransientStats {
    /// Band edges, Hz.
    pub edges_hz: Vec<f64>,
    /// Mean onset level per band, dB.
    pub onset_db_mean: Vec<f64>,
    /// Standard deviation of the onset level, dB.
    pub onset_db_sd: Vec<f64>,
    /// Mean decay per band, dB/s.
    pub decay_mean: Vec<f64>,
    /// Standard deviation of the decay, dB/s.
    pub decay_sd: Vec<f64>,
}

impl TransientStats {
    /// Mean and spread of fitted transients (all with the same bands).
    pub fn fit(fits: &[transient::Transient]) -> Result<Self, StatsError> {
        let Some(first) = fits.first() else {
            return Err(StatsError::Data("no transients to fit".into()));
        };
        if fits.iter().any(|t| t.edges_hz != first.edges_hz) {
            return Err(StatsError::Data(
                "transients with different bands (mixed sample rates?)".into(),
            ));
        }
        // Per band, over the recordings where the band holds a transient; a band present in
        // fewer than half of them is absent.
        let bands = first.onset_db.len();
        let mut out = Self {
            edges_hz: first.edges_hz.clone(),
            onset_db_mean: vec![transient::ABSENT_DB; bands],
            onset_db_sd: vec![0.0; bands],
            decay_mean: vec![0.0; bands],
            decay_sd: vec![0.0; bands],
        };
        let mean_sd = |v: &[f64]| {
            let n = v.len() as f64;
            let m = v.iter().sum::<f64>() / n;
            let sd = if v.len() < 2 {
                0.0
            } else {
                (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
            };
            (m, sd)
        };
        for b in 0..bands {
            let present: Vec<&transient::Transient> = fits
                .iter()
                .filter(|t| t.onset_db[b] > transient::ABSENT_DB)
                .collect();
            if present.is_empty() || 2 * present.len() < fits.len() {
                continue;
            }
            let on: Vec<f64> = present.iter().map(|t| t.onset_db[b]).collect();
            let de: Vec<f64> = present.iter().map(|t| t.decay_db_per_s[b]).collect();
            (out.onset_db_mean[b], out.onset_db_sd[b]) = mean_sd(&on);
            (out.decay_mean[b], out.decay_sd[b]) = mean_sd(&de);
        }
        out.validate()?;
        Ok(out)
    }

    /// Checks that the statistics are credible: finite, increasing band edges, onset levels at
    /// most [`MAX_ONSET_DB`] (a band's RMS cannot exceed a full-scale signal's), spreads and
    /// decays ≥ 0.
    ///
    /// # Errors
    /// [`StatsError::Data`] naming the first offending band.
    pub fn validate(&self) -> Result<(), StatsError> {
        let bands = self.onset_db_mean.len();
        if self.edges_hz.len() != bands + 1
            || [&self.onset_db_sd, &self.decay_mean, &self.decay_sd]
                .iter()
                .any(|v| v.len() != bands)
        {
            return Err(StatsError::Data(
                "transient statistics with mismatched band counts".into(),
            ));
        }
        if !self.edges_hz.windows(2).all(|w| w[0] < w[1] && w[0] >= 0.0) {
            return Err(StatsError::Data(
                "transient band edges must be increasing and ≥ 0 Hz".into(),
            ));
        }
        for b in 0..bands {
            let (m, s, d, ds) = (
                self.onset_db_mean[b],
                self.onset_db_sd[b],
                self.decay_mean[b],
                self.decay_sd[b],
            );
            let fine = m.is_finite()
                && m <= MAX_ONSET_DB
                && s.is_finite()
                && s >= 0.0
                && d.is_finite()
                && d >= 0.0
                && ds.is_finite()
                && ds >= 0.0;
            if !fine {
                return Err(StatsError::Data(format!(
                    "transient band {} ({:.0}–{:.0} Hz) is not credible: onset {m:.1} ± {s:.1} dB \
                     (at most {MAX_ONSET_DB} dB re full scale), decay {d:.1} ± {ds:.1} dB/s; \
                     refit it with `resound stats fit`",
                    b + 1,
                    self.edges_hz[b],
                    self.edges_hz[b + 1]
                )));
            }
        }
        Ok(())
    }

    /// One transient drawn band by band (independent Gaussians; decays kept ≥ 0).
    pub fn sample(&self, seed: u64) -> transient::Transient {
        let mut rng = SmallRng::seed_from_u64(seed);
        let mut draw = |m: f64, s: f64| {
            let z: f64 = StandardNormal.sample(&mut rng);
            m + s * z
        };
        let onset_db = self
            .onset_db_mean
            .iter()
            .zip(&self.onset_db_sd)
            .map(|(&m, &s)| {
                if m <= transient::ABSENT_DB {
                    transient::ABSENT_DB
                } else {
                    draw(m, s).clamp(transient::ABSENT_DB + 1.0, MAX_ONSET_DB)
                }
            })
            .collect();
        let decay_db_per_s = self
            .decay_mean
            .iter()
            .zip(&self.decay_sd)
            .map(|(&m, &s)| draw(m, s).max(0.0))
            .collect();
        transient::Transient {
            edges_hz: self.edges_hz.clone(),
            onset_db,
            decay_db_per_s,
        }
    }
}

/// One mode's coordinates.
fn coords(m: &DampedMode) -> [f64; 3] {
    [
        m.freq_hz.ln(),
        20.0 * m.amplitude.max(1e-12).log10(),
        DB_PER_NEPER * m.damping_per_s,
    ]
}

fn mode_of(c: &[f64]) -> DampedMode {
    DampedMode::new(
        c[0].exp(),
        (c[2] / DB_PER_NEPER).max(0.0),
        10f64.powf(c[1] / 20.0),
    )
}

impl ModeStatistics {
    /// Fits the Gaussian to the `modes` strongest modes (by level over the first 0.25 s) of
    /// each recording's analysed modes. Needs at least two recordings with that many modes.
    pub fn fit(
        material: &str,
        recordings: &[Vec<DampedMode>],
        modes: usize,
    ) -> Result<Self, StatsError> {
        if modes == 0 || modes > 200 {
            return Err(StatsError::Data(format!(
                "modes per IR must be in 1..=200, got {modes}"
            )));
        }
        let rows: Vec<Vec<f64>> = recordings
            .iter()
            .filter(|r| r.len() >= modes)
            .map(|r| {
                let mut top = r.clone();
                let level =
                    |m: &DampedMode| resound_signal::mode_level(m, resound_signal::LEVEL_WINDOW_S);
                top.sort_by(|a, b| level(b).total_cmp(&level(a)));
                top.truncate(modes);
                top.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
                top.iter().flat_map(coords).collect()
            })
            .collect();
        if rows.len() < 2 {
            return Err(StatsError::Data(format!(
                "need at least 2 recordings with {modes} modes each, have {} of {}",
                rows.len(),
                recordings.len()
            )));
        }
        let n = rows.len() as f64;
        let dim = 3 * modes;
        let mean: Vec<f64> = (0..dim)
            .map(|i| rows.iter().map(|r| r[i]).sum::<f64>() / n)
            .collect();
        let mut covariance = vec![0.0; dim * dim];
        for r in &rows {
            for i in 0..dim {
                for j in 0..dim {
                    covariance[i * dim + j] += (r[i] - mean[i]) * (r[j] - mean[j]) / (n - 1.0);
                }
            }
        }
        Ok(Self {
            material: material.to_string(),
            modes,
            mean,
            covariance,
            sources: rows.len(),
            transient: None,
        })
    }

    /// Imports one PyImpact table (`{"cf": [...], "op": [...], "rt": [...]}`).
    pub fn from_pyimpact_json(material: &str, text: &str) -> Result<Self, StatsError> {
        #[derive(Deserialize)]
        struct Table {
            cf: Vec<f64>,
            op: Vec<f64>,
            rt: Vec<f64>,
        }
        let t: Table = serde_json::from_str(text).map_err(|e| StatsError::Table(e.to_string()))?;
        if t.cf.is_empty() || t.cf.len() != t.op.len() || t.cf.len() != t.rt.len() {
            return Err(StatsError::Table(format!(
                "cf, op and rt must be equally long and not empty ({}, {}, {})",
                t.cf.len(),
                t.op.len(),
                t.rt.len()
            )));
        }
        let mut modes: Vec<(f64, f64, f64)> = Vec::with_capacity(t.cf.len());
        for ((&f, &op), &rt) in t.cf.iter().zip(&t.op).zip(&t.rt) {
            if !(f > 0.0 && f.is_finite() && op.is_finite() && rt > 0.0 && rt.is_finite()) {
                return Err(StatsError::Table(format!(
                    "unusable mode cf {f}, op {op}, rt {rt}"
                )));
            }
            // RT60: 60 dB in rt seconds.
            modes.push((f, op, 60.0 / rt));
        }
        modes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mean: Vec<f64> = modes
            .iter()
            .flat_map(|&(f, op, db)| [f.ln(), op, db])
            .collect();
        let dim = mean.len();
        Ok(Self {
            material: material.to_string(),
            modes: modes.len(),
            mean,
            covariance: vec![0.0; dim * dim],
            sources: 1,
            transient: None,
        })
    }

    /// The mean impulse response's modes (frequency-ordered).
    pub fn mean_modes(&self) -> Vec<DampedMode> {
        self.mean.chunks(3).map(mode_of).collect()
    }

    /// Mean spacing (Hz) of frequency-sorted modes.
    fn spacing(modes: &[DampedMode]) -> f64 {
        let mut f: Vec<f64> = modes.iter().map(|m| m.freq_hz).collect();
        f.sort_by(f64::total_cmp);
        if f.len() < 2 {
            return 0.0;
        }
        (f[f.len() - 1] - f[0]) / (f.len() - 1) as f64
    }

    /// Lower Cholesky factor of the covariance plus a small ridge (1e-9 of the largest variance).
    fn cholesky(&self) -> Vec<f64> {
        let n = self.mean.len();
        let scale = (0..n)
            .map(|i| self.covariance[i * n + i])
            .fold(0.0f64, f64::max);
        let ridge = 1e-9 * scale.max(1e-300);
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                let mut s = self.covariance[i * n + j] + if i == j { ridge } else { 0.0 };
                for k in 0..j {
                    s -= l[i * n + k] * l[j * n + k];
                }
                if i == j {
                    l[i * n + i] = s.max(0.0).sqrt();
                } else {
                    let d = l[j * n + j];
                    l[i * n + j] = if d > 0.0 { s / d } else { 0.0 };
                }
            }
        }
        l
    }

    /// Samples one object's impulse response (modes per unit impulse), reproducibly from `seed`.
    /// Draws are rejected until the mean mode spacing is within 10 % of the mean IR's (at most
    /// 1000 tries).
    pub fn sample(&self, seed: u64) -> Result<Vec<DampedMode>, StatsError> {
        let n = self.mean.len();
        let l = self.cholesky();
        let target = Self::spacing(&self.mean_modes());
        let mut rng = SmallRng::seed_from_u64(seed);
        for _ in 0..1000 {
            let z: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
            let x: Vec<f64> = (0..n)
                .map(|i| self.mean[i] + (0..=i).map(|k| l[i * n + k] * z[k]).sum::<f64>())
                .collect();
            let mut modes: Vec<DampedMode> = x.chunks(3).map(mode_of).collect();
            modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
            let s = Self::spacing(&modes);
            if target == 0.0 || (s / target - 1.0).abs() <= 0.1 {
                return Ok(modes);
            }
        }
        Err(StatsError::Sampling(format!(
            "no draw in 1000 kept the mean mode spacing within 10 % of {target:.1} Hz (spread too wide for the spacing constraint)"
        )))
    }
}

/// Per-impact variation (Traer eq. 9): each mode's power times a uniform factor in [0.8, 1.2].
pub fn perturb(modes: &[DampedMode], seed: u64) -> Vec<DampedMode> {
    let mut rng = SmallRng::seed_from_u64(seed);
    modes
        .iter()
        .map(|m| DampedMode {
            amplitude: m.amplitude * rng.random_range(0.8f64..=1.2).sqrt(),
            ..*m
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &str = r#"{"cf": [537.3, 803.7, 379.4], "op": [-24.5, -39.7, -42.6], "rt": [0.241, 0.1326, 0.342], "synthMethod": "matchedMode"}"#;

    #[test]
    fn pyimpact_import_reproduces_frequencies_levels_and_rt60() {
        let s = ModeStatistics::from_pyimpact_json("metal", TABLE).unwrap();
        let modes = s.sample(5).unwrap();
        let f: Vec<f64> = modes.iter().map(|m| m.freq_hz).collect();
        for (got, want) in f.iter().zip([379.4, 537.3, 803.7]) {
            assert!((got / want - 1.0).abs() < 1e-12, "{got} {want}");
        }
        // RT60: the amplitude falls 60 dB (a factor 1000) in rt seconds.
        let m = &modes[1];
        assert!(((-m.damping_per_s * 0.241).exp() - 1e-3).abs() < 1e-9);
        assert!((20.0 * m.amplitude.log10() + 24.5).abs() < 1e-9);
        assert!(
            ModeStatistics::from_pyimpact_json("x", r#"{"cf": [1.0], "op": [], "rt": [1.0]}"#)
                .is_err()
        );
    }

    #[test]
    fn perturbation_stays_within_twenty_percent_of_power_and_is_seeded() {
        let s = ModeStatistics::from_pyimpact_json("metal", TABLE).unwrap();
        let m = s.mean_modes();
        let p = perturb(&m, 3);
        for (a, b) in m.iter().zip(&p) {
            let r = (b.amplitude / a.amplitude).powi(2);
            assert!((0.8..=1.2).contains(&r), "{r}");
            assert_eq!(a.freq_hz, b.freq_hz);
        }
        assert_eq!(p, perturb(&m, 3));
        assert_ne!(p, perturb(&m, 4));
    }
}
