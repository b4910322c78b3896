//! Headless Bevy: the material of a bundled recording (a steel nut on an aluminium ramp,
//! CC BY 4.0) is estimated on a stand-in bar, then three bars of it fall onto a table in a
//! Bevy app with MinimalPlugins (no window, no audio device); the sound goes to a WAV file.
//!
//! `cargo run --release -p resound-bevy --example headless [-- OUT.wav]`

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "bevy-drop.wav".to_string());
    let recording = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/recordings/steel_nut_M4_2.wav");
    let (material, output) =
        resound_bevy::drop_scene::estimate_and_drop(&recording, std::path::Path::new(&out))?;
    println!(
        "estimated: alpha {:.3e} 1/s, beta {:.3e} s, gamma {:.3e} m²/s²",
        material.alpha, material.beta, material.gamma
    );
    println!(
        "wrote {out}: {} impacts, {:.2} s",
        output.impacts.len(),
        output.channels[0].len() as f64 / output.sample_rate_hz
    );
    Ok(())
}
