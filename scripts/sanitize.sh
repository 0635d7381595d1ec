#!/usr/bin/env bash
# Builds the CPU library and tests with AddressSanitizer + UBSan into build-asan and runs the
# CPU tests; then builds the API tests with ThreadSanitizer into build-tsan and runs the
# tests that trace from many threads at once. CUDA off. Extra arguments go to ctest -R.
set -euo pipefail
cd "$(dirname "$0")/.."
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
jobs=$(nproc)
run() {  # run DIR FLAGS TARGETS...
  local dir=$1 flags=$2
  shift 2
  cmake -S . -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS="$flags -fno-omit-frame-pointer" -DCMAKE_EXE_LINKER_FLAGS="$flags" \
    -DIRGRID_ENABLE_CUDA=OFF -DIRGRID_BUILD_TESTS=ON >/dev/null
  cmake --build "$dir" --parallel "$jobs" ${1:+--target "$@"}
}
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
run build-asan "-fsanitize=address,undefined -fno-sanitize-recover=undefined"
# Not the Install.* tests: they build the examples against the installed (instrumented) static
# library in a CMake run of their own, without the sanitizer's link flags.
ctest --test-dir build-asan -L cpu -E '^Install\.' --parallel "$jobs" --output-on-failure \
  ${1:+-R "$1"}
# TSan: the traces of one accelerator from many threads (the API's concurrency contract).
# Debian's oneTBB and Embree are not built with TSan: their synchronisation is invisible to it.
# src/cpu/parallel.h annotates our side of every hand-off; the suppressions cover the libraries.
export TSAN_OPTIONS="halt_on_error=1 suppressions=$PWD/scripts/tsan-suppressions.txt"
run build-tsan "-fsanitize=thread" test_api
ctest --test-dir build-tsan -R "ConcurrentTraces" --output-on-failure
