"""Plots `irgrid bench --json` results: MRays/s per structure and ray kind, as a PNG.

    irgrid bench SCENE --compare irregular,embree,two-level,uniform --json bench.json
    python python/examples/plot_bench.py bench.json -o bench.png

Needs matplotlib. Several JSON files (several scenes) give one panel each.
"""

import argparse
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def panel(axis, result):
    structures = result.get("compare", [result])
    labels = [f'{run["kind"]} v{run["view"]}' for run in structures[0]["runs"]]
    width = 0.8 / len(structures)
    x = np.arange(len(labels))
    for k, structure in enumerate(structures):
        speeds = [run["mrays_per_s"] for run in structure["runs"]]
        axis.bar(x + k * width, speeds, width,
                 label=f'{structure["structure"]}@{structure["backend"]}')
    axis.set_xticks(x + width * (len(structures) - 1) / 2, labels, rotation=45, ha="right")
    axis.set_ylabel("MRays/s")
    machine = result.get("machine", {})
    axis.set_title(f'{result["scene"]} ({result["triangles"]:,} triangles) — '
                   f'{machine.get("cpu", "?")}, {machine.get("threads", "?")} threads')
    axis.legend(fontsize="small")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="+")
    parser.add_argument("-o", "--output", default="bench.png")
    args = parser.parse_args()
    results = [json.load(open(path)) for path in args.json]
    figure, axes = plt.subplots(len(results), 1, figsize=(10, 4.5 * len(results)), squeeze=False)
    for axis, result in zip(axes[:, 0], results):
        panel(axis, result)
    figure.tight_layout()
    figure.savefig(args.output, dpi=110)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
