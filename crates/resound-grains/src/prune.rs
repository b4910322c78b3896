//! A smaller dictionary (Picard §5.1: "only a subset of the grain dictionary can be made
//! available"): drop the grains whose places in the recordings other grains can take.
//!
//! Every grain has one *slot*: where it was cut. A grain *covers* a slot when it is the slot's
//! own grain, or when its pattern peak in that part lies within a quarter of the slot grain's
//! length after the slot's start with |correlation| ≥ `min_corr`. A greedy set cover keeps the
//! grain covering the most uncovered slots until every slot is covered; the other grains and
//! their peaks go. Resynthesis then finds a kept grain at (or just after) every slot.

use crate::{Dictionary, Pattern};

/// Drops grains that other grains can stand in for (correlation ≥ `min_corr`).
pub fn prune(dict: &Dictionary, min_corr: f64) -> Dictionary {
    let n = dict.grains.len();
    // covers[g'] = slots (grain indices) g' covers.
    let mut covers: Vec<Vec<usize>> = (0..n).map(|g| vec![g]).collect();
    for (g, grain) in dict.grains.iter().enumerate() {
        let Some(p) = dict
            .patterns
            .iter()
            .find(|p| p.recording == grain.recording && p.part == grain.part)
        else {
            continue;
        };
        let from = grain.start;
        let to = from + (grain.samples.len() / 4) as u32;
        let lo = p.peaks.partition_point(|k| k.time < from);
        for k in p.peaks[lo..].iter().take_while(|k| k.time <= to) {
            let other = k.grain as usize;
            if other != g
                && f64::from(k.corr.abs()) >= min_corr
                && dict.grains[other].part == grain.part
            {
                covers[other].push(g);
            }
        }
    }
    let mut covered = vec![false; n];
    let mut keep = vec![false; n];
    let mut left = n;
    while left > 0 {
        let (best, gain) = (0..n)
            .filter(|&g| !keep[g])
            .map(|g| (g, covers[g].iter().filter(|&&s| !covered[s]).count()))
            .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
            .unwrap_or((0, 0));
        if gain == 0 {
            break;
        }
        keep[best] = true;
        for &s in &covers[best] {
            if !covered[s] {
                covered[s] = true;
                left -= 1;
            }
        }
    }
    let mut index = vec![u32::MAX; n];
    let mut grains = Vec::new();
    for (g, grain) in dict.grains.iter().enumerate() {
        if keep[g] {
            index[g] = grains.len() as u32;
            grains.push(grain.clone());
        }
    }
    let patterns = dict
        .patterns
        .iter()
        .map(|p| Pattern {
            peaks: p
                .peaks
                .iter()
                .filter(|k| keep[k.grain as usize])
                .map(|k| crate::Peak {
                    grain: index[k.grain as usize],
                    ..*k
                })
                .collect(),
            ..p.clone()
        })
        .collect();
    Dictionary {
        sample_rate_hz: dict.sample_rate_hz,
        recordings: dict.recordings.clone(),
        grains,
        patterns,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{analyze, Contact, Recording};
    use rand::SeedableRng;

    #[test]
    fn repeated_events_keep_one_grain_each_and_still_rebuild() {
        let fs = 44_100.0;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(3);
        let a = crate::testing::event(0, 2600, fs, &mut rng);
        let b = crate::testing::event(3, 2200, fs, &mut rng);
        // a b a b a: the second and third a, b are the same waveforms.
        let x: Vec<f32> = [&a, &b, &a, &b, &a]
            .into_iter()
            .flatten()
            .copied()
            .collect();
        let rec = Recording {
            name: "abab".into(),
            contact: Contact::Impact,
            samples: x.clone(),
        };
        let (d, _) = analyze(&[rec], fs, &Default::default(), &|_| {}).expect("analysis");
        let p = prune(&d, 0.9);
        p.validate().expect("valid");
        assert!(
            p.grains.len() < d.grains.len(),
            "{} → {}",
            d.grains.len(),
            p.grains.len()
        );
        let y = crate::resynth::resynthesize(&p, 0, &Default::default()).expect("rebuild");
        let sc = crate::quality::spectral_convergence_db(&x, &y, fs);
        assert!(
            sc < -20.0,
            "{sc} dB with {} of {} grains",
            p.grains.len(),
            d.grains.len()
        );
    }
}
