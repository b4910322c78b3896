"""Type stubs of the native module (Rust, pyo3). Use the functions of :mod:`resound`; the
classes are public there. Reports are dicts: the documents the CLI's ``--json`` prints."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__all__ = ["ResoundError", "Material", "ModalModel", "ModeStatistics", "GrainDictionary", "analyze_file",
           "analyze_array", "analyze_joint", "get_material", "list_materials", "save_material",
           "estimate_material", "render_strike", "render_modes", "render_impact",
           "render_scene", "batch", "render_scrape", "grains_analyze", "render_scene_dict",
           "version"]

_Path = Union[str, PathLike[str]]
_Report = Dict[str, Any]

class ResoundError(Exception):
    """A Resound operation failed; the message is the CLI's."""

@final
class Material:
    """A sounding material (Ren 2013 §5): Rayleigh α (1/s), β (s), γ = E/ρ (m²/s²), σ, and
    what its document carries (damping model, residual, provenance). Equal when the documents
    are."""

    def __new__(cls, name: str, alpha: float, beta: float, gamma: float,
                sigma: float) -> "Material": ...
    @staticmethod
    def load(spec: _Path, library: Optional[_Path] = None) -> "Material":
        """A material by library name, file, built-in name or ``preset:NAME``."""
    @staticmethod
    def from_dict(doc: Dict[str, Any]) -> "Material":
        """A material from its document (checked)."""
    @staticmethod
    def from_json(text: str) -> "Material":
        """A material from its JSON document (checked)."""
    def to_dict(self) -> Dict[str, Any]:
        """The material's document."""
    def to_json(self) -> str:
        """The material's JSON document (what ``resound materials export`` writes)."""
    @property
    def name(self) -> str: ...
    @property
    def alpha(self) -> float: ...
    @property
    def beta(self) -> float: ...
    @property
    def gamma(self) -> float: ...
    @property
    def sigma(self) -> float: ...
    @property
    def origin(self) -> str:
        """``builtin``, ``library``, ``estimated``, … as listed; ``document`` otherwise."""
    @property
    def provenance(self) -> Optional[Dict[str, Any]]: ...

_MaterialArg = Union[Material, str]

@final
class ModalModel:
    """A modal model: frequencies and surface mode shapes of an object (Ren 2013 §3)."""

    @staticmethod
    def from_file(path: _Path, scale: float = 1.0, modes: int = 60,
                  reference_material: str = "ceramic") -> "ModalModel":
        """Solves a mesh file (OBJ, STL, PLY, .msh, .node/.ele, .mesh; coordinates × ``scale``
        in m) for ``modes`` elastic modes with ``reference_material`` (preset or "E,nu,rho"),
        or loads a ``.rmodal``."""
    @staticmethod
    def from_arrays(vertices: npt.NDArray[np.float64], triangles: npt.NDArray[np.uint32],
                    scale: float = 1.0, modes: int = 60,
                    reference_material: str = "ceramic") -> "ModalModel":
        """Solves a closed surface: ``vertices`` (n, 3) in m before ``scale``, ``triangles``
        (m, 3) vertex indices."""
    def report(self, hit: Optional[Sequence[float]] = None) -> _Report:
        """The model's figures and modes (gains at ``hit``): ``resound model --json``."""
    def save(self, path: _Path) -> None:
        """Writes a ``.rmodal`` file (atomically)."""
    @property
    def n_modes(self) -> int: ...
    @property
    def eigenvalues(self) -> npt.NDArray[np.float64]:
        """λ = ω² for the reference material, rad²/s²."""
    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """Surface vertices, m, (n, 3)."""
    @property
    def triangles(self) -> npt.NDArray[np.uint32]:
        """Surface triangles, (m, 3)."""
    @property
    def reference_material(self) -> Dict[str, Any]:
        """The solve's material (youngs_modulus Pa, poisson_ratio, density kg/m³)."""
    def frequencies_hz(self, material: Optional[_MaterialArg] = None,
                       library: Optional[_Path] = None) -> npt.NDArray[np.float64]:
        """Undamped frequencies for ``material`` (a Material or a reference; default: the
        reference material), Hz."""
    def hit(self, point: Sequence[float]) -> Tuple[Tuple[float, float, float], float,
                                                   npt.NDArray[np.float64]]:
        """Snaps ``point`` (m) to the surface: (surface point m, distance m, each mode's gain
        there in m per N·s)."""
    def modes(self, material: _MaterialArg, point: Sequence[float], max_freq_hz: float = 24000.0,
              library: Optional[_Path] = None) -> npt.NDArray[np.float64]:
        """The damped modes of an object of ``material`` struck at ``point`` (m), per unit
        impulse: (n, 4) — Hz, 1/s, amplitude, rad."""

@final
class ModeStatistics:
    """Per-material mode statistics (Traer 2019)."""

    @staticmethod
    def load(path: _Path) -> "ModeStatistics":
        """A Resound statistics file or a PyImpact material table (JSON)."""
    @staticmethod
    def from_pyimpact_json(material: str, text: str) -> "ModeStatistics":
        """A PyImpact material table given as JSON text."""
    @property
    def name(self) -> str: ...
    @property
    def modes(self) -> int:
        """Modes per sampled impulse response."""
    def sample(self, seed: int) -> npt.NDArray[np.float64]:
        """An impulse response drawn with ``seed``: modes (n, 4) — Hz, 1/s, amplitude, rad."""
    def to_json(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def save(self, path: _Path) -> None:
        """Writes a statistics file (atomically)."""
    @staticmethod
    def fit(recordings: List[_Path], material: str, modes: int = 15,
            highpass_hz: Optional[float] = None) -> "ModeStatistics":
        """Fits statistics to recordings of strikes of one material (Traer 2019)."""
    @staticmethod
    def import_pyimpact(dir: _Path) -> List[Tuple[str, "ModeStatistics"]]:
        """Every PyImpact table in ``dir``, by name."""

@final
class GrainDictionary:
    """A grain dictionary (Picard 2009)."""

    @staticmethod
    def load(path: _Path) -> "GrainDictionary":
        """Reads a ``.grains`` file."""
    @property
    def sample_rate(self) -> float:
        """Sample rate of the grains, Hz."""
    @property
    def recordings(self) -> List[Tuple[str, str, int]]:
        """The recordings: (name, contact kind, samples)."""
    def summary(self) -> _Report:
        """The dictionary's figures."""
    def resynthesize(self, recording: Union[int, str], time_scale: float = 1.0, variation: float = 0.0,
                     seed: int = 1) -> npt.NDArray[np.float32]:
        """Rebuilds a recording (index or name), time-scaled and varied: float32 samples at
        the dictionary's rate and the recording's level."""

def analyze_file(path: _Path, channel: Optional[int] = None, strike: Optional[int] = None,
                 resample_hz: Optional[int] = None, max_modes: int = 64,
                 min_db: float = 60.0, highpass_hz: Optional[float] = None
                 ) -> Tuple[npt.NDArray[np.float64], _Report]: ...
def analyze_array(samples: npt.NDArray[np.float64], sample_rate: float,
                  strike: Optional[int] = None, max_modes: int = 64,
                  min_db: float = 60.0, highpass_hz: Optional[float] = None
                  ) -> Tuple[npt.NDArray[np.float64], _Report]: ...
def analyze_joint(paths: Sequence[_Path], channel: Optional[int] = None,
                  strike: Optional[int] = None, every_channel: bool = False,
                  every_strike: bool = False, resample_hz: Optional[int] = None,
                  max_modes: int = 64, min_db: float = 60.0,
                  highpass_hz: Optional[float] = None) -> _Report: ...
def get_material(spec: _Path, library: Optional[_Path] = None) -> Material: ...
def list_materials(library: Optional[_Path] = None) -> List[Material]: ...
def save_material(material: Material, library: Optional[_Path] = None,
                  replace: bool = False) -> None: ...
def estimate_material(model: ModalModel, hit: Sequence[float], path: Optional[_Path] = None,
                      samples: Optional[npt.NDArray[np.float64]] = None,
                      sample_rate: Optional[float] = None, channel: Optional[int] = None,
                      strike: Optional[int] = None, name: str = "estimated",
                      residual: bool = True,
                      allow_implausible: bool = False,
                      mic: Optional[Sequence[float]] = None,
                      highpass_hz: Optional[float] = None) -> Tuple[Material, _Report]: ...
def render_strike(material: _MaterialArg, model: ModalModel, hit: Sequence[float],
                  speed_m_s: float = 1.0, duration_s: float = 1.0, sample_rate: int = 48000,
                  residual: bool = True, impactor_mass_kg: Optional[float] = None,
                  impactor_radius_m: float = 0.005,
                  library: Optional[_Path] = None,
                  mic: Optional[Sequence[float]] = None) -> Tuple[npt.NDArray[np.float32], _Report]: ...
def render_modes(modes: npt.NDArray[np.float64], duration_s: float = 1.0,
                 sample_rate: int = 48000) -> npt.NDArray[np.float32]: ...
def render_impact(stats: ModeStatistics, seed: int = 0, speed_m_s: float = 1.0,
                  duration_s: float = 1.0, sample_rate: int = 44100, residual: bool = False,
                  impactor_mass_kg: Optional[float] = None,
                  impactor_radius_m: float = 0.005) -> npt.NDArray[np.float32]: ...
def render_scene(path: _Path, library: Optional[_Path] = None, keep_level: bool = False
                 ) -> Tuple[npt.NDArray[np.float32], int, List[_Report], _Report]: ...
def render_scene_dict(scene: Dict[str, Any], base_dir: _Path, library: Optional[_Path] = None,
                      keep_level: bool = False
                      ) -> Tuple[npt.NDArray[np.float32], int, List[_Report], _Report]: ...
def render_scrape(modes: npt.NDArray[np.float64], speed_m_s: Optional[float] = None,
                  trajectory: Optional[npt.NDArray[np.float64]] = None,
                  duration_s: float = 2.0, surface: str = "fractal",
                  roughness_m: float = 5e-6, surface_spacing_m: float = 1e-5,
                  probe_mass_kg: float = 0.01, friction: float = 100.0, gamma: float = 1.0,
                  tip_width_m: float = 2e-4, irs: int = 8, seed: int = 1,
                  sample_rate: int = 48000
                  ) -> Tuple[npt.NDArray[np.float32], float, Dict[str, Any]]: ...
def grains_analyze(recordings: List[str], output: _Path,
                   arrays: Optional[List[npt.NDArray[np.float32]]] = None,
                   sample_rate: Optional[float] = None, kind: str = "auto",
                   kinds: Optional[List[str]] = None, min_db: float = -50.0,
                   peaks: Optional[int] = None, min_corr: float = 0.5,
                   prune: Optional[float] = None) -> _Report: ...
def batch(jobs: _Path, out: _Path, shard: int = 0, shards: int = 1,
          library: Optional[_Path] = None, cache: Optional[_Path] = None) -> _Report: ...
def version() -> str: ...
