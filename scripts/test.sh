#!/usr/bin/env bash
# Sets up, builds and runs every test: the C++ suite (ctest; GPU tests skip cleanly without a
# GPU), then the Python package, installed with pip into build/venv, and its pytest suite.
# Tests reading ../shared/scenes skip when that folder is absent, and fail instead with
# IRGRID_REQUIRE_SHARED_SCENES=1 (as .ci/run sets).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DIRGRID_BUILD_TESTS=ON
build_dir=${IRGRID_BUILD_DIR:-build}
ctest --test-dir "$build_dir" --output-on-failure --parallel "$(nproc)" --timeout 900
# A short fuzzing smoke: every libFuzzer target for IRGRID_FUZZ_SECONDS (default 10; 0 skips).
fuzz_seconds=${IRGRID_FUZZ_SECONDS:-10}
if [ "$fuzz_seconds" != 0 ] && command -v clang++ >/dev/null; then
  bash scripts/fuzz.sh "$fuzz_seconds"
fi
bash scripts/python-test.sh
