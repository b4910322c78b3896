"""Resound: physically based contact sound.

Find the material behind a recorded strike, then make any object of that material sound right
when it is hit. Audio is float32 numpy arrays shaped ``(samples,)`` or ``(channels, samples)``
with a ``sample_rate`` keyword, as in soundfile, librosa and pedalboard; units are SI (m, s, Hz,
kg) and named in each keyword (``speed_m_s``, ``duration_s``). Heavy work releases the GIL, so
threads run in parallel. There is no global state: every function takes what it needs.

Errors raise :class:`ResoundError` with the message the ``resound`` command line prints.
Reports are the documents the command line's ``--json`` prints, as dicts: both come from the
same typed reports of the Rust library.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import GrainDictionary, Material, ModalModel, ModeStatistics, ResoundError

__all__ = [
    "Body",
    "GrainDictionary",
    "Material",
    "ModalModel",
    "ModeStatistics",
    "Modes",
    "ResoundError",
    "Scene",
    "SceneRender",
    "analyze",
    "analyze_joint",
    "analyze_grains",
    "batch",
    "estimate_material",
    "fit_stats",
    "import_pyimpact",
    "material",
    "materials",
    "render_impact",
    "render_modes",
    "render_scene",
    "render_scrape",
    "render_strike",
    "save_material",
]

__version__ = _native.version()

PathLike = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class Modes:
    """Damped sinusoids a·e^(−d·t)·sin(2πf·t + θ), sorted by frequency.

    Attributes:
        freq_hz: frequencies f, Hz.
        damping_per_s: decay rates d, 1/s (the envelope is e^(−d·t)).
        amplitude: peak amplitudes a at t = 0, full scale = 1.
        phase_rad: phases θ, rad.
        report: the analysis figures (the JSON of ``resound analyze --json``, without modes).
    """

    freq_hz: np.ndarray
    damping_per_s: np.ndarray
    amplitude: np.ndarray
    phase_rad: np.ndarray
    report: Dict[str, Any] = field(default_factory=dict, repr=False)

    @classmethod
    def from_array(cls, rows: np.ndarray, report: Optional[Dict[str, Any]] = None) -> "Modes":
        """Modes from an array shaped (n, 4): frequency, damping, amplitude, phase."""
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, 4)
        return cls(rows[:, 0].copy(), rows[:, 1].copy(), rows[:, 2].copy(), rows[:, 3].copy(),
                   report or {})

    def to_array(self) -> np.ndarray:
        """The modes as an array shaped (n, 4): frequency, damping, amplitude, phase."""
        return np.stack([self.freq_hz, self.damping_per_s, self.amplitude, self.phase_rad],
                        axis=1).astype(np.float64)

    def __len__(self) -> int:
        return len(self.freq_hz)


MaterialLike = Union[Material, str, "os.PathLike[str]"]


def _material_arg(m: MaterialLike) -> Union[Material, str]:
    if isinstance(m, Material):
        return m
    if isinstance(m, (str, os.PathLike)):
        return os.fspath(m)
    raise TypeError(f"a material is a Material, a library name, a file or 'preset:NAME', not {type(m).__name__}")


def _opt_path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _mono(audio: np.ndarray, channel: Optional[int]) -> np.ndarray:
    a = np.asarray(audio)
    if a.ndim == 1:
        if channel == 0:
            raise ResoundError("channel: channels count from 1 (1 is the first), not 0")
        if channel not in (None, 1):
            raise ResoundError(f"channel {channel} does not exist (1 channel; channels count from 1)")
        x = a
    elif a.ndim == 2:
        # (channels, samples), as soundfile.read(...).T and librosa give; a (samples, channels)
        # array with more rows than columns is taken as such.
        if a.shape[0] > a.shape[1]:
            a = a.T
        if channel is None:
            x = a.mean(axis=0)
        elif channel == 0:
            raise ResoundError("channel: channels count from 1 (1 is the first), not 0")
        elif 1 <= channel <= a.shape[0]:
            x = a[channel - 1]
        else:
            raise ResoundError(f"channel {channel} does not exist ({a.shape[0]} channels; channels count from 1)")
    else:
        raise ResoundError(f"audio must be shaped (samples,) or (channels, samples), got {a.shape}")
    if not np.issubdtype(x.dtype, np.number):
        raise TypeError(f"audio must be numeric, got {x.dtype}")
    if np.issubdtype(x.dtype, np.signedinteger):
        # PCM convention (soundfile, the decoders): full scale is 2^(bits−1).
        x = x / -float(np.iinfo(x.dtype).min)
    elif np.issubdtype(x.dtype, np.integer):
        raise TypeError(f"unsigned integer audio ({x.dtype}) is ambiguous; convert to float")
    return np.ascontiguousarray(x, dtype=np.float64)


def analyze(audio: Union[PathLike, np.ndarray], sample_rate: Optional[float] = None, *,
            channel: Optional[int] = None, strike: Optional[int] = None,
            resample_hz: Optional[int] = None, max_modes: int = 64,
            min_db: float = 60.0, highpass_hz: Optional[float] = None) -> Modes:
    """The damped sinusoids of a recorded strike (Ren 2013 §4).

    Args:
        audio: a file (WAV, FLAC, OGG Vorbis, MP3) or samples shaped (samples,) or
            (channels, samples), full scale = 1 (integer arrays are scaled).
        sample_rate: the samples' rate, Hz (arrays only).
        channel: which channel, counting from 1 like strikes (1 is the first; default: the mix).
        strike: which strike of several, from 1 (default: the loudest clean one).
        resample_hz: resample a file to this rate first.
        max_modes: most modes kept.
        min_db: keep modes within this many dB of the strongest.
        highpass_hz: a zero-phase high-pass cut-off applied first (default: one chosen from
            the rumble measured, as ``resound analyze`` does without ``--highpass-hz``).
    """
    if isinstance(audio, (str, os.PathLike)):
        if sample_rate is not None:
            raise TypeError("sample_rate is for arrays; a file knows its own")
        rows, rep = _native.analyze_file(os.fspath(audio), channel, strike, resample_hz,
                                         max_modes, min_db, highpass_hz)
    else:
        if sample_rate is None:
            raise TypeError("an array needs sample_rate=")
        if resample_hz is not None:
            raise TypeError("resample_hz is for files")
        rows, rep = _native.analyze_array(_mono(audio, channel), float(sample_rate), strike,
                                          max_modes, min_db, highpass_hz)
    rep.pop("modes", None)
    return Modes.from_array(rows, rep)


def analyze_joint(files: Sequence[PathLike], *, channel: Optional[int] = None,
                  strike: Optional[int] = None, every_channel: bool = False,
                  every_strike: bool = False, resample_hz: Optional[int] = None,
                  max_modes: int = 64, min_db: float = 60.0,
                  highpass_hz: Optional[float] = None
                  ) -> Tuple[List[Modes], Dict[str, Any]]:
    """One set of poles (f, d) shared by several takes of one object — files, and with
    ``every_channel`` / ``every_strike`` their channels and strikes — each take with its own
    amplitudes and phases (``resound analyze --joint``).

    Returns each take's modes (the shared f and d where that take hears them) and the joint
    report: the takes, and per pole σ (the larger of the joint Cramér–Rao bound and the
    takes' scatter), how many takes hear it, each take's own fit and ``disagree`` where the
    takes' fits stray beyond their σ.
    """
    if isinstance(files, (str, os.PathLike)):
        raise TypeError("files is a list of paths (one object's takes)")
    paths = [os.fspath(f) for f in files]
    if channel is not None and every_channel:
        raise TypeError("channel and every_channel exclude each other")
    if strike is not None and every_strike:
        raise TypeError("strike and every_strike exclude each other")
    rep = _native.analyze_joint(paths, channel, strike, every_channel, every_strike,
                                resample_hz, max_modes, min_db, highpass_hz)
    takes = []
    for k, t in enumerate(rep["takes"]):
        rows = [(m["freq_hz"], m["damping_per_s"], m["amplitude"][k], m["phase_rad"][k])
                for m in rep["modes"] if m["amplitude"][k] > 0]
        takes.append(Modes.from_array(np.array(rows, dtype=np.float64), dict(t)))
    return takes, rep


def material(spec: PathLike, *, library: Optional[PathLike] = None) -> Material:
    """A material by library name, file, built-in name or ``preset:NAME``."""
    return _native.get_material(os.fspath(spec), _opt_path(library))


def materials(*, library: Optional[PathLike] = None) -> List[Material]:
    """Every material: the library's, then the built-ins it does not replace."""
    return _native.list_materials(_opt_path(library))


def save_material(m: Material, *, library: Optional[PathLike] = None,
                  replace: bool = False) -> None:
    """Stores ``m`` in the library under its name (an existing entry only with ``replace``)."""
    if not isinstance(m, Material):
        raise TypeError(f"save_material takes a Material, not {type(m).__name__}")
    _native.save_material(m, _opt_path(library), replace)


def estimate_material(audio: Union[PathLike, np.ndarray], model: ModalModel,
                      hit: Sequence[float], *, sample_rate: Optional[float] = None,
                      channel: Optional[int] = None, strike: Optional[int] = None,
                      name: str = "estimated", residual: bool = True,
                      allow_implausible: bool = False,
                      mic: Optional[Sequence[float]] = None,
                      highpass_hz: Optional[float] = None) -> Tuple[Material, Dict[str, Any]]:
    """Estimates the material of ``model`` struck at ``hit`` (m) from a recording of it
    (Ren 2013 §5): the material and the fit report (paired modes, standard errors, warnings).
    ``mic``: where the microphone was (model coordinates, m); each mode is then weighted by
    what it radiates there (the model's acoustic transfer), as ``render_strike(mic=)`` does.
    ``highpass_hz``: the analysis' high-pass cut-off, as in ``analyze``. A fit that is not
    credible raises ``ResoundError`` unless ``allow_implausible``.
    """
    h = [float(c) for c in hit]
    m3 = None if mic is None else [float(c) for c in mic]
    if isinstance(audio, (str, os.PathLike)):
        if sample_rate is not None:
            raise TypeError("sample_rate is for arrays; a file knows its own")
        m, rep = _native.estimate_material(model, h, os.fspath(audio), None, None, channel,
                                           strike, name, residual, allow_implausible, m3,
                                           highpass_hz)
    else:
        if sample_rate is None:
            raise TypeError("an array needs sample_rate=")
        m, rep = _native.estimate_material(model, h, None, _mono(audio, channel),
                                           float(sample_rate), None, strike, name, residual,
                                           allow_implausible, m3, highpass_hz)
    return m, rep


def render_strike(material: MaterialLike, model: ModalModel, hit: Sequence[float], *,
                  speed_m_s: float = 1.0, duration_s: float = 1.0, sample_rate: int = 48000,
                  residual: bool = True, impactor_mass_kg: Optional[float] = None,
                  impactor_radius_m: float = 0.005,
                  library: Optional[PathLike] = None,
                  mic: Optional[Sequence[float]] = None,
                  return_info: bool = False
                  ) -> Union[np.ndarray, Tuple[np.ndarray, Dict[str, Any]]]:
    """One strike of an object (``model``) of ``material`` at ``hit`` (m) by a steel sphere at
    ``speed_m_s``: float32 samples at physical scale (1 m away; not normalized). ``mic``:
    a microphone (model coordinates, m) that hears each mode as it radiates there (the model's
    acoustic transfer, fitted on the spot when it holds none). With ``return_info``, also the
    strike's report (contact time, force, modes kept, peak, warnings: what ``resound synth
    --json`` prints, less the output file)."""
    x, info = _native.render_strike(_material_arg(material), model,
                                    [float(c) for c in hit], speed_m_s, duration_s,
                                    sample_rate, residual, impactor_mass_kg,
                                    impactor_radius_m, _opt_path(library),
                                    None if mic is None else [float(c) for c in mic])
    return (x, info) if return_info else x


def _mode_rows(modes: Any) -> np.ndarray:
    """Modes as a contiguous (n, 4) float64 array, or a TypeError/ValueError that says what a
    mode array is (never a numpy reshape error)."""
    if isinstance(modes, Modes):
        return np.ascontiguousarray(modes.to_array())
    what = ("modes are Modes or an array shaped (n, 4): freq_hz, damping_per_s, amplitude, "
            "phase_rad")
    if modes is None or isinstance(modes, (str, bytes)):
        raise TypeError(f"{what}; got {type(modes).__name__}")
    try:
        rows = np.asarray(modes, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{what}; got {type(modes).__name__} ({e})") from None
    if rows.ndim == 2 and rows.shape[1] == 4 or rows.ndim == 1 and rows.size == 4:
        return np.ascontiguousarray(rows.reshape(-1, 4))
    raise ValueError(f"{what}; got an array shaped {rows.shape}")


def render_modes(modes: Union[Modes, np.ndarray], *, duration_s: float = 1.0,
                 sample_rate: int = 48000) -> np.ndarray:
    """Analysed modes rendered as recorded (phases included): float32 samples."""
    return _native.render_modes(_mode_rows(modes), duration_s,
                                sample_rate)


def render_impact(stats: ModeStatistics, *, seed: int = 0, speed_m_s: float = 1.0,
                  duration_s: float = 1.0, sample_rate: int = 44100, residual: bool = False,
                  impactor_mass_kg: Optional[float] = None,
                  impactor_radius_m: float = 0.005) -> np.ndarray:
    """One impact of an object drawn from mode statistics (Traer 2019; PyImpact tables load
    with :meth:`ModeStatistics.load`): the object's IR with ``seed``, this impact's variation
    with ``seed + 1``. Float32 samples."""
    return _native.render_impact(stats, seed, speed_m_s, duration_s, sample_rate, residual,
                                 impactor_mass_kg, impactor_radius_m)


def _vec3(v: Optional[Sequence[float]]) -> Optional[List[float]]:
    if v is None:
        return None
    out = [float(c) for c in v]
    if len(out) != 3:
        raise TypeError(f"a 3-vector has 3 components, got {len(out)}")
    return out


@dataclass
class Body:
    """One body of a :class:`Scene` (the ``[[body]]`` table of a scene file).

    Args:
        name: unique name.
        shape: ``{"box": [x, y, z]}``, ``{"plate": [x, y, thickness]}`` (full sizes, m),
            ``{"sphere": r}``, ``{"cylinder": [r, height]}``, ``{"bowl": [r, thickness]}`` or
            ``{"mesh": "file.obj"}``.
        material: a library name, ``preset:NAME``, a material file, or a :class:`Material`.
        density_kg_m3: density, kg/m³.
        fixed: immovable (a floor, a table); it still sounds.
        position_m, rotation_deg, velocity_m_s, angular_velocity_rad_s: the start state
            (y is up; the rotation is a rotation vector, axis × angle in degrees).
        restitution, friction: contact coefficients.
        modes: modes of its modal model.
        sound: ``True`` (its modal model), ``False`` (silent), a :class:`ModeStatistics` file
            path as ``{"stats": path}`` or ``{"grains": path, "gain": 1.0}``.
        extra: any other scene-file field (``surface``, ``roughness``, ``scale``, ``poisson``,
            ``resolution``, ``surface_spacing``).

    Fields left ``None`` take the scene file's defaults.
    """

    name: str
    shape: Dict[str, Any]
    material: MaterialLike
    density_kg_m3: float
    fixed: Optional[bool] = None
    position_m: Optional[Sequence[float]] = None
    rotation_deg: Optional[Sequence[float]] = None
    velocity_m_s: Optional[Sequence[float]] = None
    angular_velocity_rad_s: Optional[Sequence[float]] = None
    restitution: Optional[float] = None
    friction: Optional[float] = None
    modes: Optional[int] = None
    sound: Optional[Union[bool, Dict[str, Any]]] = None
    extra: Dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> Dict[str, Any]:
        """The body as a scene file's table (a :class:`Material` inline, as its document)."""
        m = _material_arg(self.material)
        d: Dict[str, Any] = {
            "name": self.name,
            "shape": dict(self.shape),
            "material": m.to_dict() if isinstance(m, Material) else m,
            "density": float(self.density_kg_m3),
        }
        opt = {
            "fixed": self.fixed,
            "position": _vec3(self.position_m),
            "rotation": _vec3(self.rotation_deg),
            "velocity": _vec3(self.velocity_m_s),
            "angular_velocity": _vec3(self.angular_velocity_rad_s),
            "restitution": self.restitution,
            "friction": self.friction,
            "modes": self.modes,
            "sound": self.sound,
        }
        d.update({k: v for k, v in opt.items() if v is not None})
        for k, v in self.extra.items():
            if k in d:
                raise TypeError(f"body {self.name!r}: extra field {k!r} is a named argument")
            d[k] = v
        return d


@dataclass
class Scene:
    """A scene built in code: what a scene file (TOML) holds. Render it with
    :func:`render_scene`; ``to_dict()`` gives the scene file's fields."""

    bodies: List[Body] = field(default_factory=list)
    duration_s: Optional[float] = None
    sample_rate: Optional[int] = None
    seed: Optional[int] = None
    stereo: Optional[bool] = None
    steps_per_second: Optional[float] = None
    gravity_m_s2: Optional[Sequence[float]] = None
    listener_m: Optional[Sequence[float]] = None

    def add(self, body: Body) -> "Scene":
        """Appends ``body``; returns the scene (for chaining)."""
        self.bodies.append(body)
        return self

    def to_dict(self) -> Dict[str, Any]:
        """The scene file's fields (materials given as :class:`Material` inline)."""
        d: Dict[str, Any] = {}
        opt = {
            "duration": self.duration_s,
            "sample_rate": self.sample_rate,
            "seed": self.seed,
            "stereo": self.stereo,
            "steps_per_second": self.steps_per_second,
            "gravity": _vec3(self.gravity_m_s2),
        }
        d.update({k: v for k, v in opt.items() if v is not None})
        if self.listener_m is not None:
            d["listener"] = {"position": _vec3(self.listener_m)}
        d["body"] = [b.to_dict() for b in self.bodies]
        return d


@dataclass(frozen=True)
class SceneRender:
    """A rendered scene: ``audio`` float32 (channels, samples) at ``sample_rate`` Hz, the
    contact ``events`` (time, bodies, kind, force, …) and the ``summary`` figures."""

    audio: np.ndarray
    sample_rate: int
    events: List[Dict[str, Any]]
    summary: Dict[str, Any]


def render_scene(scene: Union[PathLike, Scene, Dict[str, Any]], *,
                 base_dir: Optional[PathLike] = None, library: Optional[PathLike] = None,
                 keep_level: bool = False) -> SceneRender:
    """Simulates and renders a scene, as ``resound scene``: a scene file (TOML: bodies,
    materials, listener), a :class:`Scene` built in code, or a dict of the scene file's fields.
    Relative paths in a built scene (meshes, statistics, grains) are taken from ``base_dir``
    (default: the working directory). ``keep_level`` keeps the physical level (else
    peak-normalized)."""
    if isinstance(scene, (str, os.PathLike)):
        if base_dir is not None:
            raise TypeError("base_dir is for scenes built in code; a file's paths are its own")
        audio, fs, events, summary = _native.render_scene(os.fspath(scene), _opt_path(library),
                                                          keep_level)
        return SceneRender(audio, fs, events, summary)
    base = os.fspath(base_dir) if base_dir is not None else os.getcwd()
    if isinstance(scene, Scene):
        doc = scene.to_dict()
    elif isinstance(scene, dict):
        doc = scene
    else:
        raise TypeError(f"a scene is a file, a Scene or a dict, not {type(scene).__name__}")
    audio, fs, events, summary = _native.render_scene_dict(doc, base, _opt_path(library),
                                                           keep_level)
    return SceneRender(audio, fs, events, summary)


def render_scrape(modes: Union[Modes, np.ndarray], *, speed_m_s: Optional[float] = None,
                  trajectory: Optional[np.ndarray] = None, duration_s: float = 2.0,
                  surface: Union[str, PathLike] = "fractal", roughness_m: float = 5e-6,
                  surface_spacing_m: float = 1e-5, probe_mass_kg: float = 0.01,
                  friction: float = 100.0, gamma: float = 1.0, tip_width_m: float = 2e-4,
                  irs: int = 8, seed: int = 1, sample_rate: int = 48000
                  ) -> Tuple[np.ndarray, float]:
    """A probe scraped over a surface texture on an object (Traer 2019 §4, eq. 8–9), as
    ``resound scrape``: float32 samples at their physical level (turned down only where they
    would clip, with a :class:`UserWarning` saying by how much; an inaudible render warns too)
    and the length scraped, m.

    Args:
        modes: the object's modes per unit impulse — :meth:`ModalModel.modes`,
            :meth:`ModeStatistics.sample`, or analysed :class:`Modes`.
        speed_m_s: a constant scraping speed, m/s; or
        trajectory: (n, 2) points of time s and position along the surface m.
        surface: ``"fractal"`` (a 1/f² Brownian profile of RMS ``roughness_m``) or a height
            profile (``.npy``, m, sampled every ``surface_spacing_m``; quilted to length).
        probe_mass_kg, friction, gamma: eq. 8's probe mass, shear friction A and exponent γ.
        tip_width_m: the probe tip's width (a spatial low-pass of the texture), m.
        irs: location-dependent impulse responses along the path (eq. 9), 1–256.
        seed: surface, quilting and IR variation.
    """
    rows = _mode_rows(modes)
    traj = None if trajectory is None else np.ascontiguousarray(trajectory, dtype=np.float64)
    x, length_m, info = _native.render_scrape(
        rows, speed_m_s, traj, duration_s,
        os.fspath(surface), roughness_m, surface_spacing_m, probe_mass_kg, friction, gamma,
        tip_width_m, irs, seed, sample_rate)
    for w in info["warnings"]:
        warnings.warn(w["message"], UserWarning, stacklevel=2)
    if info["gain_db"] < 0:
        warnings.warn(f"peak {info['peak']:.2f} of full scale; turned down by "
                      f"{-info['gain_db']:.1f} dB (no clipping)", UserWarning, stacklevel=2)
    return x, length_m


def analyze_grains(recordings: Sequence[Union[PathLike, Tuple[str, np.ndarray]]],
                   output: PathLike, *, sample_rate: Optional[float] = None,
                   kind: str = "auto", min_db: float = -50.0, peaks: Optional[int] = None,
                   min_corr: float = 0.5, prune: Optional[float] = None
                   ) -> Tuple[GrainDictionary, Dict[str, Any]]:
    """Cuts recordings of non-modal contact (rolling, rattling, crumbling) into grains and
    correlation patterns (Picard 2009), as ``resound grains analyze``; saves the dictionary
    to ``output`` and returns it with its figures.

    Args:
        recordings: files (WAV, FLAC, OGG, MP3; a ``"rolling:"`` prefix sets the kind), or
            ``(name, samples)`` pairs of mono audio at ``sample_rate`` (all one or the other).
        sample_rate: the arrays' rate, Hz; for files, the analysis rate (default: the first
            file's).
        kind: ``auto`` (from the name, else the envelope), ``impact``, ``rolling``,
            ``sliding`` or ``continuous``.
        min_db: drop grains this far below the loudest of their part, dB.
        peaks: pattern peaks kept per recording part (default: automatic).
        min_corr: smallest correlation a pattern peak may have.
        prune: drop grains that another can stand in for at this correlation (0–1).
    """
    pairs = [r for r in recordings if isinstance(r, tuple)]
    if pairs and len(pairs) != len(recordings):
        raise TypeError("recordings are all files or all (name, samples) pairs")
    if pairs:
        if sample_rate is None:
            raise TypeError("arrays need sample_rate=")
        names = [str(n) for n, _ in pairs]
        arrays = [np.ascontiguousarray(_mono(a, None), dtype=np.float32) for _, a in pairs]
        rep = _native.grains_analyze(names, os.fspath(output), arrays, float(sample_rate), kind,
                                     None, min_db, peaks, min_corr, prune)
    else:
        rep = _native.grains_analyze([os.fspath(r) for r in recordings], os.fspath(output),
                                     None, sample_rate, kind, None, min_db, peaks, min_corr,
                                     prune)
    return GrainDictionary.load(os.fspath(output)), rep


def fit_stats(recordings: Sequence[PathLike], material: str, *, modes: int = 15,
              highpass_hz: Optional[float] = None) -> ModeStatistics:
    """Fits per-material mode statistics (Traer 2019) to recordings of strikes of objects of
    one material, as ``resound stats fit``; save them with :meth:`ModeStatistics.save`."""
    return ModeStatistics.fit([os.fspath(r) for r in recordings], material, modes, highpass_hz)


def import_pyimpact(directory: PathLike) -> Dict[str, ModeStatistics]:
    """Every PyImpact material table (``<material>_<size>_mm.json``) in ``directory``, by
    name (``<material>_<size>``), as ``resound stats import-pyimpact``."""
    return dict(ModeStatistics.import_pyimpact(os.fspath(directory)))


def batch(jobs: PathLike, out: PathLike, *, shard: Tuple[int, int] = (0, 1),
          library: Optional[PathLike] = None, cache: Optional[PathLike] = None) -> Dict[str, Any]:
    """Runs shard ``shard = (i, n)`` of a jobs file, as ``resound batch`` (content-addressed
    outputs, a per-shard manifest, resumable). Returns the run's figures; failed job lines are
    listed in ``failures`` rather than raised."""
    i, n = shard
    return _native.batch(os.fspath(jobs), os.fspath(out), int(i), int(n),
                         _opt_path(library), _opt_path(cache))
