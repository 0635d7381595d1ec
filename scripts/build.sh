#!/usr/bin/env bash
# Configures and builds irgrid (Release) into ${IRGRID_BUILD_DIR:-build}. Extra arguments go to
# CMake, e.g. -DIRGRID_ENABLE_CUDA=OFF.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${IRGRID_BUILD_DIR:-build}
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build "$build_dir" --parallel "$(nproc)"
