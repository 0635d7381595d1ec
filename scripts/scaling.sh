#!/usr/bin/env bash
# Build-time scaling: `irgrid build` of the grid and of Embree over builtin:hairball:N and
# builtin:sphere:N for N from 100K to 10M (one process per build, the median of REPEAT runs),
# with the build's memory peak (the largest phase's) and the process's peak memory. Writes
# out/scaling/results.jsonl, then the tables and the plot (scripts/plot_scaling.py:
# out/scaling/scaling.md, with each phase's time and memory peak per size and their exponents,
# and scaling.png; the plot needs matplotlib).
#   scripts/scaling.sh [SIZES...]     default: 100000 300000 1000000 3000000 10000000
# Environment: IRGRID_BIN (default build/irgrid), PYTHON (with matplotlib; default python3),
# REPEAT (default 3), FAMILIES (default "hairball sphere"), STRUCTURES (default
# "irregular embree").
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${IRGRID_BIN:-build/irgrid}
repeat=${REPEAT:-3}
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(100000 300000 1000000 3000000 10000000)
out=out/scaling
mkdir -p "$out"
results="$out/results.jsonl"
: >"$results"
for family in ${FAMILIES:-hairball sphere}; do
  for n in "${sizes[@]}"; do
    for structure in ${STRUCTURES:-irregular embree}; do
      for run in $(seq "$repeat"); do
        json="$out/$family-$n-$structure-$run.json"
        echo "scaling.sh: $family:$n $structure run $run" >&2
        if ! /usr/bin/time -f "%M %e" -o "$out/time.txt" \
          "$bin" build "builtin:$family:$n" --structure "$structure" --json "$json" >/dev/null; then
          echo "{\"family\":\"$family\",\"n\":$n,\"structure\":\"$structure\",\"failed\":true}" >>"$results"
          break
        fi
        read -r maxrss_kb wall_s <"$out/time.txt"
        python3 - "$json" "$family" "$n" "$structure" "$maxrss_kb" "$wall_s" >>"$results" <<'PY'
import json, sys
path, family, n, structure, maxrss_kb, wall_s = sys.argv[1:]
d = json.load(open(path))
print(json.dumps({"family": family, "n": int(n), "structure": structure,
                  "triangles": d["triangles"], "build_ms": d["build_ms"],
                  "phases_ms": d.get("build_phases_ms", {}),
                  "grid_bytes": d["memory_bytes"],
                  "references": d.get("counts", {}).get("references"),
                  "cells": d.get("counts", {}).get("cells"),
                  "peak_build_bytes": d.get("counts", {}).get("peak_build_bytes"),
                  "phase_peak_bytes": d.get("build_phase_peak_bytes", {}),
                  # irgrid build restarts the kernel's peak with each phase, so time's maximum
                  # resident size covers the last phase only: the command's own whole peak.
                  "max_rss_bytes": max(int(maxrss_kb) * 1024, d.get("process_peak_bytes", 0)),
                  "wall_s": float(wall_s)}))
PY
      done
    done
  done
done
"${PYTHON:-python3}" scripts/plot_scaling.py "$results" "$out" || echo "scaling.sh: no plot (matplotlib missing?)" >&2
