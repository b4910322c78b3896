//! `bench grains`: grains of the shared recordings.

use super::*;

/// Picard et al. 2009 §5.1: 94 recordings, 14.6 MB of 16-bit 44.1 kHz audio, 5171 grains;
/// MATLAB analysis 11 min (grains) + 4 h (patterns).
const PICARD_AUDIO_S: f64 = 14.6e6 / 2.0 / 44_100.0;
const PICARD_GRAINS: f64 = 5171.0;
const PICARD_MATLAB_S: f64 = 11.0 * 60.0 + 4.0 * 3600.0;

/// Runs `bench grains` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_grains(a: GrainsBenchArgs) -> Result<()> {
    let root = match a.data {
        Some(d) => d,
        None => ["../shared/data/recordings", "/work/shared/data/recordings"]
            .iter()
            .map(std::path::PathBuf::from)
            .find(|p| p.is_dir())
            .context("no shared recordings found; pass --data DIR")?,
    };
    let mut files: Vec<String> = Vec::new();
    for (sub, ext) in [("spatialaudio-ramp", "wav"), ("minetest-game", "ogg")] {
        let mut f: Vec<String> = std::fs::read_dir(root.join(sub))
            .with_context(|| format!("reading {}", root.join(sub).display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == ext))
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        f.sort();
        files.extend(f);
    }
    let (recs, fs, file_bytes) = resound::grain_files::load_recordings(
        &files,
        resound::grain_files::KindRule::Auto,
        Some(44_100),
    )?;
    let audio_s: f64 = recs.iter().map(|r| r.samples.len() as f64 / fs).sum();
    let t0 = std::time::Instant::now();
    let (dict, info) = resound::grains::analyze(
        &recs,
        fs,
        &resound::grains::AnalyzeParams::default(),
        &|_| {},
    )?;
    let analysis_s = t0.elapsed().as_secs_f64();
    // Quality after the 16-bit round trip of the file.
    let bytes = resound::io::grains_file::encode(&dict);
    let saved = resound::io::grains_file::decode(&bytes, std::path::Path::new("bench.grains"))?;
    let summary = resound::grain_files::summary(&saved, Some(&recs))?;
    // The pruned dictionary (grains that others stand in for at correlation 0.8 dropped).
    let pruned = resound::grains::prune::prune(&dict, 0.8);
    let pruned_bytes = resound::io::grains_file::encode(&pruned);
    let pruned = resound::io::grains_file::decode(&pruned_bytes, std::path::Path::new("p.grains"))?;
    let pruned_summary = resound::grain_files::summary(&pruned, Some(&recs))?;
    let pruned_sc: Vec<f64> = pruned_summary
        .recordings
        .iter()
        .filter_map(|r| r.spectral_convergence_db)
        .collect();
    let scale = PICARD_AUDIO_S / audio_s;
    let scaled = (info.sms_s + info.grains_s) * scale
        + info.patterns_s * scale * (PICARD_GRAINS / dict.grains.len().max(1) as f64);
    let sc: Vec<f64> = summary
        .recordings
        .iter()
        .filter_map(|r| r.spectral_convergence_db)
        .collect();
    // Compression by kind of recording (own grains and peaks against mono 16-bit originals).
    let class_ratio = |continuous: bool| {
        let (mut orig, mut stored) = (0.0, 0.0);
        for r in &summary.recordings {
            if (r.contact != resound::grains::Contact::Impact) == continuous {
                let ratio = r.compression_ratio;
                let o = r.duration_s * fs * 2.0;
                orig += o;
                stored += o / ratio.max(1e-12);
            }
        }
        orig / stored.max(1e-12)
    };
    let median = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let median_sc = median(&sc);
    #[derive(Serialize)]
    struct Pruned {
        grains: usize,
        compression_ratio: f64,
        spectral_convergence_db_median: f64,
        spectral_convergence_db_worst: f64,
        per_recording_db: Vec<f64>,
    }
    #[derive(Serialize)]
    struct Doc<'a> {
        benchmark: &'static str,
        recordings: usize,
        audio_s: f64,
        analysis_s: f64,
        sms_s: f64,
        grains_s: f64,
        patterns_s: f64,
        pairs: usize,
        grains: usize,
        analysis_s_scaled_94: f64,
        analysis_s_scaled_94_linear: f64,
        picard_matlab_s: f64,
        compression_ratio: f64,
        compression_ratio_impulsive: f64,
        compression_ratio_continuous: f64,
        compression_ratio_vs_files: f64,
        file_bytes: usize,
        source_file_bytes: usize,
        spectral_convergence_db_worst: f64,
        spectral_convergence_db_median: f64,
        per_recording: &'a [resound::grain_files::RecordingSummary],
        pruned_0_8: Pruned,
    }
    let worst = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let v = Doc {
        benchmark: "grains",
        recordings: recs.len(),
        audio_s,
        analysis_s,
        sms_s: info.sms_s,
        grains_s: info.grains_s,
        patterns_s: info.patterns_s,
        pairs: info.pairs,
        grains: dict.grains.len(),
        analysis_s_scaled_94: scaled,
        analysis_s_scaled_94_linear: analysis_s * scale,
        picard_matlab_s: PICARD_MATLAB_S,
        compression_ratio: summary.compression_ratio,
        compression_ratio_impulsive: class_ratio(false),
        compression_ratio_continuous: class_ratio(true),
        compression_ratio_vs_files: file_bytes as f64 / bytes.len().max(1) as f64,
        file_bytes: bytes.len(),
        source_file_bytes: file_bytes,
        spectral_convergence_db_worst: worst(&sc),
        spectral_convergence_db_median: median_sc,
        per_recording: &summary.recordings,
        pruned_0_8: Pruned {
            grains: pruned.grains.len(),
            compression_ratio: pruned_summary.compression_ratio,
            spectral_convergence_db_median: median(&pruned_sc),
            spectral_convergence_db_worst: worst(&pruned_sc),
            per_recording_db: pruned_sc.clone(),
        },
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "{} recordings, {:.1} s of audio: analysis {:.2} s (SMS {:.2}, grains {:.2}, patterns {:.2}); {} grains; scaled to Picard's 94 recordings: {:.1} s (MATLAB: {:.0} s); compression {:.2}:1 (impulsive {:.2}:1, continuous {:.2}:1); rebuild spectral convergence median {:.1} dB, worst {:.1} dB",
            recs.len(),
            audio_s,
            analysis_s,
            info.sms_s,
            info.grains_s,
            info.patterns_s,
            dict.grains.len(),
            scaled,
            PICARD_MATLAB_S,
            v.compression_ratio,
            v.compression_ratio_impulsive,
            v.compression_ratio_continuous,
            v.spectral_convergence_db_median,
            v.spectral_convergence_db_worst,
        );
        let p = &v.pruned_0_8;
        println!(
            "pruned at correlation 0.8: {} grains, compression {:.2}:1, rebuild median {:.1} dB, worst {:.1} dB",
            p.grains, p.compression_ratio, p.spectral_convergence_db_median, p.spectral_convergence_db_worst,
        );
    }
    Ok(())
}
