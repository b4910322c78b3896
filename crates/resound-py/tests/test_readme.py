"""Issue 37: the README's Python block runs as written, so it can never silently rot.

It runs from the top of a checkout after the README's shell examples; this test makes what
those lines make (with the CLI) and then executes the block unchanged.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
CLI = os.environ.get("RESOUND_BIN", str(REPO / "target/debug/resound"))


def block(text, heading, fence):
    start = text.index(fence, text.index(heading)) + len(fence)
    return text[start:text.index("```", start)]


def test_the_readme_python_block_runs_as_written(tmp_path, monkeypatch, capsys):
    readme = (REPO / "README.md").read_text()
    code = block(readme, "### Python", "```python\n")
    monkeypatch.setenv("RESOUND_LIBRARY", str(tmp_path / "library.sqlite"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / ".cache"))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "assets").symlink_to(REPO / "assets")
    (tmp_path / "path/to").mkdir(parents=True)
    (tmp_path / "path/to/material_data").symlink_to(
        REPO / "crates/resound-cli/tests/fixtures/pyimpact")
    shutil.copy(REPO / "assets/recordings/steel_nut_M4_2.wav", "strike.wav")
    job = block(readme, "### Datasets", "```json\n").replace("\n", "")
    Path("jobs.jsonl").write_text(job + "\n")
    # What the shell examples make that the block uses, by their own lines.
    shell = block(readme, "## Examples", "```sh\n")
    wanted = ("ramp.obj", "cup.obj", "resound demo")
    lines = [ln.split("  #")[0].strip() for ln in shell.splitlines()]
    for line in [ln for ln in lines if any(w in ln for w in wanted)]:
        if line.startswith("resound estimate") or line.startswith("resound synth"):
            continue
        done = subprocess.run([CLI, *line.split()[1:]], capture_output=True, text=True)
        assert done.returncode == 0, f"{line}: {done.stderr}"
    assert Path("demo-out/scene.toml").exists() and Path("ramp.obj").exists()
    exec(compile(code, "README.md (Python block)", "exec"), {"__name__": "readme"})
    # The block's own print shows the estimate's pairing and the contact time.
    printed = capsys.readouterr().out
    assert re.search(r"\d", printed), printed
    # What it wrote is there.
    assert Path("nut.grains").exists() and Path("out").is_dir()
