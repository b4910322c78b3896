//! `bench analyze`: recording analysis (Ren's protocol, mixtures, the wide protocol).

use super::*;

/// Runs `bench analyze` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_analyze(a: AnalyzeBenchArgs) -> Result<()> {
    use crate::analysis::{mixtures, single_sinusoids, wide};
    use resound::signal::AnalyzeParams;
    let parse = |list: &str| {
        list.split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .with_context(|| format!("bad SNR '{s}'"))
            })
            .collect::<Result<Vec<f64>>>()
    };
    let snrs = if a.wide_only {
        Vec::new()
    } else {
        parse(&a.snr_db)?
    };
    let wide_snrs = if a.wide == 0 {
        Vec::new()
    } else {
        parse(&a.wide_snr_db)?
    };
    let mut methods = vec![("refined", AnalyzeParams::default())];
    if !a.no_stage1 {
        methods.push((
            "stage1",
            AnalyzeParams {
                refine: false,
                ..AnalyzeParams::default()
            },
        ));
    }
    #[derive(Serialize)]
    struct Method {
        #[serde(skip_serializing_if = "Option::is_none")]
        single: Option<crate::analysis::SingleReport>,
        mixtures: Vec<crate::analysis::MixtureReport>,
        wide: Vec<crate::analysis::WideReport>,
        seconds_per_audio_second: f64,
    }
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        #[serde(skip_serializing_if = "Option::is_none")]
        refined: Option<Method>,
        #[serde(skip_serializing_if = "Option::is_none")]
        stage1: Option<Method>,
        /// The textbook ESPRIT baseline on the wide protocol's cases.
        #[serde(skip_serializing_if = "Option::is_none")]
        esprit: Option<Vec<crate::analysis::WideReport>>,
    }
    let mut out = Doc {
        benchmark: "analyze",
        refined: None,
        stage1: None,
        esprit: None,
    };
    for (name, params) in &methods {
        if !a.json && !a.wide_only {
            eprintln!("bench analyze [{name}]: {} single sinusoids ...", a.trials);
        }
        let single = (!a.wide_only).then(|| single_sinusoids(a.trials, a.seed, params));
        let mut mix = Vec::new();
        for &snr in &snrs {
            if !a.json {
                eprintln!(
                    "bench analyze [{name}]: {} mixtures at {snr} dB SNR ...",
                    a.mixtures
                );
            }
            mix.push(mixtures(snr, a.mixtures, a.seed + 1, params));
        }
        let mut wides = Vec::new();
        for &snr in &wide_snrs {
            if !a.json {
                eprintln!(
                    "bench analyze [{name}]: {} wide-range cases at {snr} dB SNR ...",
                    a.wide
                );
            }
            wides.push(wide(snr, a.wide, a.seed + 2, params));
        }
        let secs: f64 =
            mix.iter().map(|m| m.seconds_per_audio_second).sum::<f64>() / mix.len().max(1) as f64;
        if !a.json {
            if let Some(single) = &single {
                println!(
                    "[{name}] protocol 1 (Ren 2013, {} noise-free single modes, 44.1 kHz, 1 s):",
                    single.trials
                );
                println!(
                "  mean error f {:.2e} %  d {:.2e} %  (max {:.2e} %, {:.2e} %), missed {}, {:.3} s per s of audio",
                single.mean_freq_error_pct,
                single.mean_damping_error_pct,
                single.max_freq_error_pct,
                single.max_damping_error_pct,
                single.missed,
                single.seconds_per_audio_second
            );
                println!("[{name}] protocol 2 (mixtures of 1-24 modes, white noise):");
                println!(
                    "  {:>6} {:>7} {:>9} {:>11} {:>10} {:>12} {:>12} {:>10}",
                    "SNR_dB",
                    "modes",
                    "recall",
                    "recall(det)",
                    "spurious",
                    "f_err/CRB",
                    "d_err/CRB",
                    "s/s audio"
                );
                for m in &mix {
                    println!(
                        "  {:>6.0} {:>7} {:>9.3} {:>11.3} {:>10.3} {:>12.2} {:>12.2} {:>10.3}",
                        m.snr_db,
                        m.reference_modes,
                        m.recall,
                        m.recall_detectable,
                        m.spurious,
                        m.median_freq_error_over_crb,
                        m.median_damping_error_over_crb,
                        m.seconds_per_audio_second
                    );
                }
                println!("[{name}] mean analysis time per second of audio (mixtures): {secs:.3} s");
            }
            print_wide(name, &wides);
        }
        let m = Some(Method {
            single,
            mixtures: mix,
            wide: wides,
            seconds_per_audio_second: secs,
        });
        if *name == "refined" {
            out.refined = m;
        } else {
            out.stage1 = m;
        }
    }
    if !a.no_baseline && !wide_snrs.is_empty() {
        let mut rows = Vec::new();
        for &snr in &wide_snrs {
            if !a.json {
                eprintln!(
                    "bench analyze [esprit]: {} wide-range cases at {snr} dB SNR (textbook ESPRIT) ...",
                    a.wide
                );
            }
            rows.push(crate::analysis::wide_with(
                snr,
                a.wide,
                a.seed + 2,
                |x, fs| Some(crate::esprit::textbook_esprit(x, fs)),
            ));
        }
        if !a.json {
            print_wide("esprit", &rows);
            if let Some(ours) = out.refined.as_ref().filter(|m| m.wide.len() == rows.len()) {
                println!("[refined vs esprit] same cases, same run:");
                for (o, e) in ours.wide.iter().zip(&rows) {
                    println!(
                        "  {:>4.0} dB: recall {:.3} vs {:.3}, spurious {:.3} vs {:.3}, time {:.2}x the baseline's",
                        o.snr_db,
                        o.recall,
                        e.recall,
                        o.spurious,
                        e.spurious,
                        o.seconds_per_audio_second / e.seconds_per_audio_second.max(1e-12)
                    );
                }
            }
        }
        out.esprit = Some(rows);
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    }
    Ok(())
}

/// Prints the wide protocol's table of one method.
fn print_wide(name: &str, wides: &[crate::analysis::WideReport]) {
    if wides.is_empty() {
        return;
    }
    println!("[{name}] protocol 4 (wide: 20 Hz-22 kHz, d 0.1-1000 1/s, doublets, noisy lead-in + DC, 48 kHz):");
    println!(
        "  {:>6} {:>6} {:>7} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>7} {:>9}",
        "SNR_dB",
        "modes",
        "recall",
        "spurious",
        "d>100",
        "f<300",
        "doublet",
        "f/CRB",
        "d/CRB",
        "onset2ms",
        "failed",
        "s/s"
    );
    for w in wides {
        println!(
            "  {:>6.0} {:>6} {:>7.3} {:>9.3} {:>8.3} {:>8.3} {:>8.3} {:>9.2} {:>9.2} {:>9.2} {:>7} {:>9.3}",
            w.snr_db, w.reference_modes, w.recall, w.spurious, w.recall_damped, w.recall_low,
            w.recall_doublet, w.median_freq_error_over_crb, w.median_damping_error_over_crb,
            w.onset_within_2ms, w.failed, w.seconds_per_audio_second
        );
    }
}
