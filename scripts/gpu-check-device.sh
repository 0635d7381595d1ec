#!/usr/bin/env bash
# The one-shot GPU check, run on the GPU machine from a bundle that scripts/gpu-bundle.sh made
# (it is copied there as run.sh): the tests labelled gpu, the CUDA example, compute-sanitizer's
# memcheck and racecheck on a small scene, the benchmark (paper table) and rebuild timings on
# every bundled scene, in the order of their value (the tests, then the benchmark, then the
# sanitizers and the rebuilds). Each step has a time limit, and all of them share one deadline,
# so the whole check ends inside one device call however slow a step turns out.
#
# Usage (on the GPU machine): bash bundle/run.sh
#   IRGRID_CHECK_COMPARE  structures the benchmark compares (default: irregular@cuda, and
#                         cwbvh@cuda where this build has it)
#   IRGRID_CHECK_STEPS    steps to run, comma-separated (default: tests,example,bench,memcheck,
#                         racecheck,rebuild)
#   IRGRID_CHECK_SECONDS  the deadline of all steps together (default 480: a device call runs
#                         600 s at most); a step that would start with under 20 s left is skipped
# Logs, JSON and summary.md go to results/ beside this script and, packed as results.tar.gz with
# summary.md beside it, to $OUT when that is set (the device tool brings back few files).
# Exit status: 0 when every step passed, 1 when one failed, 3 when none failed but some were
# skipped for the deadline, 2 when there is no NVIDIA device and 4 when its driver is older than
# the CUDA 13 runtime linked in (at once, nothing run). compute-sanitizer's steps count as
# passed, marked unavailable, where the tool is missing or refuses the device (it does under
# gVisor).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
results=$here/results
rm -rf "$results"
mkdir -p "$results"

if ! { command -v nvidia-smi >/dev/null && nvidia-smi -L 2>/dev/null | grep -q '^GPU'; }; then
  echo "gpu-check: no NVIDIA device here (nvidia-smi lists no GPU): run this on the GPU machine" >&2
  exit 2
fi
export IRGRID_REQUIRE_GPU=1  # with a device present, a GPU test that skips is a failure
# CUDA 13's runtime, linked in statically, needs driver 580 or later: with an older one every
# CUDA call fails, so stop before spending the lease.
driver=$(nvidia-smi --query-gpu=driver_version --format=csv,noheader 2>/dev/null | head -1)
if [ "${driver%%.*}" -lt 580 ] 2>/dev/null; then
  echo "gpu-check: driver $driver is older than 580, which the CUDA 13 runtime needs" >&2
  exit 4
fi

# Large files travel xz-compressed (the lease carries 64 MiB); unpack them once.
unpacked=${TMPDIR:-/tmp}/irgrid-bundle
rm -rf "$unpacked"  # an earlier bundle's binaries must not run as this one's
mkdir -p "$unpacked/bin" "$unpacked/lib" "$unpacked/lib-fallback"
for packed in "$here"/bin/* "$here"/lib/* "$here"/lib-fallback/*; do
  [ -e "$packed" ] || continue
  folder=$(basename "$(dirname "$packed")")
  case "$packed" in
    *.xz) xz -dc "$packed" >"$unpacked/$folder/$(basename "$packed" .xz)" ;;
    *) cp "$packed" "$unpacked/$folder/" ;;
  esac
done
chmod +x "$unpacked"/bin/*
bin=$unpacked/bin
export LD_LIBRARY_PATH="$unpacked/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
if ! ldconfig -p 2>/dev/null | grep -q 'libstdc++.so.6 '; then
  LD_LIBRARY_PATH="$LD_LIBRARY_PATH:$unpacked/lib-fallback"
fi
export IRGRID_SHARED_SCENES="$here/scenes"

steps=",${IRGRID_CHECK_STEPS:-tests,example,bench,memcheck,racecheck,rebuild},"
deadline=$((SECONDS + ${IRGRID_CHECK_SECONDS:-480}))
compare=${IRGRID_CHECK_COMPARE:-irregular@cuda}
if [ -z "${IRGRID_CHECK_COMPARE:-}" ] && "$bin/irgrid" info | grep -q '^structures:.*cwbvh'; then
  compare=irregular@cuda,cwbvh@cuda
fi
summary=$results/summary.md
status=0
printf '| step | exit | seconds |\n| --- | --- | --- |\n' >"$summary"

# step NAME SECONDS COMMAND...: runs COMMAND with a time limit (SECONDS, or what is left before
# the deadline), its output in NAME.log; skipped with under 20 s left.
step() {
  local name=$1 limit=$2
  shift 2
  local left=$((deadline - SECONDS))
  if [ $left -lt 20 ]; then
    printf '| %s | skipped (deadline) | 0 |\n' "$name" >>"$summary"
    [ $status -eq 0 ] && status=3
    return 0
  fi
  [ $limit -gt $left ] && limit=$left
  local start=$SECONDS
  timeout --kill-after=5 "$limit" "$@" >"$results/$name.log" 2>&1
  local code=$?
  printf '| %s | %s | %s |\n' "$name" "$code$([ $code -eq 124 ] && echo ' (timed out)')" \
    $((SECONDS - start)) >>"$summary"
  if [ $code -ne 0 ]; then
    status=1
    echo "== $name failed (exit $code); its log ends:"
    tail -15 "$results/$name.log"
  fi
  return $code
}
# sanitizer NAME SECONDS COMMAND...: a compute-sanitizer step, marked unavailable (not failed)
# where the tool is missing or refuses the device.
sanitizer() {
  local name=$1
  if ! command -v compute-sanitizer >/dev/null; then
    printf '| %s | unavailable (no compute-sanitizer) | 0 |\n' "$name" >>"$summary"
    return 0
  fi
  local before=$status
  step "$@" && return 0
  if grep -q "Device not supported" "$results/$name.log"; then
    status=$before
    printf '| %s | unavailable (device not supported) | 0 |\n' "$name" >>"$summary"
  fi
}
wants() { [[ $steps == *,$1,* ]]; }

nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm \
  --format=csv | tee "$results/gpu.txt"
"$bin/irgrid" info | tee "$results/info.txt"

if wants tests; then
  for test in "$bin"/test_*; do
    name=$(basename "$test")
    # Blocking launches: a faulting kernel is reported by its own launch, not a later call.
    step "$name" 150 env CUDA_LAUNCH_BLOCKING=1 "$test" --gtest_brief=1 \
      --gtest_output="json:$results/$name.json"
  done
fi
if wants example && [ -x "$bin/cuda_kernel" ]; then
  step cuda_kernel_example 60 "$bin/cuda_kernel"
fi
# The sanitizers watch a whole benchmark of a small scene: both builds, the traversal kernels for
# closest and any hit, trace and trace_device.
small=(bench builtin:teapot-stadium:20000 --backend cuda --width 128 --height 128 --count 16384
  --spp 1 --repeat 1 --build-repeat 1 --validate 2000)

views=()
[ -e "$here/scenes/views.json" ] && views=(--views-file "$here/scenes/views.json")
scenes=()
for scene in "$here"/scenes/*/*.obj.xz "$here"/scenes/*/*.ply.xz; do
  [ -e "$scene" ] && scenes+=("$scene")
done
if wants bench; then
  for scene in "${scenes[@]}"; do
    name=$(basename "$(dirname "$scene")")
    step "bench-$name" 200 "$bin/irgrid" bench "$scene" "${views[@]}" --compare "$compare" \
      --kinds primary,ao,random --json "$results/bench-$name.json"
  done
fi
if wants memcheck; then
  sanitizer memcheck 100 compute-sanitizer --tool memcheck --leak-check full --error-exitcode 9 \
    "$bin/irgrid" "${small[@]}"
fi
if wants racecheck; then
  sanitizer racecheck 80 compute-sanitizer --tool racecheck --error-exitcode 9 \
    "$bin/irgrid" "${small[@]}" --kinds primary,random
fi
if wants rebuild; then
  for scene in "${scenes[@]}"; do
    name=$(basename "$(dirname "$scene")")
    step "rebuild-$name" 120 "$bin/irgrid" bench "$scene" --rebuild 20 \
      --compare "$compare" --json "$results/rebuild-$name.json"
  done
fi

# Last, so that the reply's tail holds it: the comparison tables and the step summary.
for log in "$results"/bench-*.log "$results"/rebuild-*.log; do
  [ -e "$log" ] || continue
  echo "== $(basename "$log" .log)"
  sed -n '/^comparison/,$p;/^rebuilds of/,$p' "$log" | head -30
done
cat "$summary"
if [ -n "${OUT:-}" ]; then
  tar -czf "$OUT/results.tar.gz" -C "$here" results
  cp "$summary" "$OUT/"
fi
exit $status
