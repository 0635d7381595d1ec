#!/usr/bin/env bash
# Builds the Python package the way a user does (pip install . into a fresh virtual
# environment, CPU backend only to keep it short) and runs its pytest suite against the
# installed package, the Dask test on a local two-worker cluster among them.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${IRGRID_PYTHON_VENV:-build/venv}
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --upgrade pip
"$venv/bin/python" -m pip install -q numpy pytest hypothesis "dask[array,distributed]" trimesh rtree
"$venv/bin/python" -m pip install -q . --config-settings=cmake.define.IRGRID_ENABLE_CUDA=OFF
"$venv/bin/python" -c "import irgrid; print('irgrid', irgrid.version(), 'backends:', irgrid.backends())"
"$venv/bin/python" -m pytest -q python/tests
