#!/usr/bin/env bash
# Compares two irgrid binaries (e.g. a copy of build/irgrid made before a change, and the new
# build/irgrid) on one scene, in the two ways docs/benchmarks.md uses on a noisy machine:
#   time          alternating rounds of `irgrid --threads T bench` (A, B, A, B, ...); per view and
#                 ray kind the best MRays/s of each binary and B / A, and whether both did the same
#                 work per ray (cells and triangle tests: equal means the same grid was built)
#   instructions  `irgrid --threads 1 build` under callgrind: instructions of the whole build and
#                 of its main phases, deterministic (independent of the machine's load)
# Usage: bash scripts/ab-compare.sh time|instructions BINARY_A BINARY_B SCENE [ROUNDS] [THREADS]
# Needs python3; `instructions` also needs valgrind (apt install valgrind).
set -euo pipefail
mode=${1:-}
a=${2:-}
b=${3:-}
scene=${4:-}
rounds=${5:-3}
threads=${6:-1}
usage="usage: bash scripts/ab-compare.sh time|instructions BINARY_A BINARY_B SCENE [ROUNDS] [THREADS]"
[ -n "$scene" ] || { echo "$usage" >&2; exit 2; }
for binary in "$a" "$b"; do
  [ -x "$binary" ] || { echo "ab-compare: '$binary' is not an executable" >&2; exit 2; }
done
command -v python3 >/dev/null || { echo "ab-compare: needs python3" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
binary_of() { if [ "$1" = A ]; then echo "$a"; else echo "$b"; fi; }

case "$mode" in
time)
  for round in $(seq "$rounds"); do
    for side in A B; do
      echo "ab-compare: round $round/$rounds, $side" >&2
      "$(binary_of "$side")" --threads "$threads" bench "$scene" --width 384 --height 384 --spp 1 --repeat 5 \
        --validate 1000 --json "$work/$side-$round.json" >/dev/null 2>"$work/$side-$round.log" ||
        { cat "$work/$side-$round.log" >&2; exit 1; }
    done
  done
  python3 - "$work" "$rounds" <<'EOF'
import json, sys
work, rounds = sys.argv[1], int(sys.argv[2])
best, work_per_ray, builds = {}, {}, {"A": [], "B": []}
for side in ("A", "B"):
    for r in range(1, rounds + 1):
        report = json.load(open(f"{work}/{side}-{r}.json"))
        builds[side].append(report["build_ms"])
        for run in report["runs"]:
            if run["mismatches"]:
                sys.exit(f"ab-compare: {side} has {run['mismatches']} mismatches in {run['kind']}")
            key = (run["view"], run["kind"])
            best.setdefault(key, {}).setdefault(side, 0.0)
            best[key][side] = max(best[key][side], run["mrays_per_s"])
            work_per_ray.setdefault(key, {})[side] = (run.get("cells_per_ray"), run.get("tests_per_ray"))
print(f"{'view':>4} {'kind':<8} {'A MRays/s':>10} {'B MRays/s':>10} {'B / A':>6}  same work per ray")
for (view, kind), value in sorted(best.items()):
    same = work_per_ray[(view, kind)]["A"] == work_per_ray[(view, kind)]["B"]
    print(f"{view:>4} {kind:<8} {value['A']:>10.2f} {value['B']:>10.2f} {value['B'] / value['A']:>6.3f}  "
          f"{'yes' if same else 'no'}")
print(f"build ms, best of {rounds}: A {min(builds['A']):.1f}, B {min(builds['B']):.1f}")
EOF
  ;;
instructions)
  command -v valgrind >/dev/null || { echo "ab-compare: needs valgrind" >&2; exit 2; }
  for side in A B; do
    echo "ab-compare: callgrind, $side (a few minutes)" >&2
    valgrind --tool=callgrind --callgrind-out-file="$work/$side.out" "$(binary_of "$side")" \
      --threads 1 build "$scene" >/dev/null 2>"$work/$side.log" ||
      { tail -5 "$work/$side.log" >&2; exit 1; }
    callgrind_annotate --inclusive=yes "$work/$side.out" >"$work/$side.txt" 2>/dev/null
  done
  python3 - "$work" <<'EOF'
import re, sys
work = sys.argv[1]
phases = [("build", "irgrid::build_grid<"), ("octree levels", "irgrid::build_octree_levels<"),
          ("merge", "irgrid::merge_cells<"), ("expansion", "irgrid::expand_cells<")]
def counts(side):
    found = {}
    for line in open(f"{work}/{side}.txt"):
        for name, symbol in phases:
            if symbol in line and name not in found:
                found[name] = int(re.match(r"\s*([\d,]+)", line).group(1).replace(",", ""))
    return found
a, b = counts("A"), counts("B")
print(f"{'instructions':<14} {'A':>16} {'B':>16} {'B / A':>6}")
for name, _ in phases:
    if name in a and name in b:
        print(f"{name:<14} {a[name]:>16,} {b[name]:>16,} {b[name] / a[name]:>6.3f}")
EOF
  ;;
*)
  echo "$usage" >&2
  exit 2
  ;;
esac
