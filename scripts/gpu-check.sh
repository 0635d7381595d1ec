#!/usr/bin/env bash
# The GPU comparison in one shot. Here: builds bundle/ (scripts/gpu-bundle.sh with Embree, for the
# cwbvh builder, and Sponza, Conference and Crown) and checks it fits the 64 MiB a device call
# carries. There: `bash bundle/run.sh` (scripts/gpu-check-device.sh) runs the gpu-labelled
# tests, the CUDA example, the paper table, compute-sanitizer memcheck and racecheck, and rebuild
# timings within one deadline, writing logs, JSON and summary.md to $OUT.
#
# Usage: bash scripts/gpu-check.sh [extra scene files...]
set -euo pipefail
cd "$(dirname "$0")/.."
scenes=../shared/scenes
for scene in crytek-sponza/sponza.obj.xz conference/conference.obj.xz crown/crown.obj.xz; do
  [ -e "$scenes/$scene" ] || { echo "gpu-check: $scenes/$scene is missing" >&2; exit 2; }
done
bash scripts/gpu-bundle.sh --with-embree "$scenes/crytek-sponza/sponza.obj.xz" \
  "$scenes/conference/conference.obj.xz" "$scenes/crown/crown.obj.xz" "$@"
bytes=$(du -sb bundle | cut -f1)
limit=$((64 * 1024 * 1024))
if [ "$bytes" -gt "$limit" ]; then
  echo "gpu-check: bundle/ holds $bytes bytes, over the $limit a device call carries" >&2
  exit 1
fi
echo "gpu-check: bundle/ ($((bytes / 1048576)) MiB) is ready: carry it and run 'bash bundle/run.sh'"
