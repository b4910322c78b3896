#!/usr/bin/env bash
# Builds the Python package into a virtual environment (RESOUND_VENV, default .venv; made and
# filled from PyPI when missing) and runs its tests with pytest. From any directory.
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${RESOUND_VENV:-.venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/python" -c "import maturin, pytest, numpy, ray, mypy" 2>/dev/null \
    || "$VENV/bin/pip" install -q "maturin>=1.9.4,<2" pytest numpy ray mypy
# Build the abi3 wheel and install it, as users do with `pip install ./crates/resound-py`,
# but with the dev profile that `cargo test` has already built the dependencies for (a
# release build would add minutes and test the same code).
WHEELS=target/wheels-test
rm -rf "$WHEELS"
VIRTUAL_ENV="$PWD/$VENV" PATH="$PWD/$VENV/bin:$PATH" \
    "$VENV/bin/maturin" build --quiet --profile dev -m crates/resound-py/Cargo.toml --out "$WHEELS"
"$VENV/bin/pip" install -q --force-reinstall --no-deps "$WHEELS"/resound-*.whl
# The type stubs say what the native module has (names, signatures, defaults).
"$VENV/bin/python" -m mypy.stubtest resound._native
# The tests compare with the CLI; `cargo test --workspace` has built it.
[ -x target/debug/resound ] || cargo build --quiet -p resound-cli
RESOUND_REQUIRE_RAY=1 RESOUND_BIN="$PWD/target/debug/resound" "$VENV/bin/python" -m pytest -q crates/resound-py/tests
