#!/usr/bin/env bash
# Builds the CUDA configuration and gathers what a machine with only an NVIDIA driver needs to run
# the GPU tests and the benchmark: the irgrid binary, the test executables labelled gpu, the
# non-system shared libraries they load, chosen scenes and a run script.
#
# Usage: bash scripts/gpu-bundle.sh [-o DIR] [--with-embree] [SCENE_FILE...]
#   -o DIR          bundle folder (default bundle/, git-ignored)
#   --with-embree   keep the Embree baseline (adds about 45 MB of libembree3)
#   SCENE_FILE      scene files copied into DIR/scenes/<folder>/ (e.g. ../shared/scenes/crown/crown.obj.xz)
# On the GPU machine: bash DIR/run.sh [bench arguments...]   (results and logs go to $OUT or DIR/results)
set -euo pipefail
cd "$(dirname "$0")/.."
out=bundle
embree=OFF
scenes=()
while [ $# -gt 0 ]; do
  case "$1" in
    -o) out=$2; shift 2 ;;
    --with-embree) embree=ON; shift ;;
    -h|--help) sed -n 2,10p "$0"; exit 0 ;;
    *) scenes+=("$1"); shift ;;
  esac
done
command -v nvcc >/dev/null || export PATH="$PATH:/usr/local/cuda/bin"
command -v nvcc >/dev/null || { echo "gpu-bundle: nvcc not found (CUDA toolkit >= 12 needed)" >&2; exit 2; }

build_dir=${IRGRID_BUNDLE_BUILD_DIR:-build-bundle}
# Static libstdc++/libgcc and the static CUDA runtime: the target has its own (newer) glibc and a
# driver, nothing else.
IRGRID_BUILD_DIR=$build_dir bash scripts/build.sh -DIRGRID_ENABLE_CUDA=ON \
  -DIRGRID_ENABLE_EMBREE="$embree" -DCMAKE_EXE_LINKER_FLAGS="-static-libstdc++ -static-libgcc"

rm -rf "$out"
mkdir -p "$out/bin" "$out/lib" "$out/scenes"
binaries=("$build_dir/irgrid")
for test in "$build_dir"/tests/test_*; do
  name=$(basename "$test")
  [[ -x "$test" && "$name" =~ cuda|gpu ]] && binaries+=("$test")  # CTest's gpu label rule
done
for binary in "${binaries[@]}"; do
  strip -o "$out/bin/$(basename "$binary")" "$binary"
  # Every resolved library except glibc's own, which the target provides (newer).
  ldd "$binary" | awk '$3 ~ /^\// {print $3}' | while read -r lib; do
    case "$(basename "$lib")" in
      libc.so*|libm.so*|libpthread.so*|libdl.so*|librt.so*|ld-linux*|libresolv.so*) ;;
      *) cp -Lu "$lib" "$out/lib/" ;;
    esac
  done
done
for scene in "${scenes[@]}"; do
  folder="$out/scenes/$(basename "$(dirname "$scene")")"
  mkdir -p "$folder"
  cp "$scene" "$folder/"
done
cp ../shared/scenes/views.json "$out/scenes/" 2>/dev/null || true

cat > "$out/run.sh" <<'RUN'
#!/usr/bin/env bash
# Runs the GPU tests (the executables CTest labels gpu) and the benchmark on every bundled scene.
# Extra arguments go to `irgrid bench`. Logs and JSON go to $OUT (or results/ beside this script).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
results=${OUT:-$here/results}
mkdir -p "$results"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export IRGRID_SHARED_SCENES="$here/scenes"
status=0
# With an NVIDIA device present, the GPU tests must run: IRGRID_REQUIRE_GPU turns their "no GPU"
# skip (a driver too old for the toolkit, a missing library) into a failure.
if ls /dev/nvidia[0-9]* >/dev/null 2>&1 ||
   { command -v nvidia-smi >/dev/null && nvidia-smi -L 2>/dev/null | grep -q '^GPU'; }; then
  export IRGRID_REQUIRE_GPU=1
  echo "run.sh: an NVIDIA device is present: GPU tests that skip fail"
fi
"$here/bin/irgrid" info | tee "$results/info.txt"
for test in "$here"/bin/test_*; do
  name=$(basename "$test")
  "$test" --gtest_brief=1 --gtest_output="json:$results/$name.json" >"$results/$name.log" 2>&1
  code=$?
  echo "$name: exit $code ($(grep -c '^\[  FAILED' "$results/$name.log") failed lines," \
    "$(grep -c '^\[  SKIPPED' "$results/$name.log") skipped lines)"
  [ $code -eq 0 ] || { status=1; tail -20 "$results/$name.log"; }
done
for scene in "$here"/scenes/*/*.obj.xz "$here"/scenes/*/*.ply.xz; do
  [ -e "$scene" ] || continue
  name=$(basename "$(dirname "$scene")")
  views=()
  [ -e "$here/scenes/views.json" ] && views=(--views-file "$here/scenes/views.json")
  "$here/bin/irgrid" bench "$scene" "${views[@]}" --backend cuda \
    --json "$results/bench-$name.json" "$@" 2>"$results/bench-$name.log" |
    tee "$results/bench-$name.txt" || status=1
done
exit $status
RUN
chmod +x "$out/run.sh"
du -sh "$out"
echo "gpu-bundle: $out is ready; on the GPU machine run: bash $out/run.sh"
