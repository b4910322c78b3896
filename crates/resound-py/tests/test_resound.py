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
from shapes import SCENE_TOML, box

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
    for channel in (1, 2):
        from_file = resound.analyze(wav, channel=channel)
        # (samples, channels) int16 as the stdlib reads it: scaled by 1/32768 like the decoder.
        from_array = resound.analyze(pcm, sample_rate=fs, channel=channel)
        assert len(from_file) >= 5
        assert np.allclose(from_array.freq_hz, from_file.freq_hz, rtol=1e-9)
        assert np.allclose(from_array.damping_per_s, from_file.damping_per_s, rtol=1e-6)
        assert np.allclose(from_array.amplitude, from_file.amplitude, rtol=1e-6)
    left = resound.analyze(wav, channel=1)
    # Channels count from 1, like strikes, for files and arrays alike (issue 37).
    for audio, kw in ((wav, {}), (pcm, {"sample_rate": fs})):
        with pytest.raises(resound.ResoundError, match="count from 1"):
            resound.analyze(audio, channel=0, **kw)
        with pytest.raises(resound.ResoundError, match="count from 1"):
            resound.analyze(audio, strike=0, **kw)
    # The CLI writes the same document (channels count from 1 in both, like strikes).
    out = cli("analyze", str(wav), "--channel", "1", "--json", "-", cwd=tmp_path)
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


def test_a_strike_heard_at_a_microphone_is_estimated_with_it():
    # The metal box again, heard 40 cm off its side: radiation is part of both forward models.
    v, t = box(0.3, 0.2, 0.1)
    big = resound.ModalModel.from_arrays(v, t, modes=20)
    hit, mic, fs = [0.15, 0.05, 0.03], [0.1, 0.4, 0.3], 44100
    truth = resound.material("metal")
    plain = resound.render_strike(truth, big, hit, duration_s=1.0, sample_rate=fs,
                                  residual=False)
    x = resound.render_strike(truth, big, hit, duration_s=1.0, sample_rate=fs, residual=False,
                              mic=mic)
    # Same length, other levels: the modes radiate unlike each other.
    assert x.shape == plain.shape and not np.allclose(x / np.max(abs(x)),
                                                      plain / np.max(abs(plain)), atol=1e-3)
    est, report = resound.estimate_material(x, big, hit, sample_rate=fs, residual=False,
                                            mic=mic)
    assert list(report["mic"]) == mic and report["passes"] >= 1
    assert abs(est.gamma / truth.gamma - 1) < 0.02
    with pytest.raises(resound.ResoundError, match="not finite"):
        resound.render_strike(truth, big, hit, duration_s=0.1, mic=[float("nan"), 0, 0])


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




def scene_in_code(ball_material="preset:steel"):
    return resound.Scene(duration_s=0.6, seed=3, listener_m=(0, 0.3, 0.5)).add(
        resound.Body("table", {"box": [0.6, 0.04, 0.4]}, "preset:wood", 700, fixed=True,
                     position_m=(0, -0.02, 0), modes=12)).add(
        resound.Body("ball", {"sphere": 0.02}, ball_material, 7850, position_m=(0, 0.22, 0),
                     velocity_m_s=(0.3, 0, 0), modes=8))


def test_a_scene_built_in_code_renders_as_its_scene_file(tmp_path):
    (tmp_path / "s.toml").write_text(SCENE_TOML)
    from_file = resound.render_scene(tmp_path / "s.toml", keep_level=True)
    built = resound.render_scene(scene_in_code(), keep_level=True)
    assert np.array_equal(built.audio, from_file.audio)
    assert built.events == from_file.events and built.events[0]["kind"] == "impact"
    as_dict = resound.render_scene(scene_in_code().to_dict(), keep_level=True)
    assert np.array_equal(as_dict.audio, from_file.audio)
    # A Material object in a built scene: steel's document sounds as preset:steel does.
    steel = resound.material("preset:steel")
    with_doc = resound.render_scene(scene_in_code(steel), keep_level=True)
    assert np.array_equal(with_doc.audio, from_file.audio)
    # A built scene's errors name the field, as a file's do.
    bad = scene_in_code()
    bad.bodies[1].density_kg_m3 = -1
    with pytest.raises(resound.ResoundError, match="density"):
        resound.render_scene(bad)
    with pytest.raises(resound.ResoundError, match="unknown field"):
        resound.render_scene({**scene_in_code().to_dict(), "durration": 1})


def test_a_radiating_scene_names_bodies_whose_radiation_is_uncertain():
    # A thin plate's bending modes defeat the transfer fit: a note names it, not the ball.
    scene = {"duration": 0.3, "radiation": True, "listener": {"position": [0.0, 0.3, 0.4]},
             "body": [{"name": "plate", "fixed": True, "shape": {"plate": [0.16, 0.1, 0.004]},
                       "material": "preset:aluminium", "density": 2700, "modes": 10},
                      {"name": "ball", "shape": {"sphere": 0.02}, "material": "preset:steel",
                       "density": 7850, "position": [0.0, 0.2, 0.0], "modes": 6}]}
    r = resound.render_scene(scene)
    warnings = r.summary["warnings"]
    assert any(w["kind"] == "poor_transfer"
               and w["message"].startswith('body "plate": the acoustic transfer')
               for w in warnings), warnings
    assert not any('"ball"' in w["message"] for w in warnings), warnings
    assert np.all(np.isfinite(r.audio)) and np.max(np.abs(r.audio)) > 0


def test_a_scrape_sounds_at_the_objects_modes_and_matches_the_cli(model, tmp_path):
    fs = 48000
    modes = model.modes("wood", [0.04, 0.013, 0.011], max_freq_hz=fs / 2)
    assert modes.shape[1] == 4 and len(modes) > 5
    x, path_m = resound.render_scrape(modes, speed_m_s=0.2, duration_s=0.5, sample_rate=fs)
    assert x.dtype == np.float32 and x.shape == (fs // 2,) and np.all(np.isfinite(x))
    assert abs(path_m - 0.2 * (len(x) - 1) / fs) < 1e-9
    # Its energy is at the object's modes: the spectrum's peak is one of them.
    spectrum = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    peak_hz = np.argmax(spectrum) * fs / len(x)
    assert np.min(abs(modes[:, 0] - peak_hz)) < 0.02 * peak_hz
    # A probe that does not move does not scrape.
    still, still_m = resound.render_scrape(modes, trajectory=np.array([[0, 0.05], [0.5, 0.05]]),
                                           duration_s=0.5, sample_rate=fs)
    rms = lambda a: float(np.sqrt(np.mean(a.astype(np.float64) ** 2)))
    assert still_m == 0 and rms(still) < 1e-3 * rms(x)
    # The CLI renders the same scrape (it normalizes: compare shapes).
    doc = {"modes": [dict(zip(["freq_hz", "damping_per_s", "amplitude", "phase_rad"], map(float, r)))
                     for r in modes]}
    (tmp_path / "modes.json").write_text(json.dumps(doc))
    out = cli("scrape", "--modes", "modes.json", "--speed", "0.2", "--duration", "0.5",
              "--sample-rate", str(fs), "--format", "float", "-o", "s.wav", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    cli_x = read_float_wav(tmp_path / "s.wav")
    assert len(cli_x) == len(x)
    corr = np.dot(cli_x, x) / np.sqrt(np.dot(cli_x, cli_x) * np.dot(x.astype(np.float64), x))
    assert corr > 0.99999
    # A scrape that would clip is turned down, and says so (never silently).
    loud = modes.copy()
    loud[:, 2] *= 1e10  # the plain scrape peaks near -158 dBFS
    with pytest.warns(UserWarning, match="turned down by"):
        y, _ = resound.render_scrape(loud, speed_m_s=0.2, duration_s=0.5, sample_rate=fs)
    assert np.max(np.abs(y)) <= 1.0
    with pytest.raises(resound.ResoundError, match="speed_m_s or trajectory"):
        resound.render_scrape(modes, duration_s=0.5)
    with pytest.raises(resound.ResoundError, match="increase"):
        resound.render_scrape(modes, trajectory=np.array([[0, 0], [0, 1.0]]))


def read_float_wav(path):
    """A mono 32-bit float WAV (format 3), which the stdlib wave module does not read."""
    b = Path(path).read_bytes()
    assert b[:4] == b"RIFF" and b[8:12] == b"WAVE"
    k = 12
    while k < len(b):
        tag, size = b[k:k + 4], int.from_bytes(b[k + 4:k + 8], "little")
        if tag == b"data":
            return np.frombuffer(b[k + 8:k + 8 + size], dtype="<f4").astype(np.float64)
        k += 8 + size + (size & 1)
    raise AssertionError("no data chunk")


def clicks(fs, seconds, rate_hz, seed):
    """Rattling: decaying 2–6 kHz bursts at random times."""
    rng = np.random.default_rng(seed)
    x = np.zeros(int(fs * seconds))
    t = np.arange(int(0.01 * fs)) / fs
    for start in rng.uniform(0, seconds - 0.02, int(rate_hz * seconds)):
        k = int(start * fs)
        f = rng.uniform(2000, 6000)
        x[k:k + len(t)] += rng.uniform(0.2, 1) * np.exp(-400 * t) * np.sin(2 * np.pi * f * t)
    return (0.5 * x / np.abs(x).max()).astype(np.float32)


def test_grains_from_arrays_rebuild_and_time_scale_their_recording(tmp_path):
    fs = 44100
    x = clicks(fs, 1.0, 40, seed=5)
    d, info = resound.analyze_grains([("rattle", x)], tmp_path / "r.grains", sample_rate=fs,
                                     kind="impact")
    assert isinstance(d, resound.GrainDictionary) and d.sample_rate == fs
    assert d.recordings == [("rattle", "impact", len(x))]
    assert info["grains"] > 10 and info["file_bytes"] == (tmp_path / "r.grains").stat().st_size
    y = d.resynthesize("rattle")
    assert y.dtype == np.float32 and abs(len(y) - len(x)) <= fs // 100
    # A rebuild at the recording's level, correlated with it.
    n = min(len(x), len(y))
    corr = np.dot(x[:n], y[:n]) / np.sqrt(np.dot(x[:n], x[:n]) * np.dot(y[:n], y[:n]))
    assert corr > 0.5
    assert info["recordings"][0]["spectral_convergence_db"] < -3
    slow = d.resynthesize(0, time_scale=2.0)
    # Time-scaled: onsets twice as far apart (grains keep their own length), so the times by
    # which a quarter, half and three quarters of the energy has come double.
    def energy_times(a):
        c = np.cumsum(a.astype(np.float64) ** 2)
        return np.searchsorted(c, [0.25 * c[-1], 0.5 * c[-1], 0.75 * c[-1]]) / fs
    ratio = energy_times(slow) / energy_times(x)
    assert np.all(abs(ratio - 2.0) < 0.1), ratio
    assert 1.9 < len(slow) / len(x) < 2.05
    assert d.summary()["grains"] == info["grains"]
    with pytest.raises(resound.ResoundError, match="no recording 'nope'"):
        d.resynthesize("nope")
    with pytest.raises(resound.ResoundError, match="silent"):
        resound.analyze_grains([("quiet", np.zeros(fs, np.float32))], tmp_path / "q.grains",
                               sample_rate=fs)


def test_grains_from_a_real_file_match_the_cli(tmp_path):
    ogg = ASSETS / "recordings/default_dig_choppy.1.ogg"
    d, info = resound.analyze_grains([ogg], tmp_path / "py.grains")
    out = cli("grains", "analyze", str(ogg), "-o", "cli.grains", "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    theirs = json.loads(out.stdout)
    for k in ("grains", "impulsive", "sinusoidal", "transient", "grain_bytes", "file_bytes"):
        assert info[k] == theirs[k], k
    assert (tmp_path / "py.grains").read_bytes() == (tmp_path / "cli.grains").read_bytes()
    # An absurd analysis rate is refused before any resampling (it once asked for terabytes).
    for rate in (1e12, -5.0, float("nan")):
        with pytest.raises(resound.ResoundError, match="outside the supported 8000–192000 Hz"):
            resound.analyze_grains([ogg], tmp_path / "x.grains", sample_rate=rate)


def write_wav16(path, x, fs):
    import wave
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(fs)
        w.writeframes((np.clip(x, -1, 1) * 32767).astype("<i2").tobytes())


def test_statistics_fit_from_python_as_the_cli_and_pyimpact_tables_import(model, tmp_path):
    fs = 44100
    files = []
    for k, hit in enumerate([[0.04, 0.013, 0.011], [0.01, 0.03, 0.02], [-0.03, -0.01, 0.025],
                             [0.02, -0.03, -0.01]]):
        x = resound.render_strike("plastic", model, hit, duration_s=0.5, sample_rate=fs,
                                  residual=False)
        rec = np.concatenate([np.zeros(2000), 0.5 * x / np.abs(x).max()])
        files.append(tmp_path / f"plastic{k}.wav")
        write_wav16(files[-1], rec, fs)
    # Four modes: this small box's plastic modes are heavily damped and overlap (d 500-1400
    # 1/s, lines hundreds of Hz wide), so analysis separates only a few in some strikes.
    s = resound.fit_stats(files, "plastic", modes=4)
    assert s.name == "plastic" and s.modes == 4
    s.save(tmp_path / "py.stats.json")
    out = cli("stats", "fit", *map(str, files), "--material", "plastic", "--modes", "4",
              "-o", "cli.stats.json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert json.loads((tmp_path / "py.stats.json").read_text()) == \
        json.loads((tmp_path / "cli.stats.json").read_text())
    # What the fit samples lies among the recorded object's modes (plastic: wood's modes on
    # this small box are damped too fast to analyse).
    f = model.frequencies_hz("plastic")
    ir = resound.ModeStatistics.load(tmp_path / "py.stats.json").sample(1)
    assert f.min() * 0.7 < np.median(ir[:, 0]) < f.max() * 1.3
    tables = resound.import_pyimpact(PYIMPACT)
    assert list(tables) == ["metal_3"]
    one = resound.ModeStatistics.load(PYIMPACT / "metal_3_mm.json")
    assert np.array_equal(tables["metal_3"].sample(2), one.sample(2))
    with pytest.raises(resound.ResoundError, match="no PyImpact tables"):
        resound.import_pyimpact(tmp_path / "empty" if (tmp_path / "empty").mkdir() is None
                                else tmp_path)


def test_joint_analysis_of_both_channels_shares_poles_and_matches_the_cli(tmp_path):
    wav = ASSETS / "recordings/steel_nut_M4_2.wav"
    takes, rep = resound.analyze_joint([wav], every_channel=True)
    assert len(takes) == 2 == len(rep["takes"])
    poles = {m["freq_hz"] for m in rep["modes"]}
    for t in takes:
        assert len(t) >= 5
        # Every take's modes are the shared poles (only amplitudes and phases are its own).
        assert set(t.freq_hz.tolist()) <= poles
        assert np.all(np.diff(t.freq_hz) > 0)
    both = [m for m in rep["modes"] if m["heard_in"] == 2]
    assert len(both) >= 3
    for m in both:
        assert m["sigma"]["freq_hz"] > 0 and m["sigma"]["damping_per_s"] > 0
        assert all(o is not None for o in m["own"])
    out = cli("analyze", str(wav), "--joint", "--every-channel", "--json", "-", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert np.allclose([m["freq_hz"] for m in doc["modes"]],
                       [m["freq_hz"] for m in rep["modes"]], rtol=1e-9)
    with pytest.raises(TypeError, match="list of paths"):
        resound.analyze_joint(wav)
    with pytest.raises(TypeError, match="exclude"):
        resound.analyze_joint([wav], channel=0, every_channel=True)
    out = cli("analyze", str(wav), str(wav), cwd=tmp_path)
    assert out.returncode == 2 and "--joint" in out.stderr


def test_bad_mode_arrays_raise_our_message_not_a_numpy_internal():
    """Issue 37: render_scrape(None, …) raised numpy's "cannot reshape array of size 1"."""
    import pytest as _pytest
    for bad, kind in [(None, TypeError), ("x", TypeError), ([1.0, 2.0, 3.0], ValueError),
                      (np.zeros((3, 5)), ValueError), ([[1, 2], [3]], TypeError)]:
        for call in (lambda m: resound.render_scrape(m, speed_m_s=0.2, duration_s=0.1),
                     lambda m: resound.render_modes(m, duration_s=0.1)):
            with _pytest.raises(kind, match="freq_hz, damping_per_s, amplitude, phase_rad"):
                call(bad)
    # One mode as a flat 4-vector is still one mode.
    y = resound.render_modes([440.0, 5.0, 0.5, 0.0], duration_s=0.1, sample_rate=8000)
    assert y.shape == (800,) and np.abs(y).max() > 0.1
