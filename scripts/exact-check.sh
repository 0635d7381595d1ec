#!/usr/bin/env bash
# The recorded check of the exact oracle (docs/validation.md): for Crytek Sponza, Conference and
# Crown, the irregular grid's hits on every view and ray kind against the exact oracle, 131,072
# rays per view and kind (over 10^6 per scene), t, u and v included. Writes out/exact-<scene>.json,
# .txt and .log, and prints the machine, the date and the time each scene took.
# Usage: bash scripts/exact-check.sh [SCENE_FILE...]   (default: the three shared scenes)
#        extra bench options (e.g. --compare irregular,embree) via IRGRID_EXACT_CHECK_OPTIONS
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${IRGRID_BUILD_DIR:-build}
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(../shared/scenes/crytek-sponza/sponza.obj.xz
                                   ../shared/scenes/conference/conference.obj.xz
                                   ../shared/scenes/crown/crown.obj.xz)
read -r -a extra <<<"${IRGRID_EXACT_CHECK_OPTIONS:-}"
mkdir -p out
echo "machine: $(lscpu | sed -n 's/^Model name: *//p' | head -1), $(nproc) threads; $(date -u +%Y-%m-%dT%H:%MZ)"
status=0
for scene in "${scenes[@]}"; do
  name=$(basename "$(dirname "$scene")")
  start=$(date +%s)
  "$build_dir/irgrid" bench "$scene" --exact --validate 131072 --width 512 --height 512 --spp 4 \
    --count 262144 --repeat 1 --build-repeat 0 "${extra[@]}" --json "out/exact-$name.json" \
    2>"out/exact-$name.log" | tee "out/exact-$name.txt" || status=1
  echo "$name: $(($(date +%s) - start)) s"
done
exit $status
