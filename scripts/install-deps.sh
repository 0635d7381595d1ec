#!/usr/bin/env bash
# Installs the Debian 12 packages irgrid builds with (skips apt when all are present).
# The CUDA backend additionally needs the CUDA toolkit (nvcc >= 12); without it irgrid builds
# for the CPU only.
set -euo pipefail

packages=(build-essential cmake ninja-build pkg-config xz-utils
          libtbb-dev libfmt-dev nlohmann-json3-dev libcli11-dev libtinyobjloader-dev libstb-dev
          zlib1g-dev liblzma-dev libgtest-dev libembree-dev python3 python3-dev python3-venv
          libgmp-dev clang libclang-rt-14-dev)  # clang: the fuzz targets (scripts/fuzz.sh)

missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" ||
    missing+=("$package")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} Debian packages present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: run as root to install: ${missing[*]}" >&2; exit 2; }
  sudo="sudo"
fi
echo "install-deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
