#!/usr/bin/env bash
# The CPU figures of docs/benchmarks.md: for Crytek Sponza, Conference, Crown and the hostile
# built-ins overlap:30000 and stack:30000 (docs/robustness.md), the validated run
# of the irregular grid (all views and ray kinds, 20,000 rays checked per run) and the comparison
# with Embree (one ray at a time and in 8-ray packets) and the uniform/two-level grids on the same
# rays. Writes out/<scene>-*.json|txt.
# Usage: bash scripts/bench-cpu-scenes.sh [SCENE...]   (default: the five above)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${IRGRID_BUILD_DIR:-build}
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(../shared/scenes/crytek-sponza/sponza.obj.xz
                                   ../shared/scenes/conference/conference.obj.xz
                                   ../shared/scenes/crown/crown.obj.xz
                                   builtin:overlap:30000 builtin:stack:30000)
mkdir -p out
for scene in "${scenes[@]}"; do
  name=$(basename "$(dirname "$scene")")
  [[ $scene == builtin:* ]] && name=${scene#builtin:} && name=${name//:/-}
  "$build_dir/irgrid" bench "$scene" --validate 20000 --repeat 1 \
    --json "out/$name-validate.json" 2>"out/$name-validate.log" | tee "out/$name-validate.txt"
  "$build_dir/irgrid" bench "$scene" --compare irregular,embree,embree-packets,two-level,uniform \
    --width 512 --height 512 --spp 1 --repeat 3 --validate 20000 \
    --json "out/$name-compare.json" 2>"out/$name-compare.log" | tee "out/$name-compare.txt"
done
