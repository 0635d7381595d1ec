#!/usr/bin/env bash
# Builds the CUDA configuration and gathers what a machine with only an NVIDIA driver needs to run
# the GPU tests and the benchmark: the irgrid binary, the test executables labelled gpu, the
# non-system shared libraries they load, chosen scenes and a run script.
#
# Usage: bash scripts/gpu-bundle.sh [-o DIR] [--with-embree] [SCENE_FILE...]
#   -o DIR          bundle folder (default bundle/, git-ignored)
#   --with-embree   keep the Embree baseline (adds about 45 MB of libembree3)
#   SCENE_FILE      scene files copied into DIR/scenes/<folder>/ (e.g. ../shared/scenes/crown/crown.obj.xz)
# On the GPU machine: bash DIR/run.sh (scripts/gpu-check-device.sh; results go to $OUT or DIR/results)
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
# The CUDA example, built as an embedder would: against an installed irgrid.
cmake --install "$build_dir" --prefix "$build_dir/bundle-prefix" >/dev/null
cmake -S examples/cuda_kernel -B "$build_dir/bundle-example" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$PWD/$build_dir/bundle-prefix" \
  -DCMAKE_EXE_LINKER_FLAGS="-static-libstdc++ -static-libgcc" >/dev/null
cmake --build "$build_dir/bundle-example" >/dev/null
binaries+=("$build_dir/bundle-example/cuda_kernel")
for binary in "${binaries[@]}"; do
  strip -o "$out/bin/$(basename "$binary")" "$binary"
  # Every resolved library except glibc's own, which the target provides (newer).
  ldd "$binary" | awk '$3 ~ /^\// {print $3}' | while read -r lib; do
    case "$(basename "$lib")" in
      libc.so*|libm.so*|libpthread.so*|libdl.so*|librt.so*|ld-linux*|libresolv.so*) ;;
      # The target's own (newer) C++ runtime serves the shared libraries; ours only where it has
      # none, since an older one first in the search path would break its tools.
      libstdc++.so*|libgcc_s.so*) mkdir -p "$out/lib-fallback" && cp -Lu "$lib" "$out/lib-fallback/" ;;
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

cp scripts/gpu-check-device.sh "$out/run.sh"
chmod +x "$out/run.sh"
# The lease carries 64 MiB: large binaries and libraries travel xz-compressed (run.sh unpacks).
find "$out/bin" "$out/lib" "$out/lib-fallback" -type f -size +2M -exec xz -T0 -6 {} +
du -sh "$out"
echo "gpu-bundle: $out is ready; on the GPU machine run: bash $out/run.sh"
