"""Table and plot of scripts/scaling.sh's results: build time and peak memory against triangle
count, grid and Embree, and the fitted exponent of time ~ N^k per family and structure.

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
