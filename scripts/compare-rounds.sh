#!/usr/bin/env bash
# Repeats one `irgrid bench --compare` run in ROUNDS separate processes and summarises, per view
# and ray kind, each contender's MRays/s ratio to the first: lowest, median and highest over the
# rounds. On a shared machine whose speed drifts by 10-30% within minutes, one run's ratio near
# 1 says little; the median over rounds and the count of rounds the first contender led are what
# docs/benchmarks.md quotes for the traversal target. Every round validates its rays
# (--validate 2000) and the summary fails on any mismatch.
# Usage: bash scripts/compare-rounds.sh SCENE [ROUNDS] [STRUCTURES] [-- more bench options]
#   defaults: 5 rounds, irregular,embree; 512 x 512 primary rays, 1 secondary sample per hit,
#   median of 3 traces per round. Writes out/<scene>-rounds-<k>.json. Needs python3.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-}
rounds=${2:-5}
structures=${3:-irregular,embree}
[ -n "$scene" ] || {
  echo "usage: bash scripts/compare-rounds.sh SCENE [ROUNDS] [STRUCTURES] [-- bench options]" >&2
  exit 2
}
shift $(($# < 3 ? $# : 3))
[ "${1:-}" != "--" ] || shift
command -v python3 >/dev/null || { echo "compare-rounds: needs python3" >&2; exit 2; }
build_dir=${IRGRID_BUILD_DIR:-build}
name=$(basename "$(dirname "$scene")")
[ "$name" != "." ] || name=$(basename "$scene")
mkdir -p out
files=()
for round in $(seq "$rounds"); do
  file="out/$name-rounds-$round.json"
  echo "compare-rounds: round $round of $rounds ($structures on $scene)" >&2
  "$build_dir/irgrid" bench "$scene" --compare "$structures" --width 512 --height 512 --spp 1 \
    --repeat 3 --build-repeat 0 --validate 2000 --json "$file" "$@" >/dev/null
  files+=("$file")
done
python3 - "${files[@]}" <<'EOF'
import json, statistics, sys

rounds = [json.load(open(path)) for path in sys.argv[1:]]
names = [f"{c['structure']}@{c['backend']}" for c in rounds[0]["compare"]]
mismatches = sum(r["mismatches"] for d in rounds for c in d["compare"] for r in c["runs"])
print(f"{rounds[0]['scene']}: {len(rounds)} rounds, ratio to {names[0]} (lowest / median / highest)")
print(f"{'view':>4}  {'kind':<9}" + "".join(f"{n:>30}" for n in names[1:]) + "   rounds led by " + names[0])
for i, run in enumerate(rounds[0]["compare"][0]["runs"]):
    cells, led = [], None
    for k in range(1, len(names)):
        ratios = sorted(d["compare"][k]["runs"][i]["mrays_per_s"] / d["compare"][0]["runs"][i]["mrays_per_s"]
                        for d in rounds)
        cells.append(f"{ratios[0]:.2f} / {statistics.median(ratios):.2f} / {ratios[-1]:.2f}")
        wins = sum(1 for r in ratios if r < 1)
        led = wins if led is None else min(led, wins)
    print(f"{run['view']:>4}  {run['kind']:<9}" + "".join(f"{c:>30}" for c in cells) + f"   {led} of {len(rounds)}")
builds = {n: statistics.median(d["compare"][k]["build_ms"] for d in rounds) for k, n in enumerate(names)}
print("build ms, median: " + ", ".join(f"{n} {ms:.1f}" for n, ms in builds.items()))
print(f"mismatches: {mismatches}")
sys.exit(1 if mismatches else 0)
EOF
