#!/usr/bin/env bash
# Builds the libFuzzer targets with Clang (AddressSanitizer and UBSan on, CUDA off) into
# ${IRGRID_FUZZ_DIR:-build-fuzz} and runs each for SECONDS seconds (default 10: the CI smoke)
# from a copy of fuzz/corpus. Crashes stop the run with the reproducer in the build folder.
#   scripts/fuzz.sh [SECONDS] [TARGET...]   targets: obj ply compressed rays views grid
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-10}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(obj ply compressed rays views grid)
dir=${IRGRID_FUZZ_DIR:-build-fuzz}
flags="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -g -O1"
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
CC=clang CXX=clang++ cmake -S . -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DIRGRID_ENABLE_CUDA=OFF -DIRGRID_BUILD_TESTS=OFF -DIRGRID_BUILD_TOOLS=OFF \
  -DIRGRID_BUILD_FUZZERS=ON >/dev/null
cmake --build "$dir" --parallel "$(nproc)" --target "${targets[@]/#/fuzz_}"
for target in "${targets[@]}"; do
  corpus="$dir/corpus/$target"
  mkdir -p "$corpus"
  cp -n fuzz/corpus/"$target"/* "$corpus"/ 2>/dev/null || true
  echo "fuzz.sh: $target for ${seconds} s"
  # rss_limit bounds each input (the decompression limit keeps real inputs far below it).
  (cd "$dir" && ./fuzz/fuzz_"$target" -max_total_time="$seconds" -rss_limit_mb=2048 \
     -max_len=65536 -print_final_stats=1 "corpus/$target" 2>&1 | grep -E "stat::number_of_executed_units|stat::peak_rss|ERROR|SUMMARY|Done" || true)
  [ -z "$(ls "$dir"/crash-* "$dir"/leak-* "$dir"/oom-* 2>/dev/null)" ] || { echo "fuzz.sh: $target failed" >&2; exit 1; }
done
