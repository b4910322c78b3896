//! Scene files (TOML): bodies, their shapes and materials, the listener, the run's settings.
//!
//! ```toml
//! # A steel ball dropped on a wooden table, heard from 60 cm.
//! duration = 3.0            # s
//! sample_rate = 48000       # Hz
//! seed = 1                  # surface textures
//! stereo = true
//! ambisonics = false        # true: 4 channels of first-order ambisonics (AmbiX W Y Z X)
//! radiation = false         # true: modes radiate by each model's acoustic transfer
//!
//! [listener]
//! position = [0.0, 0.3, 0.6]   # m (y is up)
//!
//! [floor]                      # optional: a reflecting floor (an image source per body)
//! height = 0.0                 # m
//! reflection = 0.9             # pressure reflection coefficient
//!
//! [air]                        # absorption per mode (ISO 9613-1); these are the defaults
//! absorption = true
//! temperature = 20.0           # °C
//! humidity = 50.0              # %
//! pressure = 101.325           # kPa
//!
//! [[body]]
//! name = "table"
//! fixed = true                 # does not move (floor, table); still sounds
//! shape = { box = [1.0, 0.04, 0.6] }   # full sizes, m
//! material = "preset:wood"     # a library name, a material file (.json), or preset:NAME
//! density = 700                # kg/m³
//! position = [0.0, -0.02, 0.0] # m
//!
//! [[body]]
//! name = "ball"
//! shape = { sphere = 0.02 }    # radius, m
//! material = "preset:steel"
//! density = 7850
//! position = [0.0, 0.3, 0.0]
//! velocity = [0.0, 0.0, 0.0]          # m/s
//! angular_velocity = [0.0, 0.0, 0.0]  # rad/s
//! restitution = 0.6
//! friction = 0.4
//! modes = 24                   # modes of its modal model
//! ```
//!
//! Shapes: `box = [x, y, z]`, `plate = [x, y, thickness]` (full sizes), `sphere = r`,
//! `cylinder = [r, height]` (along z), `bowl = [r, thickness]` or `[r, thickness, depth]`,
//! `mesh = "file.obj"` (relative to the scene file; `scale` multiplies its coordinates).
//! `rotation` is a rotation vector in degrees (axis × angle). `sound = { stats =
//! "metal.stats.json" }` (or `stats = "…"`) makes a body sound from mode statistics instead of
//! its modal model, `sound = { grains = "stone.grains", gain = 1.0 }` from recorded grains
//! retargeted to its contacts (`resound grains analyze`), `sound = false` silences it;
//! `surface = "fractal"` (or a
//! `.npy` height profile, with `surface_spacing` and `roughness` in m) makes sliding on it
//! scrape by Traer's model. `contact_damping = 0.02` is the loss factor a body takes on
//! (and gives) while it rests, slides or rolls on another with its weight (0: none). Errors
//! name the line and the field.

/// The scene format in brief, for a front end's help (`resound scene --help`).
pub const FORMAT_HELP: &str = "\
Scene file (TOML; y is up, SI units):
  duration = 4.0            # s
  sample_rate = 48000       # Hz
  seed = 7
  stereo = true
  [listener]
  position = [0.0, 0.35, 0.7]
  [[body]]                  # one table per body
  name = \"ball\"
  shape = { sphere = 0.02 } # or box = [x, y, z], plate = [x, y, thickness],
                            # cylinder = [radius, height], bowl = [radius, thickness, depth],
                            # mesh = \"file.obj\"
  material = \"metal\"      # library or built-in name, material file, or preset:NAME
  density = 7850            # kg/m³
  position = [0, 0.3, 0]    # m; also rotation (degrees), velocity (m/s),
                            # angular_velocity (rad/s), restitution, friction
  fixed = false             # a fixed body (the table) does not move
  modes = 40                # modes solved for its sound
  # sound = { grains = \"x.grains\", gain = 1.0 } or { stats = \"x.stats.json\" }
Every field: the docs of resound_io::scene::BodyFile. A full example: assets/scenes/demo.toml
(`resound demo` writes it with its materials to demo-out/scene.toml).";

use serde::Deserialize;
use std::path::Path;

/// A parsed, validated scene file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Length of the rendering, s.
    #[serde(default = "default_duration")]
    pub duration: f64,
    /// Output sample rate, Hz.
    #[serde(default = "default_rate")]
    pub sample_rate: u32,
    /// Seed of the surface textures.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Stereo output.
    #[serde(default = "default_true")]
    pub stereo: bool,
    /// First-order ambisonics (4 channels, AmbiX: W Y Z X, SN3D) instead of stereo.
    #[serde(default)]
    pub ambisonics: bool,
    /// Each modal body's modes radiate by its acoustic transfer (level and directivity per
    /// mode, near and far field; fitted once per model and cached with it) instead of alike.
    #[serde(default)]
    pub radiation: bool,
    /// Physics steps per second.
    #[serde(default = "default_steps")]
    pub steps_per_second: f64,
    /// Gravity, m/s².
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// The listener.
    #[serde(default)]
    pub listener: Listener,
    /// The air (absorption per mode, ISO 9613-1).
    #[serde(default)]
    pub air: AirFile,
    /// A reflecting floor (an image source per body).
    #[serde(default)]
    pub floor: Option<FloorFile>,
    /// The bodies.
    pub body: Vec<BodyFile>,
}

/// A body's material: a reference (library name, material file, `preset:NAME`) or the material
/// itself (a material document inline: scenes built in code pass their materials as values).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum MaterialSpec {
    /// A library name, a material file (relative to the scene) or `preset:NAME`.
    Name(String),
    /// The material document itself (validated like a material file).
    Inline(Box<resound_core::SoundMaterial>),
}

/// The air between the bodies and the listener.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AirFile {
    /// Absorb sound in the air (ISO 9613-1); `false`: distance and delay only.
    #[serde(default = "default_true")]
    pub absorption: bool,
    /// Temperature, °C.
    #[serde(default = "default_temperature")]
    pub temperature: f64,
    /// Relative humidity, %.
    #[serde(default = "default_humidity")]
    pub humidity: f64,
    /// Atmospheric pressure, kPa.
    #[serde(default = "default_pressure")]
    pub pressure: f64,
}

impl Default for AirFile {
    fn default() -> Self {
        Self {
            absorption: true,
            temperature: default_temperature(),
            humidity: default_humidity(),
            pressure: default_pressure(),
        }
    }
}

fn default_temperature() -> f64 {
    20.0
}
fn default_humidity() -> f64 {
    50.0
}
fn default_pressure() -> f64 {
    101.325
}

/// A floor that reflects sound.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FloorFile {
    /// Height of the floor plane, m.
    #[serde(default)]
    pub height: f64,
    /// Pressure reflection coefficient, 0–1.
    #[serde(default = "default_reflection")]
    pub reflection: f64,
}

fn default_reflection() -> f64 {
    0.9
}

/// Where the listener is.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Listener {
    /// Position, m.
    pub position: [f64; 3],
}

impl Default for Listener {
    fn default() -> Self {
        Self {
            position: [0.0, 0.5, 1.0],
        }
    }
}

/// A body's shape.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(rename_all = "lowercase")]
pub enum ShapeFile {
    /// Box, full sizes.
    Box([f64; 3]),
    /// Plate, full sizes (x, y, thickness along z).
    Plate([f64; 3]),
    /// Sphere radius.
    Sphere(f64),
    /// Cylinder radius and height (along z).
    Cylinder([f64; 2]),
    /// Bowl radius, thickness (, depth).
    Bowl(Vec<f64>),
    /// Mesh file.
    Mesh(String),
}

/// A body's `sound` field.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum SoundFile {
    /// Sounds from its modal model (`true`) or not at all (`false`).
    Flag(bool),
    /// Sounds from mode statistics.
    Stats {
        /// The `.stats.json` file.
        stats: String,
    },
    /// Sounds from recorded grains (Picard 2009) retargeted to its contacts.
    Grains {
        /// The `.grains` dictionary (`resound grains analyze`).
        grains: String,
        /// Level factor.
        #[serde(default = "default_gain")]
        gain: f64,
    },
}

fn default_gain() -> f64 {
    1.0
}

impl Default for SoundFile {
    fn default() -> Self {
        SoundFile::Flag(true)
    }
}

impl BodyFile {
    /// Whether the body sounds at all.
    pub fn sounds(&self) -> bool {
        !matches!(self.sound, SoundFile::Flag(false))
    }

    /// The statistics file the body sounds from, if any (`sound = { stats = … }` or `stats`).
    pub fn stats_file(&self) -> Option<&str> {
        match &self.sound {
            SoundFile::Stats { stats } => Some(stats),
            SoundFile::Flag(true) => self.stats.as_deref(),
            SoundFile::Flag(false) | SoundFile::Grains { .. } => None,
        }
    }

    /// The grain dictionary the body sounds from and its gain, if any
    /// (`sound = { grains = …, gain = … }`).
    pub fn grains_file(&self) -> Option<(&str, f64)> {
        match &self.sound {
            SoundFile::Grains { grains, gain } => Some((grains, *gain)),
            _ => None,
        }
    }
}

/// One body.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyFile {
    /// Unique name.
    pub name: String,
    /// Shape.
    pub shape: ShapeFile,
    /// Material: library name, material file, or `preset:NAME` (or a material document
    /// inline). With `stats`, it only names the elastic constants for Hertz contact (a preset
    /// name) and may be any of these.
    pub material: MaterialSpec,
    /// Sound from mode statistics (`resound stats`, a `.stats.json` file) instead of a modal
    /// model of the shape: one sampled impulse response per body, powers varied ±20 % over the
    /// surface (Traer 2019).
    #[serde(default)]
    pub stats: Option<String>,
    /// Density, kg/m³.
    pub density: f64,
    /// Immovable.
    #[serde(default)]
    pub fixed: bool,
    /// Position, m.
    #[serde(default)]
    pub position: [f64; 3],
    /// Rotation vector, degrees.
    #[serde(default)]
    pub rotation: [f64; 3],
    /// Linear velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Angular velocity, rad/s.
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    /// Restitution.
    #[serde(default = "default_restitution")]
    pub restitution: f64,
    /// Friction.
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Modes of the modal model.
    #[serde(default = "default_modes")]
    pub modes: usize,
    /// Voxels along the longest side (0: automatic).
    #[serde(default)]
    pub resolution: usize,
    /// Poisson's ratio of the modal model.
    #[serde(default = "default_poisson")]
    pub poisson: f64,
    /// Mesh coordinate scale.
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Whether and how the body sounds: `true` (its modal model), `false`, or
    /// `{ stats = "metal.stats.json" }` (Traer's statistical model, like the `stats` field).
    #[serde(default)]
    pub sound: SoundFile,
    /// Surface texture for scraping (Traer §4): "fractal" or a `.npy` height profile (m).
    #[serde(default)]
    pub surface: Option<String>,
    /// Sample spacing of the texture, m.
    #[serde(default = "default_spacing")]
    pub surface_spacing: f64,
    /// RMS height of a fractal texture, m.
    #[serde(default = "default_roughness")]
    pub roughness: f64,
    /// Contact damping: the loss factor this body takes on (and gives) across a contact that
    /// carries its weight (default 0.02; 0: none).
    #[serde(default)]
    pub contact_damping: Option<f64>,
}

fn default_spacing() -> f64 {
    1e-5
}
fn default_roughness() -> f64 {
    5e-6
}

fn default_duration() -> f64 {
    3.0
}
fn default_rate() -> u32 {
    48_000
}
fn default_seed() -> u64 {
    1
}
fn default_true() -> bool {
    true
}
fn default_steps() -> f64 {
    240.0
}
fn default_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}
fn default_restitution() -> f64 {
    0.5
}
fn default_friction() -> f64 {
    0.5
}
fn default_modes() -> usize {
    32
}
fn default_poisson() -> f64 {
    0.3
}
fn default_scale() -> f64 {
    1.0
}

/// A scene file that cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneFileError {
    /// Unreadable file.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: String,
        /// Why.
        message: String,
    },
    /// TOML syntax or a field of the wrong type, missing or unknown (the message names the
    /// line, the column and the field).
    #[error("{path}: {message}")]
    Parse {
        /// File.
        path: String,
        /// toml's message.
        message: String,
    },
    /// A value out of range.
    #[error("{path}{}: {field}: {message}", if *line == 0 { String::new() } else { format!(", line {line}") })]
    Invalid {
        /// File.
        path: String,
        /// Line (1-based; 0 for a scene that came from no text, such as a Python dict).
        line: usize,
        /// Field (`body "ball".density`).
        field: String,
        /// What is wrong.
        message: String,
    },
}

/// Reads and validates a scene file.
pub fn read_scene(path: &Path) -> Result<SceneFile, SceneFileError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneFileError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    parse_scene(&text, &path.display().to_string())
}

/// Parses and validates scene text; `path` names it in messages.
pub fn parse_scene(text: &str, path: &str) -> Result<SceneFile, SceneFileError> {
    let scene: SceneFile = toml::from_str(text).map_err(|e| SceneFileError::Parse {
        path: path.to_string(),
        message: e.to_string().trim_end().to_string(),
    })?;
    validate_scene(scene, path, Some(text))
}

/// The byte ranges of each `[[body]]` table in scene text, in order (to the next table of
/// bodies or the end).
fn body_spans(text: &str) -> Vec<std::ops::Range<usize>> {
    let mut starts = Vec::new();
    let mut offset = 0;
    for l in text.split_inclusive('\n') {
        if l.trim_start().starts_with("[[body]]") {
            starts.push(offset);
        }
        offset += l.len();
    }
    (0..starts.len())
        .map(|k| starts[k]..starts.get(k + 1).copied().unwrap_or(text.len()))
        .collect()
}

/// Validates a scene deserialized from any format (TOML text, a Python dict, JSON) with the
/// scene file's rules and messages. `text`, when the scene came from text, lets errors name
/// the line; without it they name the field alone (line 0).
///
/// # Errors
/// A value out of range, named by its field.
pub fn validate_scene(
    scene: SceneFile,
    path: &str,
    text: Option<&str>,
) -> Result<SceneFile, SceneFileError> {
    let text_or_empty = text.unwrap_or("");
    let line_of = |offset: usize| {
        if text.is_none() {
            return 0;
        }
        text_or_empty[..offset.min(text_or_empty.len())]
            .matches('\n')
            .count()
            + 1
    };
    let line_of_key = |key: &str| {
        if text.is_none() {
            return 0;
        }
        text_or_empty
            .lines()
            .position(|l| l.trim_start().starts_with(key))
            .map_or(1, |i| i + 1)
    };
    let invalid = |line: usize, field: String, message: String| SceneFileError::Invalid {
        path: path.to_string(),
        line,
        field,
        message,
    };
    if let Some(f) = &scene.floor {
        if !(f.height.is_finite() && (0.0..=1.0).contains(&f.reflection)) {
            return Err(invalid(
                line_of_key("reflection").max(line_of_key("height")),
                "floor".into(),
                format!(
                    "height must be finite and reflection in [0, 1], got {} m, {}",
                    f.height, f.reflection
                ),
            ));
        }
    }
    let a = &scene.air;
    if !((-40.0..=60.0).contains(&a.temperature)
        && (0.0..=100.0).contains(&a.humidity)
        && (50.0..=110.0).contains(&a.pressure))
    {
        return Err(invalid(
            line_of_key("temperature").max(line_of_key("humidity")),
            "air".into(),
            format!(
                "temperature must be within −40…60 °C, humidity 0–100 % and pressure \
                 50–110 kPa, got {} °C, {} %, {} kPa",
                a.temperature, a.humidity, a.pressure
            ),
        ));
    }
    if !(scene.duration > 0.0 && scene.duration <= 3600.0) {
        return Err(invalid(
            line_of_key("duration"),
            "duration".into(),
            format!("must be in (0, 3600] s, got {}", scene.duration),
        ));
    }
    if !resound_core::limits::sample_rate_ok(f64::from(scene.sample_rate)) {
        return Err(invalid(
            line_of_key("sample_rate"),
            "sample_rate".into(),
            resound_core::limits::sample_rate_message(f64::from(scene.sample_rate)),
        ));
    }
    if !(30.0..=4000.0).contains(&scene.steps_per_second) {
        return Err(invalid(
            line_of_key("steps_per_second"),
            "steps_per_second".into(),
            format!("must be within 30–4000, got {}", scene.steps_per_second),
        ));
    }
    if !scene
        .listener
        .position
        .iter()
        .chain(&scene.gravity)
        .all(|v| v.is_finite())
    {
        return Err(invalid(
            line_of_key("position"),
            "listener.position".into(),
            "must be finite".into(),
        ));
    }
    if scene.body.is_empty() {
        return Err(invalid(
            line_of(0),
            "body".into(),
            "the scene has no bodies".into(),
        ));
    }
    let mut names = std::collections::HashSet::new();
    let spans = body_spans(text_or_empty);
    for (bi, b) in scene.body.iter().enumerate() {
        // This body's text: from its table to the next body's (an inline array of bodies has
        // no table of its own: its lines are the scene's first).
        let span = spans.get(bi).cloned().unwrap_or(0..0);
        let body_line = line_of(span.start);
        // The line of `key = …` within this body's table, else the table's first line.
        let key_line = |key: &str| {
            let t = text_or_empty;
            let region = &t[span.start.min(t.len())..span.end.min(t.len())];
            let mut offset = span.start;
            for l in region.split_inclusive('\n') {
                let t = l.trim_start();
                if t.strip_prefix(key)
                    .is_some_and(|rest| rest.trim_start().starts_with('='))
                {
                    return line_of(offset);
                }
                offset += l.len();
            }
            body_line
        };
        let field = |f: &str| format!("body {:?}.{f}", b.name);
        let line = body_line;
        if b.name.trim().is_empty() || !names.insert(b.name.clone()) {
            return Err(invalid(
                line,
                "body.name".into(),
                format!("names must be non-empty and unique, got {:?}", b.name),
            ));
        }
        if !(b.density.is_finite() && b.density > 0.0) {
            return Err(invalid(
                key_line("density"),
                field("density"),
                format!("must be > 0 kg/m³, got {}", b.density),
            ));
        }
        if !(0.0..=1.0).contains(&b.restitution) {
            return Err(invalid(
                key_line("restitution"),
                field("restitution"),
                format!("must be in [0, 1], got {}", b.restitution),
            ));
        }
        if !(b.friction.is_finite() && b.friction >= 0.0) {
            return Err(invalid(
                key_line("friction"),
                field("friction"),
                format!("must be ≥ 0, got {}", b.friction),
            ));
        }
        if !(1..=500).contains(&b.modes) {
            return Err(invalid(
                key_line("modes"),
                field("modes"),
                format!("must be in 1..=500, got {}", b.modes),
            ));
        }
        if !(b.poisson > 0.0 && b.poisson < 0.5) {
            return Err(invalid(
                key_line("poisson"),
                field("poisson"),
                format!("must be in (0, 0.5), got {}", b.poisson),
            ));
        }
        if !(b.scale.is_finite() && b.scale > 0.0) {
            return Err(invalid(
                key_line("scale"),
                field("scale"),
                format!("must be > 0, got {}", b.scale),
            ));
        }
        if let Some((_, gain)) = b.grains_file() {
            if !(gain.is_finite() && gain >= 0.0) {
                return Err(invalid(
                    key_line("sound"),
                    field("sound.gain"),
                    format!("must be ≥ 0, got {gain}"),
                ));
            }
        }
        if !(b.surface_spacing > 0.0
            && b.surface_spacing < 0.01
            && b.roughness > 0.0
            && b.roughness < 0.01)
        {
            return Err(invalid(
                key_line("surface_spacing"),
                field("surface_spacing"),
                format!(
                    "surface_spacing and roughness must be in (0, 0.01) m, got {} and {}",
                    b.surface_spacing, b.roughness
                ),
            ));
        }
        if let Some(eta) = b.contact_damping {
            if !(0.0..=0.5).contains(&eta) {
                return Err(invalid(
                    key_line("contact_damping"),
                    field("contact_damping"),
                    format!("must be a loss factor in [0, 0.5], got {eta}"),
                ));
            }
        }
        match &b.material {
            MaterialSpec::Name(n) if n.trim().is_empty() => {
                return Err(invalid(
                    key_line("material"),
                    field("material"),
                    "must name a material".into(),
                ));
            }
            MaterialSpec::Inline(m) => {
                if let Err(e) = m.validate() {
                    return Err(invalid(key_line("material"), field("material"), e));
                }
            }
            MaterialSpec::Name(_) => {}
        }
        let vectors = [
            ("position", b.position),
            ("rotation", b.rotation),
            ("velocity", b.velocity),
            ("angular_velocity", b.angular_velocity),
        ];
        if let Some((name, _)) = vectors
            .iter()
            .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
        {
            return Err(invalid(
                key_line(name),
                field(name),
                "must be finite".into(),
            ));
        }
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let shape_ok = match &b.shape {
            ShapeFile::Box(s) | ShapeFile::Plate(s) => s.iter().all(|&v| pos(v)),
            ShapeFile::Sphere(r) => pos(*r),
            ShapeFile::Cylinder(s) => s.iter().all(|&v| pos(v)),
            ShapeFile::Bowl(s) => (2..=3).contains(&s.len()) && s.iter().all(|&v| pos(v)),
            ShapeFile::Mesh(p) => !p.trim().is_empty(),
        };
        if !shape_ok {
            return Err(invalid(
                key_line("shape"),
                field("shape"),
                format!(
                    "sizes must be positive (bowl: 2 or 3 values), got {:?}",
                    b.shape
                ),
            ));
        }
    }
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
duration = 2.0
[listener]
position = [0, 0.3, 0.6]

[[body]]
name = "table"
fixed = true
shape = { box = [1.0, 0.04, 0.6] }
material = "preset:wood"
density = 700

[[body]]
name = "ball"
shape = { sphere = 0.02 }
material = "preset:steel"
density = 7850
position = [0, 0.3, 0]
"#;

    #[test]
    fn a_good_scene_parses_with_defaults() {
        let s = parse_scene(GOOD, "s.toml").unwrap();
        assert_eq!(s.body.len(), 2);
        let ball = &s.body[1];
        assert_eq!(ball.shape, ShapeFile::Sphere(0.02));
        assert_eq!(
            (ball.modes, ball.restitution, s.sample_rate),
            (32, 0.5, 48_000)
        );
    }

    #[test]
    fn sound_takes_a_flag_or_statistics() {
        let s = parse_scene(
            &GOOD.replace(
                "density = 7850",
                "density = 7850\nsound = { stats = \"m.stats.json\" }",
            ),
            "s.toml",
        )
        .unwrap();
        assert_eq!(s.body[1].stats_file(), Some("m.stats.json"));
        let s = parse_scene(
            &GOOD.replace("density = 7850", "density = 7850\nsound = false"),
            "s.toml",
        )
        .unwrap();
        assert!(!s.body[1].sounds());
        assert!(s.body[0].sounds() && s.body[0].stats_file().is_none());
        let s = parse_scene(
            &GOOD.replace(
                "density = 7850",
                "density = 7850\nsound = { grains = \"stone.grains\", gain = 0.5 }",
            ),
            "s.toml",
        )
        .unwrap();
        assert_eq!(s.body[1].grains_file(), Some(("stone.grains", 0.5)));
        let e = parse_scene(
            &GOOD.replace(
                "density = 7850",
                "density = 7850\nsound = { grains = \"stone.grains\", gain = -1 }",
            ),
            "s.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("sound.gain"), "{e}");
    }

    #[test]
    fn errors_name_the_line_and_the_field() {
        // A missing field: toml names it and the line.
        let e = parse_scene(&GOOD.replace("density = 7850\n", ""), "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("density") && e.contains("line"), "{e}");
        // A misspelt field.
        let e = parse_scene(&GOOD.replace("density = 7850", "densty = 7850"), "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("densty") && e.contains("line"), "{e}");
        // A value out of range: the body's line and the field.
        let e = parse_scene(&GOOD.replace("density = 7850", "density = -3"), "s.toml").unwrap_err();
        match &e {
            SceneFileError::Invalid { line, field, .. } => {
                assert_eq!(*line, 17, "{e}");
                assert_eq!(field, "body \"ball\".density");
            }
            other => panic!("{other:?}"),
        }
        // Wrong type and bad syntax.
        let e = parse_scene(
            &GOOD.replace("duration = 2.0", "duration = \"long\""),
            "s.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("duration") && e.contains("line 2"), "{e}");
        assert!(parse_scene("[[body]\nname=", "s.toml").is_err());
        let e = parse_scene(&GOOD.replace("sphere = 0.02", "sphere = 0"), "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("shape"), "{e}");
    }
}
