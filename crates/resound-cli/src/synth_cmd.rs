//! `resound synth`: render one strike of an object made of a material, or of analysed modes.

use crate::util::{named, parse_vec3};
use anyhow::Result;
use clap::Args;
use resound::core::Material;
use resound::io::{write_wav, WavFormat};
use resound::strike::{render_strike_from, StrikeParams};
use resound::synth::excitation::ContactModel;
use std::path::PathBuf;

/// Arguments of `synth`.
#[derive(Args, Debug)]
pub struct SynthArgs {
    #[command(flatten)]
    pub object: crate::util::ObjectSourceArgs,
    /// Seed of the sampled impulse response (`--stats`); the per-impact variation uses seed + 1.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Impact speed, m/s.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub velocity: f64,
    /// Impactor mass, kg (default: a sphere of --impactor-radius of the impactor material).
    #[arg(allow_hyphen_values = true, long)]
    pub impactor_mass: Option<f64>,
    /// Impactor radius at the contact, m.
    #[arg(allow_hyphen_values = true, long, default_value_t = 0.005)]
    pub impactor_radius: f64,
    /// Impactor material (preset name or E,nu,rho).
    #[arg(long, default_value = "steel")]
    pub impactor_material: String,
    /// Contact force law.
    #[arg(long, value_name = "hertz|spring|impulse", default_value = "hertz", value_parser = named::<ContactModel>)]
    pub contact: ContactModel,
    /// Leave out the material's residual (Ren §6).
    #[arg(long)]
    pub no_residual: bool,
    /// Length of the output, s.
    #[arg(allow_hyphen_values = true, long, default_value_t = 2.0)]
    pub duration: f64,
    /// Output sample rate, Hz.
    #[arg(long, default_value_t = 48_000)]
    pub sample_rate: u32,
    /// Scale applied to mesh coordinates (0.001 for millimetres).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub scale: f64,
    /// Elastic modes to compute at most when a mesh is given (only those below the Nyquist
    /// frequency in the material are solved).
    #[arg(long, default_value_t = 200)]
    pub mesh_modes: usize,
    /// Reference material for the modal solve (its density also sets the object's E = γρ for
    /// Hertz contact).
    #[arg(long, default_value = "ceramic")]
    pub reference_material: String,
    /// Microphone x,y,z in metres (model coordinates): weight each mode by what it radiates
    /// there (the model's acoustic transfer: `resound modal --transfer`, or fitted now).
    #[arg(long, allow_hyphen_values = true, conflicts_with_all = ["modes", "stats"])]
    pub mic: Option<String>,
    /// Output WAV file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output sample format.
    #[arg(long, value_name = "pcm16|pcm24|float", default_value = "pcm24", value_parser = named::<WavFormat>)]
    pub format: WavFormat,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
    /// Bring the peak to −1 dBFS instead of writing the strike's physical level.
    #[arg(long)]
    pub normalize: bool,
    /// Also play it on the default audio device (the engine runs in the audio callback; needs
    /// the `live` build feature).
    #[arg(long, hide = !cfg!(feature = "live"))]
    pub play: bool,
}

/// Runs `synth`.
pub fn run(a: SynthArgs) -> Result<()> {
    crate::util::check_paths(a.object.inputs(), [&a.output])?;
    let params = StrikeParams {
        speed_m_s: a.velocity,
        impactor_mass_kg: a.impactor_mass,
        impactor_radius_m: a.impactor_radius,
        impactor: Material::parse(&a.impactor_material)?,
        contact: a.contact,
        residual: !a.no_residual,
        duration_s: a.duration,
        sample_rate_hz: a.sample_rate,
        mic_m: a.mic.as_deref().map(parse_vec3).transpose()?,
    };
    let source = a.object.source(
        a.seed,
        resound::object::ObjectParams::new(a.scale, a.mesh_modes, &a.reference_material)?,
    )?;
    let (mut strike, notes) =
        crate::util::with_bar("synth", |cb| render_strike_from(&source, &params, cb))?;
    crate::util::notes(&notes);
    let level_note = match a.normalize {
        true => Some(resound::strike::normalize_for_file(&mut strike)?),
        false => resound::strike::level_for_file(&mut strike)?,
    };
    crate::util::warn_all(&strike.info.warnings);
    crate::util::notes(level_note.as_slice());
    write_wav(&a.output, &strike.samples, a.sample_rate, a.format)?;
    if a.play {
        resound::live::play(
            &strike,
            10f32.powf(strike.info.gain_db / 20.0),
            a.sample_rate,
            a.duration,
        )?;
    }
    if a.json {
        return crate::util::print_written(&a.output, &strike.info);
    }
    eprintln!(
        "wrote {} ({:.2} s, {} Hz)",
        a.output.display(),
        a.duration,
        a.sample_rate
    );
    Ok(())
}
