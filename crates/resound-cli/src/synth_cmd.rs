//! `resound synth`: render one strike of an object made of a material, or of analysed modes.

use crate::estimate_cmd::object_params;
use crate::util::parse_vec3;
use anyhow::Result;
use clap::{Args, ValueEnum};
use resound::core::Material;
use resound::io::{write_wav, WavFormat};
use resound::strike::{render_strike_from, StrikeInfo, StrikeParams};
use resound::synth::excitation::ContactModel;
use serde::Serialize;
use std::path::PathBuf;

/// Contact force law.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ContactArg {
    /// Hertz contact: duration shrinks with speed.
    Hertz,
    /// Linear spring (Traer eq. 5): half sine, fixed duration.
    Spring,
    /// Ideal impulse.
    Impulse,
}

/// Output sample format.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FormatArg {
    /// 16-bit PCM.
    Pcm16,
    /// 24-bit PCM.
    Pcm24,
    /// 32-bit float.
    Float,
}

impl From<ContactArg> for ContactModel {
    fn from(c: ContactArg) -> Self {
        match c {
            ContactArg::Hertz => ContactModel::Hertz,
            ContactArg::Spring => ContactModel::Spring,
            ContactArg::Impulse => ContactModel::Impulse,
        }
    }
}

impl From<FormatArg> for WavFormat {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Pcm16 => WavFormat::Pcm16,
            FormatArg::Pcm24 => WavFormat::Pcm24,
            FormatArg::Float => WavFormat::Float32,
        }
    }
}

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
    #[arg(long, value_enum, default_value = "hertz")]
    pub contact: ContactArg,
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
    /// Elastic modes to compute when a mesh is given.
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
    #[arg(long, value_enum, default_value = "pcm24")]
    pub format: FormatArg,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
    /// Also play it on the default audio device (the engine runs in the audio callback; needs
    /// the `live` build feature).
    #[arg(long, hide = !cfg!(feature = "live"))]
    pub play: bool,
}

/// What sounds: `--modes`, `--stats` (with `--seed`), or `--material` on `--mesh` at `--hit`.
#[derive(Serialize)]
struct Output<'a> {
    /// The file written.
    output: String,
    #[serde(flatten)]
    strike: &'a StrikeInfo,
}

/// Runs `synth`.
pub fn run(a: SynthArgs) -> Result<()> {
    crate::util::check_paths(&a.object.inputs(), &[&a.output])?;
    let params = StrikeParams {
        speed_m_s: a.velocity,
        impactor_mass_kg: a.impactor_mass,
        impactor_radius_m: a.impactor_radius,
        impactor: Material::parse(&a.impactor_material)?,
        contact: a.contact.into(),
        residual: !a.no_residual,
        duration_s: a.duration,
        sample_rate_hz: a.sample_rate,
        mic_m: a.mic.as_deref().map(parse_vec3).transpose()?,
    };
    let source = a.object.source(
        a.seed,
        object_params(a.scale, a.mesh_modes, &a.reference_material)?,
    )?;
    let pb = crate::util::Bar::new("synth");
    let made = render_strike_from(&source, &params, &pb.callback());
    pb.finish_and_clear();
    let (mut strike, notes) = made?;
    for n in notes {
        eprintln!("note: {n}");
    }
    resound::strike::level_for_file(&mut strike)?;
    let info = &strike.info;
    crate::util::warn_all(&info.warnings);
    if info.gain_db < 0.0 {
        eprintln!(
            "note: peak {:.2} of full scale; turned down by {:.1} dB to −1 dBFS (no clipping)",
            info.peak, -info.gain_db
        );
    }
    write_wav(&a.output, &strike.samples, a.sample_rate, a.format.into())?;
    if a.play {
        resound::live::play(
            &strike,
            10f32.powf(strike.info.gain_db / 20.0),
            a.sample_rate,
            a.duration,
        )?;
    }
    if a.json {
        return crate::util::print_json(&Output {
            output: a.output.display().to_string(),
            strike: &strike.info,
        });
    }
    eprintln!(
        "wrote {} ({:.2} s, {} Hz)",
        a.output.display(),
        a.duration,
        a.sample_rate
    );
    Ok(())
}
