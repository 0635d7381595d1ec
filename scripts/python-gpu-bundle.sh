#!/usr/bin/env bash
# Builds the Python extension with CUDA for CPython 3.12 on this machine (whose own Python may be
# another version: only 3.12's headers are needed, taken from Ubuntu noble's libpython3.12-dev
# package and extracted, never installed) and gathers what a GPU machine with python3.12, numpy
# and pytest (torch or cupy for the GPU tests) but no compiler needs: the importable irgrid
# package, the shared libraries it loads that such a machine may lack, the Python tests and
# run.sh.
#
# Usage: bash scripts/python-gpu-bundle.sh [-o DIR]     (default pybundle/, git-ignored)
# On the GPU machine: bash DIR/run.sh [pytest arguments...]
#   (JUnit XML, log and `irgrid` info go to $OUT, or DIR/results without it; without an NVIDIA
#   device it stops at once unless its first argument is --no-gpu, for rehearsals)
# Environment: IRGRID_PY312_DEB (the .deb's URL), IRGRID_PY312_DIR (where headers are kept,
# default /tmp/irgrid-cpython-3.12), IRGRID_BUNDLE_BUILD_DIR (default build-py312),
# IRGRID_BUNDLE_JOBS (default: all cores).
set -euo pipefail
cd "$(dirname "$0")/.."
out=pybundle
while [ $# -gt 0 ]; do
  case "$1" in
    -o) out=$2; shift 2 ;;
    -h|--help) sed -n 2,15p "$0"; exit 0 ;;
    *) echo "python-gpu-bundle: unknown argument $1" >&2; exit 2 ;;
  esac
done
command -v nvcc >/dev/null || export PATH="$PATH:/usr/local/cuda/bin"
command -v nvcc >/dev/null || { echo "python-gpu-bundle: nvcc not found (CUDA toolkit >= 12 needed)" >&2; exit 2; }

# --- CPython 3.12's headers, with Debian's multiarch pyconfig.h put in place of its wrapper.
deb=${IRGRID_PY312_DEB:-http://archive.ubuntu.com/ubuntu/pool/main/p/python3.12/libpython3.12-dev_3.12.3-1ubuntu0.9_amd64.deb}
py_dir=${IRGRID_PY312_DIR:-/tmp/irgrid-cpython-3.12}
if [ ! -e "$py_dir/include/python3.12/Python.h" ]; then
  rm -rf "$py_dir" && mkdir -p "$py_dir/deb"
  echo "python-gpu-bundle: fetching $deb"
  curl -fsSL -o "$py_dir/libpython3.12-dev.deb" "$deb"
  dpkg-deb -x "$py_dir/libpython3.12-dev.deb" "$py_dir/deb"
  mkdir -p "$py_dir/include"
  cp -r "$py_dir/deb/usr/include/python3.12" "$py_dir/include/"
  cp "$py_dir/deb/usr/include/x86_64-linux-gnu/python3.12/pyconfig.h" "$py_dir/include/python3.12/"
fi

# --- nanobind's CMake files (any Python here can hold nanobind: it is compiled from source).
nanobind_dir=$(python3 -m nanobind --cmake_dir 2>/dev/null || true)
if [ -z "$nanobind_dir" ]; then
  venv=${TMPDIR:-/tmp}/irgrid-nanobind-venv
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  "$venv/bin/python" -m nanobind --cmake_dir >/dev/null 2>&1 || "$venv/bin/python" -m pip install -q nanobind
  nanobind_dir=$("$venv/bin/python" -m nanobind --cmake_dir)
fi

# --- The extension: CUDA, the C++ and CUDA runtimes linked in (the GPU machine has its own newer
# glibc and a driver); static-library symbols stay private, so that they never meet torch's.
build_dir=${IRGRID_BUNDLE_BUILD_DIR:-build-py312}
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DIRGRID_BUILD_PYTHON=ON -DIRGRID_BUILD_TESTS=OFF -DIRGRID_BUILD_TOOLS=OFF \
  -DIRGRID_ENABLE_CUDA=ON -DIRGRID_ENABLE_EMBREE=OFF \
  -Dnanobind_ROOT="$nanobind_dir" -Dnanobind_DIR="$nanobind_dir" -DPython_INCLUDE_DIR="$py_dir/include/python3.12" \
  -DPython_SOABI=cpython-312-x86_64-linux-gnu -DPython_SOSABI=abi3 \
  "-DCMAKE_MODULE_LINKER_FLAGS=-static-libstdc++ -static-libgcc -Wl,--exclude-libs,ALL"
cmake --build "$build_dir" --target _irgrid --parallel "${IRGRID_BUNDLE_JOBS:-$(nproc)}"

extension=$(ls "$build_dir"/python/irgrid/_irgrid.cpython-312-*.so)
rm -rf "$out"
mkdir -p "$out/irgrid" "$out/lib" "$out/lib-fallback" "$out/tests"
strip -o "$out/irgrid/$(basename "$extension")" "$extension"
cp python/irgrid/*.py "$out/irgrid/"
cp python/tests/*.py "$out/tests/"
# Libraries a bare machine may lack go to lib/ (first on the library path). Those every Linux
# with Python has (zlib, liblzma) go to lib-fallback/, used only if missing there: an older
# copy first on the path would shadow the newer ones that torch or Python's own modules load.
# glibc, libstdc++ and libgcc_s are never carried (the machine's are newer).
ldd "$extension" | awk '$3 ~ /^\// {print $3}' | while read -r lib; do
  case "$(basename "$lib")" in
    libc.so*|libm.so*|libpthread.so*|libdl.so*|librt.so*|ld-linux*|libresolv.so*) ;;
    libstdc++.so*|libgcc_s.so*) ;;
    libz.so*|liblzma.so*) cp -L "$lib" "$out/lib-fallback/" ;;
    *) cp -L "$lib" "$out/lib/" ;;
  esac
done

cat > "$out/run.sh" <<'RUN'
#!/usr/bin/env bash
# Runs irgrid's Python tests with this bundle's extension (CPython 3.12, CUDA) on a GPU machine.
# Needs python3 (or $PYTHON) 3.12 with numpy and pytest; the GPU tests use torch (CUDA) or
# cupy. Extra arguments go to pytest. Results go to $OUT, or results/ beside this script.
# Usage: bash run.sh [--no-gpu] [pytest arguments...]   (--no-gpu: run where no GPU is, to
# rehearse; the GPU tests then skip)
set -uo pipefail
no_gpu_ok=0
[ "${1:-}" = --no-gpu ] && { no_gpu_ok=1; shift; }
here=$(cd "$(dirname "$0")" && pwd)
results=${OUT:-$here/results}
mkdir -p "$results"
fail() { echo "run.sh: $*" >&2; exit 2; }
python=${PYTHON:-python3}
command -v "$python" >/dev/null || fail "$python not found (this bundle needs CPython 3.12)"
version=$("$python" -c 'import sys; print("%d.%d" % sys.version_info[:2])') ||
  fail "$python does not run"
[ "$version" = 3.12 ] || fail "the extension is built for CPython 3.12; $python is $version"
"$python" -c 'import numpy, pytest' || fail "$python lacks numpy or pytest"

extension=$(ls "$here"/irgrid/_irgrid.cpython-312-*.so)
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
if ldd "$extension" | grep -q 'not found'; then
  LD_LIBRARY_PATH="$LD_LIBRARY_PATH:$here/lib-fallback"
fi
missing=$(ldd "$extension" | grep 'not found') && fail "libraries missing: $missing"
export PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}"

# With an NVIDIA device present, the GPU tests must run, not skip.
gpu_present=0
if ls /dev/nvidia[0-9]* >/dev/null 2>&1 ||
   { command -v nvidia-smi >/dev/null && nvidia-smi -L 2>/dev/null | grep -q '^GPU'; }; then
  gpu_present=1
  export IRGRID_REQUIRE_GPU=1
  "$python" -c 'import torch' 2>/dev/null || "$python" -c 'import cupy' 2>/dev/null ||
    fail "$python has neither torch nor cupy: the GPU-array tests need one"
elif [ "$no_gpu_ok" = 0 ]; then
  fail "no NVIDIA device here (/dev/nvidia*, nvidia-smi); run.sh --no-gpu runs the tests anyway"
fi
"$python" -c 'import irgrid, irgrid._irgrid as c
print("irgrid", irgrid.version(), "backends:", irgrid.backends(), "cuda built:", c.has_cuda())
print("cuda:", c.cuda_status())
for name in ("torch", "cupy"):
    try:
        module = __import__(name)
        print(name, module.__version__)
    except ImportError as e:
        print(name, "not importable:", e)' 2>&1 | tee "$results/info.txt"
[ "${PIPESTATUS[0]}" -eq 0 ] || fail "import irgrid failed"

cd "$here/tests"
"$python" -m pytest -q -rs -p no:cacheprovider --junitxml="$results/pytest.xml" "$@" 2>&1 |
  tee "$results/pytest.log"
status=${PIPESTATUS[0]}
if [ "$gpu_present" = 1 ]; then
  ran=$("$python" - "$results/pytest.xml" <<'COUNT'
import sys, xml.etree.ElementTree as ET
cases = [c for c in ET.parse(sys.argv[1]).iter("testcase") if "test_gpu_arrays" in c.get("classname", "")]
print(sum(1 for c in cases if c.find("skipped") is None))
COUNT
)
  echo "run.sh: a GPU is present; $ran GPU-array tests ran (not skipped)"
  [ "${ran:-0}" -gt 0 ] || { echo "run.sh: no GPU-array test ran although a GPU is present" >&2; status=1; }
fi
exit "$status"
RUN
chmod +x "$out/run.sh"
du -sh "$out"
echo "python-gpu-bundle: $out is ready; on the GPU machine run: bash $out/run.sh"
