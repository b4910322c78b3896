#!/usr/bin/env bash
# Builds the Python package into a virtual environment (RESOUND_VENV, default .venv; made and
# filled from PyPI when missing) and runs its tests with pytest. From any directory.
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${RESOUND_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/python" -c "import maturin, pytest, numpy, ray" 2>/dev/null \
    || "$VENV/bin/pip" install -q "maturin>=1.9.4,<2" pytest numpy ray
# An editable install of a dev build (the wheel users get is `pip install ./crates/resound-py`).
VIRTUAL_ENV="$PWD/$VENV" PATH="$PWD/$VENV/bin:$PATH" \
    "$VENV/bin/maturin" develop --quiet -m crates/resound-py/Cargo.toml
# The tests compare with the CLI; `cargo test --workspace` has built it.
[ -x target/debug/resound ] || cargo build --quiet -p resound-cli
RESOUND_REQUIRE_RAY=1 RESOUND_BIN="$PWD/target/debug/resound" "$VENV/bin/python" -m pytest -q crates/resound-py/tests
