"""Tests of the resound Python package: conventions, physics, and agreement with the CLI."""

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import resound

REPO = Path(__file__).resolve().parents[3]
ASSETS = REPO / "assets"
PYIMPACT = REPO / "crates/resound-cli/tests/fixtures/pyimpact"
CLI = os.environ.get("RESOUND_BIN", str(REPO / "target/debug/resound"))


@pytest.fixture(autouse=True)
def own_library(tmp_path, monkeypatch):
    """Every test with its own (empty) material library; never the user's."""
    monkeypatch.setenv("RESOUND_LIBRARY", str(tmp_path / "library.sqlite"))
    monkeypatch.chdir(tmp_path)


def cli(*args, cwd):
    env = dict(os.environ)
    return subprocess.run([CLI, *args], cwd=cwd, env=env, capture_output=True, text=True)


def box(x=0.08, y=0.06, z=0.05):
    """A closed box surface centred at the origin: vertices (8, 3), triangles (12, 3)."""
    v = np.array([[sx * x / 2, sy * y / 2, sz * z / 2]
                  for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    idx = lambda sx, sy, sz: (sx > 0) * 4 + (sy > 0) * 2 + (sz > 0)
    t = []
    for axis in range(3):
        for s in (-1, 1):
            corners = []
            for a in (-1, 1):
                for b in (-1, 1):
                    c = [0, 0, 0]
                    c[axis] = s
                    o = [k for k in range(3) if k != axis]
                    c[o[0]], c[o[1]] = a, b
                    corners.append(idx(*c))
            p00, p01, p10, p11 = corners
            tri = [[p00, p10, p11], [p00, p11, p01]]
            # Outward: (p10 - p00) x (p11 - p00) along +axis * s.
            n = np.cross(v[p10] - v[p00], v[p11] - v[p00])
            if n[axis] * s < 0:
                tri = [[a, c, b] for a, b, c in tri]
            t += tri
    return v, np.array(t, dtype=np.uint32)


def decaying(freqs, dampings, amps, fs, n, seed=1, noise=1e-5):
    t = np.arange(n) / fs
    x = sum(a * np.exp(-d * t) * np.sin(2 * np.pi * f * t)
            for f, d, a in zip(freqs, dampings, amps))
    return x + noise * np.random.default_rng(seed).standard_normal(n)


def test_analyze_an_array_recovers_its_modes_and_follows_audio_conventions():
    fs = 44100
    x = np.concatenate([np.zeros(2000), decaying([440.0, 1234.0], [6.0, 25.0], [0.5, 0.3],
                                                 fs, fs)])
    m = resound.analyze(x.astype(np.float32), sample_rate=fs)
    assert isinstance(m, resound.Modes) and m.freq_hz.dtype == np.float64
    for f, d in [(440.0, 6.0), (1234.0, 25.0)]:
        k = np.argmin(abs(m.freq_hz - f))
        assert abs(m.freq_hz[k] - f) < 0.002 * f
        assert abs(m.damping_per_s[k] - d) < 0.1 * d
    assert m.report["sample_rate"] == fs and abs(m.report["onset_s"] - 2000 / fs) < 2e-3
    # (channels, samples) and (samples, channels) of one signal, and int16: the same modes.
    stereo = np.stack([x, x])
    for a in (stereo, stereo.T, (x * 20000).astype(np.int16)):
        m2 = resound.analyze(a, sample_rate=fs)
        assert np.allclose(m2.freq_hz[:2], m.freq_hz[:2], rtol=1e-4)
    # The modes render back to the signal they came from.
    y = resound.render_modes(m, duration_s=0.5, sample_rate=fs)
    assert y.dtype == np.float32 and y.shape == (fs // 2,)
    seg = x[2000 + int(round(m.report["onset_s"] * fs)) - 2000:][: fs // 2]
    assert np.corrcoef(seg[:len(y)], y[:len(seg)])[0, 1] > 0.95


def test_a_real_recording_analyses_the_same_from_its_file_its_array_and_the_cli(tmp_path):
    import wave

    wav = ASSETS / "recordings/steel_nut_M4_2.wav"
    with wave.open(str(wav)) as w:
        fs, n_ch = w.getframerate(), w.getnchannels()
        pcm = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").reshape(-1, n_ch)
    assert n_ch == 2
    for channel in (0, 1):
        from_file = resound.analyze(wav, channel=channel)
        # (samples, channels) int16 as the stdlib reads it: scaled by 1/32768 like the decoder.
        from_array = resound.analyze(pcm, sample_rate=fs, channel=channel)
        assert len(from_file) >= 5
        assert np.allclose(from_array.freq_hz, from_file.freq_hz, rtol=1e-9)
        assert np.allclose(from_array.damping_per_s, from_file.damping_per_s, rtol=1e-6)
        assert np.allclose(from_array.amplitude, from_file.amplitude, rtol=1e-6)
    left = resound.analyze(wav, channel=0)
    # The CLI writes the same document.
    out = cli("analyze", str(wav), "--channel", "0", "--json", "-", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    cli_f = np.array([m["freq_hz"] for m in doc["modes"]])
    assert np.allclose(cli_f, left.freq_hz, rtol=1e-9)
    assert doc["strike"] == left.report["strike"]
    assert doc["conditioning"] == left.report["conditioning"]


def test_errors_are_resound_errors_with_the_cli_message(tmp_path):
    with pytest.raises(resound.ResoundError) as e:
        resound.analyze("missing.wav")
    out = cli("analyze", "missing.wav", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr.strip() == f"error: {e.value}"
    with pytest.raises(resound.ResoundError, match="unobtainium"):
        resound.material("unobtainium")
    with pytest.raises(TypeError, match="sample_rate"):
        resound.analyze(np.zeros(100))
    with pytest.raises(resound.ResoundError, match="not finite"):
        resound.analyze(np.full(1000, np.nan), sample_rate=44100)
    v, t = box()
    with pytest.raises(resound.ResoundError, match="beyond"):
        resound.ModalModel.from_arrays(v, t + 8, modes=10)


@pytest.fixture(scope="module")
def model():
    v, t = box()
    return resound.ModalModel.from_arrays(v, t, modes=20)


def test_models_from_arrays_and_from_files_agree_and_scale_with_the_material(model, tmp_path):
    assert model.n_modes == 20 and model.eigenvalues.shape == (20,)
    assert np.all(np.diff(model.eigenvalues) >= 0)
    out = cli("mesh", "primitive", "box", "--size", "0.08,0.06,0.05", "-o", "box.obj", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    from_file = resound.ModalModel.from_file(tmp_path / "box.obj", modes=20)
    assert np.allclose(from_file.eigenvalues, model.eigenvalues, rtol=1e-6)
    # Saved and loaded: the same model.
    model.save(tmp_path / "box.rmodal")
    again = resound.ModalModel.from_file(tmp_path / "box.rmodal")
    assert np.array_equal(again.eigenvalues, model.eigenvalues)
    # f ∝ √γ: wood against metal.
    wood, metal = resound.material("wood"), resound.material("metal")
    ratio = model.frequencies_hz("wood") / model.frequencies_hz("metal")
    assert np.allclose(ratio, np.sqrt(wood.gamma / metal.gamma), rtol=1e-9)
    point, dist, gains = model.hit([0.04, 0.01, 0.01])
    assert abs(point[0] - 0.04) < 1e-9 and dist < 1e-9 and gains.shape == (20,)


def test_a_strike_sounds_at_the_models_frequencies_and_grows_with_speed(model):
    fs = 48000
    x1 = resound.render_strike("wood", model, [0.04, 0.013, 0.011], speed_m_s=1.0,
                               duration_s=0.5, sample_rate=fs, residual=False)
    x2 = resound.render_strike(resound.material("wood"), model, [0.04, 0.013, 0.011],
                               speed_m_s=2.0, duration_s=0.5, sample_rate=fs, residual=False)
    assert x1.dtype == np.float32 and x1.shape == (fs // 2,) and np.all(np.isfinite(x1))
    # Hertz impact: twice the speed is twice the impulse, and a shorter contact that reaches
    # this small box's modes (13.7 kHz and up) better: a little more than twice the level.
    rms = lambda x: np.sqrt(np.mean(x.astype(np.float64) ** 2))
    assert 2.0 < rms(x2) / rms(x1) < 3.0
    spectrum = np.abs(np.fft.rfft(x1 * np.hanning(len(x1))))
    peak_hz = np.argmax(spectrum) * fs / len(x1)
    f = model.frequencies_hz("wood")
    assert np.min(abs(f - peak_hz)) < 0.01 * peak_hz + 4


def test_estimating_a_material_from_its_own_strike_finds_it():
    # A 30 cm metal box: modes from about 5 kHz, ringing for seconds.
    v, t = box(0.3, 0.2, 0.1)
    big = resound.ModalModel.from_arrays(v, t, modes=20)
    hit = [0.15, 0.05, 0.03]
    fs = 44100
    truth = resound.material("metal")
    x = resound.render_strike(truth, big, hit, duration_s=1.0, sample_rate=fs, residual=False)
    rec = np.concatenate([np.zeros(4410, np.float32), x])
    est, report = resound.estimate_material(rec, big, hit, sample_rate=fs, name="found",
                                            residual=False)
    assert est.name == "found" and report["fit"]
    assert abs(est.gamma / truth.gamma - 1) < 0.02
    # Into the library and back.
    resound.save_material(est)
    assert resound.material("found").gamma == est.gamma
    with pytest.raises(resound.ResoundError, match="already has"):
        resound.save_material(est)
    assert "found" in [m.name for m in resound.materials()]


def test_pyimpact_tables_render_impacts_at_their_sampled_modes():
    stats = resound.ModeStatistics.load(next(PYIMPACT.glob("*.json")))
    ir = stats.sample(3)
    assert ir.shape == (stats.modes, 4)
    fs = 44100
    x = resound.render_impact(stats, seed=3, sample_rate=fs)
    assert x.dtype == np.float32 and x.shape == (fs,) and np.abs(x).max() > 0
    assert np.array_equal(x, resound.render_impact(stats, seed=3, sample_rate=fs))
    assert not np.array_equal(x, resound.render_impact(stats, seed=4, sample_rate=fs))
    spectrum = np.abs(np.fft.rfft(x))
    peak_hz = np.argmax(spectrum) * fs / len(x)
    # The loudest partial is one of the sampled IR's modes (each impact varies them slightly).
    assert np.min(abs(ir[:, 0] - peak_hz)) < 0.1 * peak_hz


def test_a_scene_renders_to_a_stereo_array_with_its_events(tmp_path):
    (tmp_path / "s.toml").write_text("""
duration = 0.6
[listener]
position = [0.0, 0.3, 0.5]
[[body]]
name = "table"
fixed = true
shape = { box = [0.6, 0.04, 0.4] }
material = "preset:wood"
density = 700
position = [0.0, -0.02, 0.0]
modes = 12
[[body]]
name = "ball"
shape = { sphere = 0.02 }
material = "preset:steel"
density = 7850
position = [0.0, 0.22, 0.0]
modes = 8
""")
    r = resound.render_scene(tmp_path / "s.toml")
    assert r.audio.dtype == np.float32 and r.audio.shape == (2, int(0.6 * r.sample_rate))
    first = r.events[0]
    assert first["kind"] == "impact"
    t = first["time_s"]
    assert abs(t - np.sqrt(2 * 0.2 / 9.81)) < 3e-3
    # Silent in free fall, sounding after the impact.
    k = int(t * r.sample_rate)
    assert np.abs(r.audio[:, : k - 200]).max() == 0
    assert np.abs(r.audio[:, k: k + 2000]).max() > 0.1
    assert r.summary["impacts"] >= 1


def test_batch_from_python_writes_what_the_cli_writes(tmp_path):
    v, t = box()
    lines = ["v %g %g %g" % tuple(p) for p in v] + ["f %d %d %d" % tuple(f + 1) for f in t]
    (tmp_path / "box.obj").write_text("\n".join(lines) + "\n")
    job = {"mesh": "box.obj", "material": "glass", "hits": [[0.04, 0.013, 0.011]],
           "speeds_m_s": [1, 2], "modes": 12, "duration_s": 0.2}
    (tmp_path / "jobs.jsonl").write_text(json.dumps(job) + "\n{broken\n")
    info = resound.batch(tmp_path / "jobs.jsonl", tmp_path / "py")
    assert info["rendered"] == 2 and [f["line"] for f in info["failures"]] == [2]
    out = cli("batch", "jobs.jsonl", "--out", "cli", cwd=tmp_path)
    assert out.returncode == 2 and "line 2" in out.stderr
    py_entries = (tmp_path / "py/manifest-0-of-1.jsonl").read_text()
    cli_entries = (tmp_path / "cli/manifest-0-of-1.jsonl").read_text()
    assert py_entries == cli_entries
    for e in map(json.loads, py_entries.splitlines()):
        f = e["files"][0]
        assert (tmp_path / "py" / f).read_bytes() == (tmp_path / "cli" / f).read_bytes()


def test_heavy_calls_release_the_gil():
    v, t = box(0.3, 0.2, 0.1)
    done = threading.Event()
    result = {}

    def solve():
        result["model"] = resound.ModalModel.from_arrays(v, t, modes=60)
        done.set()

    th = threading.Thread(target=solve)
    t0 = time.perf_counter()
    th.start()
    ticks = 0
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    th.join()
    elapsed = time.perf_counter() - t0
    assert result["model"].n_modes == 60
    # With the GIL held through the solve this loop could not run; released, it ticks about
    # once a millisecond (at least a tenth of that on a loaded machine).
    assert elapsed > 0.05, "the solve was too short to tell"
    assert ticks > 0.1 * elapsed / 0.001, (ticks, elapsed)


def test_the_ray_recipe_on_a_local_instance_with_two_workers_makes_the_unsharded_run(tmp_path):
    if os.environ.get("RESOUND_REQUIRE_RAY"):
        import ray  # noqa: F401  (test.sh installs it: a missing ray fails, never skips)
    else:
        pytest.importorskip("ray", reason="test.sh installs ray; `pip install ray` to run this")
    meshes = []
    # Shards follow a hash of the mesh path (and modes, scale, reference): these four names
    # give each of two shards two models.
    for k, size in zip([0, 1, 4, 6], [(0.08, 0.06, 0.05), (0.1, 0.05, 0.04), (0.12, 0.07, 0.03),
                                      (0.09, 0.09, 0.04)]):
        v, t = box(*size)
        lines = ["v %g %g %g" % tuple(p) for p in v] + ["f %d %d %d" % tuple(f + 1) for f in t]
        (tmp_path / f"m{k}.obj").write_text("\n".join(lines) + "\n")
        meshes.append((f"m{k}.obj", size))
    jobs = []
    for name, (x, y, z) in meshes:
        for mat in ("glass", "plastic"):
            jobs.append({"mesh": name, "material": mat, "modes": 12, "duration_s": 0.2,
                         "hits": [[x / 2, y / 5, z / 5], [x / 5, y / 2, z / 7]]})
    (tmp_path / "jobs.jsonl").write_text("\n".join(map(json.dumps, jobs)) + "\n")
    # Each Ray task solves with one thread; a solve's parallel sums round differently with
    # another thread count, so the reference runs single-threaded too (the CLI and the package
    # write the same bytes: test_batch_from_python_writes_what_the_cli_writes).
    ref = subprocess.run([CLI, "batch", "jobs.jsonl", "--out", "one", "--json"], cwd=tmp_path,
                         env={**os.environ, "RAYON_NUM_THREADS": "1"}, capture_output=True,
                         text=True)
    assert ref.returncode == 0, ref.stderr
    one = json.loads(ref.stdout)
    assert one["rendered"] == 16 and not one["failures"]
    script = REPO / "recipes/ray/batch_ray.py"
    run = subprocess.run([sys.executable, str(script), "jobs.jsonl", "ray-out", "--num-cpus", "2",
                          "--shards", "2"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    summary = json.loads(run.stdout.strip().splitlines()[-1])
    assert summary["shards"] == 2 and summary["rendered"] == 16 and summary["models_solved"] == 4

    def files(d):
        return {str(p.relative_to(d)): p.read_bytes() for p in d.glob("??/*")}

    assert files(tmp_path / "ray-out") == files(tmp_path / "one")
    entries = lambda d: sorted(l for m in d.glob("manifest-*.jsonl")
                               for l in m.read_text().splitlines())
    assert entries(tmp_path / "ray-out") == entries(tmp_path / "one")
    # Both workers had work: the two manifests are not empty.
    assert all(m.stat().st_size > 0 for m in (tmp_path / "ray-out").glob("manifest-*.jsonl"))
