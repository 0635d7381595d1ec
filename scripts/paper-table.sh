#!/usr/bin/env bash
# The paper's table (Pérard-Gayot et al. 2017, Table 1) for Crytek Sponza, Conference and Crown:
# `irgrid bench --paper-table` per scene (primary, ao and random rays, every view, validated),
# the rows gathered under one header into out/paper-table.md; each scene's JSON and log go to
# out/<scene>-paper.json|log. A shell loop over bench rather than a program over the JSON: it
# needs nothing but the irgrid binary, so it runs as it is in the GPU bundle.
# Usage: bash scripts/paper-table.sh [STRUCTURES [BENCH OPTION...]]
#   STRUCTURES: --compare of bench (default irregular,cwbvh; on a GPU irregular@cuda,cwbvh@cuda)
#   e.g. bash scripts/paper-table.sh irregular@cuda,cwbvh@cuda --repeat 5 --validate 20000
# Environment: IRGRID_BIN (default ${IRGRID_BUILD_DIR:-build}/irgrid), IRGRID_SCENES (default
# ../shared/scenes), OUT (default out).
set -euo pipefail
cd "$(dirname "$0")/.."
irgrid=${IRGRID_BIN:-${IRGRID_BUILD_DIR:-build}/irgrid}
scenes_dir=${IRGRID_SCENES:-../shared/scenes}
out=${OUT:-out}
structures=${1:-irregular,cwbvh}
shift || true
[ -x "$irgrid" ] || { echo "paper-table.sh: no irgrid binary at $irgrid" >&2; exit 2; }
mkdir -p "$out"
table="$out/paper-table.md"
: >"$table"
status=0
for scene in crytek-sponza/sponza.obj.xz conference/conference.obj.xz crown/crown.obj.xz; do
  name=$(dirname "$scene")
  [ -f "$scenes_dir/$scene" ] || { echo "paper-table.sh: missing $scenes_dir/$scene" >&2; exit 2; }
  "$irgrid" bench "$scenes_dir/$scene" --paper-table --compare "$structures" \
    --json "$out/$name-paper.json" "$@" >"$out/$name-paper.txt" 2>"$out/$name-paper.log" ||
    status=$?
  # The table's rows; its two header lines only once.
  if [ -s "$table" ]; then
    grep '^| ' "$out/$name-paper.txt" | grep -v -e '^| scene |' -e '^| --- |' >>"$table" || true
  else
    grep '^| ' "$out/$name-paper.txt" >>"$table" || true
  fi
done
cat "$table"
[ "$status" -eq 0 ] || echo "paper-table.sh: a bench run failed (exit $status); see $out/*-paper.log" >&2
exit "$status"
