#!/usr/bin/env bash
# Every test of hugrt: the Rust workspace's (cargo test), then the Python package's (pytest),
# built into a virtual environment under target/ with the package's test requirements from
# the Python package registry. Set HUGRT_SKIP_PYTHON=1 to run only the Rust tests.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --release --locked
if [ "${HUGRT_SKIP_PYTHON:-0}" = 1 ]; then
    echo "Python tests skipped (HUGRT_SKIP_PYTHON=1)"
    exit 0
fi
python=${PYTHON:-python3}
if ! command -v "$python" >/dev/null; then
    echo "Python tests skipped: no $python on PATH"
    exit 0
fi
venv=target/python-venv
if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --upgrade pip
"$venv/bin/python" -m pip install -q "maturin>=1.5,<2" numpy pytest trimesh rtree "ray[default]>=2.9"
# maturin builds the extension with the workspace's Cargo.lock and installs it in place.
VIRTUAL_ENV="$PWD/$venv" PATH="$PWD/$venv/bin:$PATH" "$venv/bin/maturin" develop --release --locked -q
"$venv/bin/python" -m pytest -q python/tests
