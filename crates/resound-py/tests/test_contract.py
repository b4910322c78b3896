"""One contract for every front end: each library step's report reaches Python as the very
document the CLI's ``--json`` prints (both are the library's typed report), so the two must be
equal field for field — less wall-clock timings and the CLI's own ``output`` file name. (JSON
has no tuples: a fixed-size array, such as a point, is a list there and a tuple in Python.)"""

import json
import math
import os
import subprocess
import wave
from pathlib import Path

import numpy as np
import pytest

import resound
from shapes import SCENE_TOML, box

REPO = Path(__file__).resolve().parents[3]
ASSETS = REPO / "assets"
CLI = os.environ.get("RESOUND_BIN", str(REPO / "target/debug/resound"))

# Wall-clock figures: they differ between any two runs.
TIMINGS = {"elapsed_s", "load_ms", "build_s", "simulate_s", "physics_s", "audio_s",
           "realtime_factor", "peak_rss_mb", "transfer_fit_s", "residual_transfer_s",
           "fit_s", "solve_s", "assemble_s", "factor_s", "eigen_s", "sturm_s", "wall_s"}


@pytest.fixture(autouse=True)
def own_library(tmp_path, monkeypatch):
    monkeypatch.setenv("RESOUND_LIBRARY", str(tmp_path / "library.sqlite"))
    monkeypatch.chdir(tmp_path)


def cli_json(*args, cwd):
    out = subprocess.run([CLI, *args], cwd=cwd, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def differences(a, b, path="", drop=frozenset()):
    """Where two documents differ, as readable paths. Floats agree to 1e-6 relative: JSON
    prints an f32 figure in its shortest form, Python holds its exact f64 value."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k in TIMINGS or k in drop:
                continue
            if k not in a or k not in b:
                out.append(f"{path}.{k}: only in {'CLI' if k in a else 'Python'}")
            else:
                out += differences(a[k], b[k], f"{path}.{k}", drop)
        return out
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return [f"{path}: {len(a)} vs {len(b)} items"]
        return [d for k, (x, y) in enumerate(zip(a, b))
                for d in differences(x, y, f"{path}[{k}]", drop)]
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and \
                math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-300):
            return []
        return [f"{path}: {a!r} vs {b!r}"]
    return [] if a == b else [f"{path}: {a!r} vs {b!r}"]


def test_differences_finds_what_differs():
    # The comparison itself can fail: a changed value, a missing key, a list length.
    assert differences({"a": 1.0, "b": [1, 2]}, {"a": 1.0, "b": [1, 2]}) == []
    assert differences({"a": 1.0}, {"a": 1.1}) == [".a: 1.0 vs 1.1"]
    assert differences({"p": [1.0, 2.0]}, {"p": (1.0, 2.0)}) == []
    assert differences({"a": -7.655195}, {"a": -7.655195236206055}) == []
    assert differences({"a": 1}, {}) == [".a: only in CLI"]
    assert differences({"b": [1]}, {"b": [1, 2]}) == [".b: 1 vs 2 items"]
    assert differences({"elapsed_s": 1.0}, {"elapsed_s": 2.0}) == []


# A metal box large enough to ring within the audible band.
SIZE, HIT = (0.3, 0.2, 0.1), [0.15, 0.05, 0.03]


@pytest.fixture(scope="module")
def rmodal(tmp_path_factory):
    d = tmp_path_factory.mktemp("model")
    v, t = box(*SIZE)
    m = resound.ModalModel.from_arrays(v, t, modes=20)
    path = d / "box.rmodal"
    m.save(path)
    return path


def write_wav(path, x, fs):
    pcm = np.clip(np.round(x / np.abs(x).max() * 0.5 * 32767), -32768, 32767).astype("<i2")
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(fs)
        w.writeframes(pcm.tobytes())


def test_analyze_reports_are_one_document(tmp_path):
    wav = ASSETS / "recordings/steel_nut_M4_2.wav"
    doc = cli_json("analyze", str(wav), "--channel", "1", "--json", "-", cwd=tmp_path)
    rows, rep = resound._native.analyze_file(str(wav), 1)
    assert len(doc["modes"]) >= 5
    assert differences(doc, rep) == []
    # The public function's Modes carry that report (less the modes, which are the arrays).
    m = resound.analyze(wav, channel=1)
    assert "modes" not in m.report and differences(doc, m.report, drop={"modes"}) == []
    assert np.allclose([r["freq_hz"] for r in doc["modes"]], m.freq_hz, rtol=1e-12)


def test_a_high_pass_cut_off_is_the_clis(tmp_path):
    wav = ASSETS / "recordings/steel_nut_M4_2.wav"
    doc = cli_json("analyze", str(wav), "--highpass-hz", "100", "--json", "-", cwd=tmp_path)
    m = resound.analyze(wav, highpass_hz=100)
    assert differences(doc, m.report, drop={"modes"}) == []
    # The cut-off is the one asked for, and it changes what is found (the default chooses its own).
    assert m.report["conditioning"]["highpass_hz"] == 100.0
    auto = resound.analyze(wav)
    assert auto.report["conditioning"].get("highpass_hz") != 100.0
    assert len(m) != len(auto) or not np.allclose(m.freq_hz, auto.freq_hz)


def test_model_reports_are_one_document(tmp_path, rmodal):
    doc = cli_json("model", str(rmodal), "--hit", ",".join(map(str, HIT)), "--json",
                   cwd=tmp_path)
    rep = resound.ModalModel.from_file(rmodal).report(hit=HIT)
    assert len(doc["modes"]) == 20 and doc["hit"]
    assert differences(doc, rep) == []


def test_strike_reports_are_one_document(tmp_path, rmodal):
    doc = cli_json("synth", "--material", "metal", "--mesh", str(rmodal), "--hit",
                   ",".join(map(str, HIT)), "--velocity", "2", "--duration", "0.3",
                   "--sample-rate", "48000", "-o", "s.wav", "--json", cwd=tmp_path)
    model = resound.ModalModel.from_file(rmodal)
    x, info = resound.render_strike(resound.material("metal"), model, HIT,
                                    speed_m_s=2.0, duration_s=0.3, sample_rate=48000,
                                    return_info=True)
    assert doc["output"] == "s.wav" and doc["material"] == "metal"
    # The file is turned down where it would clip (gain_db says by how much); the array keeps
    # the physical level.
    assert differences(doc, info, drop={"output", "gain_db"}) == []
    assert info["gain_db"] == 0.0 and doc["gain_db"] <= 0.0
    assert math.isclose(float(np.abs(x).max()), doc["peak"], rel_tol=1e-6)


def test_estimate_reports_and_materials_are_one_document(tmp_path, rmodal):
    model = resound.ModalModel.from_file(rmodal)
    fs = 48000
    x = resound.render_strike("metal", model, HIT, duration_s=1.0, sample_rate=fs)
    x = np.concatenate([np.zeros(2400), x]) + 1e-6 * np.random.default_rng(1).standard_normal(
        2400 + len(x))
    write_wav(tmp_path / "rec.wav", x, fs)
    doc = cli_json("estimate", "rec.wav", "--mesh", str(rmodal), "--hit",
                   ",".join(map(str, HIT)), "--name", "found", "-o", "found.json", "--json",
                   cwd=tmp_path)
    est, rep = resound.estimate_material("rec.wav", model, HIT, name="found")
    assert rep["fit"] and differences(doc, rep) == []
    # The material file the CLI wrote is the Material Python returned, and reads back.
    written = json.loads((tmp_path / "found.json").read_text())
    assert differences(written, est.to_dict(), drop={"created"}) == []
    back = resound.Material.from_json((tmp_path / "found.json").read_text())
    assert back.gamma == est.gamma and back.name == "found"


def test_scene_summaries_are_one_document(tmp_path):
    (tmp_path / "s.toml").write_text(SCENE_TOML)
    doc = cli_json("scene", "s.toml", "-o", "s.wav", "--events", "ev.jsonl", "--no-cache",
                   "--json", cwd=tmp_path)
    r = resound.render_scene(tmp_path / "s.toml")
    assert doc["impacts"] >= 1
    assert differences(doc, r.summary, drop={"output"}) == []
    events = [json.loads(l) for l in (tmp_path / "ev.jsonl").read_text().splitlines()]
    assert differences(events, r.events) == []


def test_materials_are_values_not_strings(rmodal):
    steel = resound.material("preset:steel")
    assert isinstance(steel, resound.Material)
    assert steel == resound.Material.from_dict(steel.to_dict())
    assert steel != resound.material("preset:wood")
    # Listed origins are serde's names (what the CLI's JSON says), not Debug text.
    origins = {m.origin for m in resound.materials()}
    assert origins <= {"builtin", "library", "estimated", "legacy_table1", "preset"} and "builtin" in origins
    # One vocabulary: the presets a plain name reaches are listed too (issue 37).
    assert {"steel", "aluminium", "ceramic"} <= {m.name for m in resound.materials()}
    # A made-up material is checked as a material file is.
    with pytest.raises(resound.ResoundError, match="material"):
        resound.Material("bad", -1.0, 1e-7, 1e6, 1.0)
    m = resound.Material("mine", 2.0, 1e-7, 2e7, 1.0)
    assert m.to_dict()["gamma"] == 2e7 and resound.Material.from_json(m.to_json()) == m
    with pytest.raises(TypeError, match="a material is a Material"):
        resound.render_strike(3.5, resound.ModalModel.from_file(rmodal), HIT)


def test_a_parameter_out_of_range_is_named_as_each_front_end_names_it(tmp_path, rmodal):
    # One check in the library; the CLI names its flag, Python its keyword.
    out = subprocess.run([CLI, "synth", "--material", "metal", "--mesh", str(rmodal), "--hit",
                          ",".join(map(str, HIT)), "--velocity", "-1", "-o", "x.wav"],
                         cwd=tmp_path, capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.strip() == "error: --velocity: speed must be in [0, 1000) m/s, got -1"
    model = resound.ModalModel.from_file(rmodal)
    with pytest.raises(resound.ResoundError) as e:
        resound.render_strike("metal", model, HIT, speed_m_s=-1.0)
    assert str(e.value) == "speed_m_s: speed must be in [0, 1000) m/s, got -1"
    assert not (tmp_path / "x.wav").exists()
