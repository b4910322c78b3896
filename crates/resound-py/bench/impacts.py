"""100 impacts from a PyImpact table, rendered from Python (the issue's PyImpact figure:
0.62–0.76 s), against the same library calls made from Rust (`resound bench stats`).

    python crates/resound-py/bench/impacts.py [--json] [--resound target/release/resound]

Build the package in release for figures (`pip install ./crates/resound-py`, or
`maturin develop --release -m crates/resound-py/Cargo.toml`). Best of 3, as the Rust bench.
"""

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import resound

REPO = Path(__file__).resolve().parents[3]
TABLE = REPO / "crates/resound-cli/tests/fixtures/pyimpact/metal_3_mm.json"


def hundred(stats):
    t0 = time.perf_counter()
    sink = 0.0
    for k in range(100):
        x = resound.render_impact(stats, seed=k, speed_m_s=0.5 + 0.01 * k, duration_s=1.0,
                                  sample_rate=44100, impactor_mass_kg=0.01)
        sink += float(x[100])
    return time.perf_counter() - t0


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--json", action="store_true")
    p.add_argument("--resound", default=str(REPO / "target/release/resound"),
                   help="the CLI for the Rust baseline (bench stats)")
    a = p.parse_args()
    stats = resound.ModeStatistics.from_pyimpact_json("metal_3", TABLE.read_text())
    py = min(hundred(stats) for _ in range(3))
    rust = None
    if Path(a.resound).exists():
        out = subprocess.run([a.resound, "bench", "stats", "--json"], capture_output=True,
                             text=True, check=True)
        rust = json.loads(out.stdout)["impacts100_render_strike_s"]
    doc = {"benchmark": "python impacts", "impacts100_python_s": py,
           "impacts100_rust_s": rust,
           "python_overhead": None if rust is None else py / rust - 1.0,
           "pyimpact_reported_s": [0.62, 0.76]}
    if a.json:
        print(json.dumps(doc, indent=2))
    else:
        extra = "" if rust is None else f"; the same calls from Rust {rust:.4f} s (overhead {100 * (py / rust - 1):+.1f} %)"
        print(f"100 impacts from Python: {py:.4f} s (PyImpact: 0.62–0.76 s){extra}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
