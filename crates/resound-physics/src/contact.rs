//! The one contact model of every front end: what a touching pair sounds like, from what a
//! physics engine reports of it after a step. Offline and live scenes (rapier's narrow phase,
//! [`crate::simulate`]) and the Bevy plugin (bevy_rapier's contact force events) both classify
//! and excite through here, so a game sounds like the same scene rendered offline. Free of
//! rapier types: an engine hands over plain numbers.
//!
//! - A pair that starts touching faster than [`IMPACT_MIN_SPEED`] is an **impact**: Hertz's
//!   force pulse for the two bodies' elasticity, reduced mass and the smaller contact radius,
//!   scaled to carry the solver's impulse ([`impact_pulse`]).
//! - A pair that stays in touch **slides** when its contact points slip faster than
//!   [`SLIP_MIN_SPEED`] (and than a tenth of the bodies' speed), else **rolls** when a body
//!   moves faster than [`MOVE_MIN_SPEED`]; each step's force follows
//!   `resound_synth::contact` (a rough profile read at the slip speed; the same low-passed and
//!   modulated by the roller's turn) — [`PairContact::continuous`].
//! - A pair still in touch whose points fly apart is an impact's rebound ([`is_leaving`]).
//! - Anything else rests and sends nothing.
//! - A pair in touch **damps** each body by a loss factor ([`contact_loss`]): a body resting
//!   on another rings shorter, sent when it changes enough ([`loss_changed`]).

use resound_synth::contact::{ContactForce, Profile, ROUGHNESS};
use resound_synth::excitation::{ContactModel, Elastic, Impact};
use serde::{Deserialize, Serialize};

/// Approach speed below which a new contact is not an impact, m/s.
pub const IMPACT_MIN_SPEED: f64 = 0.02;
/// Slip speed below which a contact does not slide, m/s.
pub const SLIP_MIN_SPEED: f64 = 0.01;
/// Speed below which a contact rests, m/s.
pub const MOVE_MIN_SPEED: f64 = 0.02;
/// Continuous force amplitudes below this are inaudible and not sent, N.
pub const MIN_CONTINUOUS_FORCE_N: f64 = 1e-6;
/// The elasticity assumed for a silent body (no material), as a hard plastic.
pub const SILENT_ELASTIC: Elastic = Elastic {
    youngs_modulus: 1e9,
    poisson_ratio: 0.3,
};

/// What kind of contact an event is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactKind {
    /// A new contact.
    Impact,
    /// Persistent contact with slip.
    Sliding,
    /// Persistent contact without slip.
    Rolling,
}

/// What one side of a contact brings to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactBody {
    /// Mass, kg (`f64::INFINITY` for an immovable body).
    pub mass_kg: f64,
    /// The radius of curvature Hertz contact sees, m.
    pub radius_m: f64,
    /// Elastic constants (Hertz stiffness).
    pub elastic: Elastic,
}

/// A typical contact radius of a body whose axis-aligned extents are `size` (m): a quarter of
/// the smallest (half the smallest half extent; a ball's radius is its own), at least 0.1 mm.
pub fn radius_from_extents(size: [f64; 3]) -> f64 {
    (0.25 * size.iter().copied().fold(f64::INFINITY, f64::min)).max(1e-4)
}

/// What a persisting contact does this step, with the speed that drives its force (m/s):
/// sliding at the slip speed, rolling at the moving body's speed, or `None` (resting, or a
/// force too small to hear). `slip_m_s`: the tangential relative speed of the contact points;
/// `moving_m_s`: the faster body's tangential speed; `normal_force_n`: the pair's normal force.
pub fn classify_persistent(
    slip_m_s: f64,
    moving_m_s: f64,
    normal_force_n: f64,
) -> Option<(ContactKind, f64)> {
    let kind = if slip_m_s > SLIP_MIN_SPEED && slip_m_s > 0.1 * moving_m_s {
        Some((ContactKind::Sliding, slip_m_s))
    } else if moving_m_s > MOVE_MIN_SPEED {
        Some((ContactKind::Rolling, moving_m_s))
    } else {
        None
    };
    kind.filter(|&(_, speed)| ROUGHNESS * normal_force_n * speed > MIN_CONTINUOUS_FORCE_N)
}

/// Whether a new contact approaching at `approach_m_s` (along the normal, before the step) is
/// an impact.
pub fn is_impact(approach_m_s: f64) -> bool {
    approach_m_s > IMPACT_MIN_SPEED
}

/// Whether a pair still reported in touch is flying apart: its contact points separate along
/// the normal faster than [`IMPACT_MIN_SPEED`] (`approach_m_s` < −that) after the step. That
/// is an impact's rebound (the solver spreads the impulse over the next step), not a body
/// resting or rubbing: it neither damps nor slides.
pub fn is_leaving(approach_m_s: f64) -> bool {
    approach_m_s < -IMPACT_MIN_SPEED
}

/// The force pulse of an impact between `bodies` approaching at `approach_m_s`: Hertz's shape
/// for their elasticity, reduced mass and the smaller contact radius, scaled to carry the
/// solver's `impulse_n_s` (restitution included), starting `at` samples (fractional) into the
/// step. Returns the pulse (N at unit scale), its scale and its first whole sample; `None`
/// when no pulse can be made (a speed or mass out of range).
pub fn impact_pulse(
    bodies: [ContactBody; 2],
    approach_m_s: f64,
    impulse_n_s: f64,
    at: f64,
    fs: f64,
) -> Option<(Vec<f32>, f64, usize)> {
    let [a, b] = bodies;
    let m_eff = if a.mass_kg.is_infinite() {
        b.mass_kg
    } else if b.mass_kg.is_infinite() {
        a.mass_kg
    } else {
        a.mass_kg * b.mass_kg / (a.mass_kg + b.mass_kg)
    };
    let imp = Impact {
        impactor_mass_kg: m_eff.max(1e-9),
        impactor_radius_m: a.radius_m.min(b.radius_m),
        impactor: a.elastic,
        object: b.elastic,
        object_mass_kg: None,
        speed_m_s: approach_m_s,
    };
    let first = at.max(0.0).floor();
    let offset = (at.max(0.0) - first) / fs;
    let pulse = imp
        .force_pulse(ContactModel::Hertz, fs, offset.min(0.999_999 / fs))
        .ok()?;
    let j_pulse: f64 = pulse.iter().map(|&f| f64::from(f)).sum::<f64>() / fs;
    let scale = if j_pulse > 0.0 {
        impulse_n_s / j_pulse
    } else {
        0.0
    };
    Some((pulse, scale, first as usize))
}

/// One touching pair's state across steps: where its force is along the profile (so steps
/// join without clicks), and what it did last (for event logging).
#[derive(Clone, Debug, Default)]
pub struct PairContact {
    /// The force state (for scraping a textured surface: [`ContactForce::scraping`]).
    pub force: ContactForce,
    /// When it was last logged, s.
    pub last_log_s: f64,
    /// What it did last step (`Impact` for a new or resting contact).
    pub last_kind: Option<ContactKind>,
}

impl PairContact {
    /// A new pair, starting `offset_m` along the profile (pairs at different offsets do not
    /// rub in unison).
    pub fn new(offset_m: f64) -> Self {
        Self {
            force: ContactForce::new(offset_m),
            ..Self::default()
        }
    }

    /// This step's force of a sliding or rolling contact into `out` (one value per sample at
    /// `fs`): `speed_m_s` as [`classify_persistent`] gave it, `roller_radius_m` the rolling
    /// body's radius. An impact kind writes nothing.
    pub fn continuous(
        &mut self,
        kind: ContactKind,
        profile: &Profile,
        normal_force_n: f64,
        speed_m_s: f64,
        roller_radius_m: f64,
        fs: f64,
        out: &mut [f32],
    ) {
        match kind {
            ContactKind::Sliding => {
                self.force
                    .sliding(profile, normal_force_n, speed_m_s, fs, out);
            }
            ContactKind::Rolling => {
                self.force
                    .rolling(profile, normal_force_n, speed_m_s, roller_radius_m, fs, out);
            }
            ContactKind::Impact => {}
        }
    }
}

/// The rough profile every continuous contact of a scene reads, from the scene's `seed`.
pub fn scene_profile(seed: u64) -> Profile {
    Profile::fractal(1 << 17, 1.0, seed)
}

/// Most contact loss factor a body takes on, however many contacts it has.
pub const MAX_CONTACT_LOSS: f64 = 0.2;

/// The loss factor a body with its own loss factor `own` ([`crate::DEFAULT_CONTACT_LOSS`] for
/// one that does not sound) takes on from a persisting contact with a body whose own is
/// `other`, carrying `normal_force` (N), the body weighing `weight` (N): the mean of the two
/// times the share of the weight the contact carries (at most 1). An immovable body (infinite
/// weight) takes on none; in zero gravity any pressing contact counts fully. Sum it over a
/// body's contacts and cap at [`MAX_CONTACT_LOSS`].
pub fn contact_loss(own: f64, other: f64, normal_force: f64, weight: f64) -> f64 {
    if !(normal_force > 0.0) || weight.is_infinite() {
        return 0.0;
    }
    let share = if weight > 0.0 {
        (normal_force / weight).min(1.0)
    } else {
        1.0
    };
    0.5 * (own + other) * share
}

/// Whether a body's loss factor `eta` should be sent again, `sent` being the last one sent:
/// when contact starts or ends, or it changes by more than a tenth (resting forces jitter
/// from step to step, and each change recomputes the body's poles).
pub fn loss_changed(eta: f64, sent: f64) -> bool {
    (eta > 0.0) != (sent > 0.0) || (eta - sent).abs() > 0.1 * sent
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEEL: Elastic = Elastic {
        youngs_modulus: 200e9,
        poisson_ratio: 0.29,
    };

    #[test]
    fn persisting_contacts_slide_roll_or_rest_by_their_speeds() {
        // A box dragged at 0.3 m/s slips as fast as it moves: sliding at the slip speed.
        assert_eq!(
            classify_persistent(0.3, 0.3, 10.0),
            Some((ContactKind::Sliding, 0.3))
        );
        // A ball rolling at 0.3 m/s: its contact point does not slip.
        assert_eq!(
            classify_persistent(0.001, 0.3, 10.0),
            Some((ContactKind::Rolling, 0.3))
        );
        // At rest; and a feather-light touch too faint to hear.
        assert_eq!(classify_persistent(0.001, 0.001, 10.0), None);
        assert_eq!(classify_persistent(0.3, 0.3, 1e-6), None);
        assert!(is_impact(0.5) && !is_impact(0.01));
    }

    #[test]
    fn an_impact_pulse_carries_the_solver_impulse_and_shortens_with_speed() {
        let fs = 96_000.0;
        let ball = ContactBody {
            mass_kg: 0.03,
            radius_m: 0.01,
            elastic: STEEL,
        };
        let floor = ContactBody {
            mass_kg: f64::INFINITY,
            radius_m: 0.05,
            elastic: STEEL,
        };
        let (slow, s_slow, _) = impact_pulse([ball, floor], 0.5, 0.02, 0.0, fs).unwrap();
        let (fast, s_fast, at) = impact_pulse([floor, ball], 4.0, 0.2, 3.5, fs).unwrap();
        for (p, s, j) in [(&slow, s_slow, 0.02), (&fast, s_fast, 0.2)] {
            let carried = p.iter().map(|&f| f64::from(f)).sum::<f64>() * s / fs;
            assert!((carried / j - 1.0).abs() < 1e-9, "{carried} vs {j}");
        }
        // Hertz: contact time ∝ v^(−1/5), so 8× faster is 1.5× shorter; the order of the
        // bodies does not matter, and the pulse starts at its sample.
        // (Timed finely: at 96 kHz a steel pulse is a few samples long.)
        let fine = 1e7;
        let len = |v: f64| {
            impact_pulse([ball, floor], v, 0.1, 0.0, fine)
                .unwrap()
                .0
                .len()
        };
        let ratio = len(0.5) as f64 / len(4.0) as f64;
        assert!((ratio - 8f64.powf(0.2)).abs() < 0.03, "{ratio}");
        assert_eq!(at, 3);
        // A steel ball on steel rings for tens of microseconds, not a fixed half millisecond.
        assert!((slow.len() as f64) / fs < 2e-4, "{} samples", slow.len());
    }

    #[test]
    fn the_contact_radius_of_extents_is_a_quarter_of_the_smallest() {
        assert_eq!(radius_from_extents([0.1, 0.03, 0.005]), 0.25 * 0.005);
        assert_eq!(radius_from_extents([0.0, 1.0, 1.0]), 1e-4);
    }
}
