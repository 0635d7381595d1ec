"""Tables and plot of scripts/scaling.sh's results: build time and peak memory against triangle
count, grid and Embree, and the fitted exponent of time ~ N^k per family and structure; then,
per family, each of the grid's build phases (time and the build's memory peak within it) per
size with its own exponent, and the references, against which the work of most phases grows.

    python3 scripts/plot_scaling.py out/scaling/results.jsonl out/scaling
"""
import collections
import json
import math
import statistics
import sys


def load(path):
    runs = collections.defaultdict(list)
    failed = set()
    for line in open(path):
        r = json.loads(line)
        key = (r["family"], r["structure"], r["n"])
        if r.get("failed"):
            failed.add(key)
        else:
            runs[key].append(r)
    return runs, failed


def exponent(points):
    """Least-squares slope of log(time) against log(triangles)."""
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = statistics.fmean(xs), statistics.fmean(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def exponent_text(points):
    """exponent() to two places, or blank where a value is missing or not positive."""
    if len(points) < 2 or any(v is None or v <= 0 for _, v in points):
        return ""
    return f"{exponent(points):.2f}"


# The build's phases in the order they run (irgrid build); others follow in name order.
PHASE_ORDER = ["top grid", "top-level references", "octree levels", "empty space",
               "cells and references", "merge", "voxel map", "expansion", "compress"]


def median_run(rs):
    """The run whose build time is the median (its phases and peaks go together)."""
    return sorted(rs, key=lambda r: r["build_ms"])[len(rs) // 2]


def phase_tables(runs):
    """Per family, the grid's phases per size: ms and the build's peak MiB within each phase,
    with exponents against triangles, then the references and build time per reference."""
    lines = []
    families = sorted({f for f, s, _ in runs if s == "irregular"})
    for family in families:
        sizes = sorted(n for f, s, n in runs if f == family and s == "irregular")
        picked = [median_run(runs[(family, "irregular", n)]) for n in sizes]
        tris = [r["triangles"] for r in picked]
        names = {p for r in picked for p in r["phases_ms"]}
        phases = [p for p in PHASE_ORDER if p in names] + sorted(names - set(PHASE_ORDER))
        head = "| | " + " | ".join(f"{t:,}" for t in tris) + " | exponent |"
        rule = "| --- |" + " ---: |" * (len(tris) + 1)

        def row(label, values, fmt, small=None):
            # `small` for values below 10 (a decimal, so that short phases still show).
            def text(v):
                return "" if v is None else (fmt if v >= 10 or not small else small).format(v)
            cells = " | ".join(text(v) for v in values)
            return f"| {label} | {cells} | {exponent_text(list(zip(tris, values)))} |"

        lines += [f"{family}, the grid's build per phase: ms (median run)", "", head, rule,
                  row("whole build", [r["build_ms"] for r in picked], "{:,.0f}", "{:.1f}")]
        lines += [row(p, [r["phases_ms"].get(p) for r in picked], "{:,.0f}", "{:.1f}")
                  for p in phases]
        refs = [r.get("references") for r in picked]
        if all(refs):
            lines += [row("references per triangle", [x / t for x, t in zip(refs, tris)], "{:.2f}"),
                      row("build ns per reference",
                          [r["build_ms"] * 1e6 / x for r, x in zip(picked, refs)], "{:,.0f}")]
        lines += ["", f"{family}, the build's memory peak within each phase: MiB (median run)", "",
                  head, rule,
                  row("grid", [r["grid_bytes"] / 2**20 for r in picked], "{:,.1f}")]
        lines += [row(p, [(r.get("phase_peak_bytes") or {}).get(p, 0) / 2**20 or None
                          for r in picked], "{:,.1f}") for p in phases]
        if all(refs):
            times = list(zip(refs, [r["build_ms"] for r in picked]))
            lines += ["", f"- {family}, irregular: time ~ references^{exponent(times):.2f}"]
        lines.append("")
    return lines


def main(results, out_dir):
    runs, failed = load(results)
    rows, series = [], collections.defaultdict(list)
    for key in sorted(set(runs) | failed):
        family, structure, n = key
        if key in failed:
            rows.append(f"| {family} | {n:,} | {structure} | failed | | | | |")
            continue
        rs = runs[key]
        ms = statistics.median(r["build_ms"] for r in rs)
        tris = rs[0]["triangles"]
        rss = max(r["max_rss_bytes"] for r in rs) / 2**20
        grid = rs[0]["grid_bytes"] / 2**20
        phases = rs[0]["phases_ms"]
        top = sorted(phases.items(), key=lambda p: -p[1])[:3]
        # The build's own buffers at their peak, and the phase that made it (grids only).
        peaks = rs[0].get("phase_peak_bytes") or {}
        build_peak = ""
        if peaks:
            phase, most = max(peaks.items(), key=lambda p: p[1])
            build_peak = f"{most / 2**20:,.0f} ({most / rs[0]['grid_bytes']:.2f}×, {phase})"
        rows.append(f"| {family} | {tris:,} | {structure} | {ms:,.0f} | {grid:,.0f} | {build_peak} | "
                    f"{rss:,.0f} | " + ", ".join(f"{k} {v:,.0f}" for k, v in top) + " |")
        series[(family, structure)].append((tris, ms))
    lines = ["| scene | triangles | structure | build ms (median) | structure MiB | build peak MiB (× structure, phase) | process peak MiB | largest phases (ms, one run) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"] + rows + [""]
    for (family, structure), points in sorted(series.items()):
        if len(points) >= 2:
            lines.append(f"- {family}, {structure}: time ~ N^{exponent(points):.2f} "
                         f"over {points[0][0]:,}–{points[-1][0]:,} triangles")
    lines += [""] + phase_tables(runs)
    text = "\n".join(lines) + "\n"
    open(f"{out_dir}/scaling.md", "w").write(text)
    print(text)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (family, structure), points in sorted(series.items()):
        xs, ys = zip(*sorted(points))
        ax.loglog(xs, ys, marker="o", linestyle="-" if structure == "irregular" else "--",
                  label=f"{structure} ({family})")
    ax.set_xlabel("triangles")
    ax.set_ylabel("build time (ms, median)")
    ax.set_title("irgrid build: irregular grid vs Embree")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(f"{out_dir}/scaling.png", dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
