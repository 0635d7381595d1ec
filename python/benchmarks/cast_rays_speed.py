"""Python cast_rays against the C++ trace on the same rays, and optionally Open3D and
trimesh+embreex: a benchmark, not a test.

    python python/benchmarks/cast_rays_speed.py SCENE [--rays 1000000] [--cli build/irgrid]
        [--others]

The C++ figures are `irgrid bench SCENE --rays FILE --hit-arrays` (medians of 5 traces of the
same rays, validated): the trace into Hit records (triangle, t, u, v: no normals), and the trace
into the same five arrays cast_rays returns (normals included, rows read in place); the Python
figures are the median of 5 calls. The two are timed in turn --rounds
times; each engine's figure is the median over the rounds. --others also times Open3D's
RaycastingScene.cast_rays and trimesh's embreex intersector when they are installed (put them in
a throwaway venv: pip install open3d embreex trimesh). Every engine's hits are compared with
irgrid's before a speed is printed.
"""

import argparse
import json
import os
import platform
import subprocess
import tempfile
import time

import numpy as np

import irgrid


def cpu_name():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def random_rays(vertices, count, seed=0):
    """Origins in the scene box, directions uniform on the sphere (the benchmarks' random kind)."""
    rng = np.random.default_rng(seed)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    origins = rng.uniform(lo, hi, (count, 3))
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.concatenate([origins, directions], axis=1).astype(np.float32)


def median_seconds(call, repeat=5):
    call()  # warm-up
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def cli_mrays(cli, scene_path, rays):
    """MRays/s of the C++ trace into Hit records, and into cast_rays's arrays."""
    with tempfile.TemporaryDirectory() as folder:
        ray_file, json_file = os.path.join(folder, "rays.bin"), os.path.join(folder, "b.json")
        records = np.zeros((len(rays), 8), np.float32)
        records[:, 0:3], records[:, 4:7], records[:, 7] = rays[:, :3], rays[:, 3:], np.inf
        records.tofile(ray_file)
        subprocess.run([cli, "bench", scene_path, "--rays", ray_file, "--repeat", "5",
                        "--validate", "10000", "--hit-arrays", "--json", json_file], check=True,
                       stdout=subprocess.DEVNULL)
        run = json.load(open(json_file))["runs"][0]
        if run["mismatches"]:
            raise SystemExit(f"irgrid bench: {run['mismatches']} mismatches")
        return run["mrays_per_s"], run["arrays_mrays_per_s"]


def agreement(a_t, b_t):
    both = np.isfinite(a_t) & np.isfinite(b_t)
    same_hit = np.isfinite(a_t) == np.isfinite(b_t)
    close = np.isclose(a_t[both], b_t[both], rtol=1e-4, atol=1e-5)
    return float(same_hit.mean()), float(close.mean()) if both.any() else 1.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--rays", type=int, default=1_000_000)
    parser.add_argument("--cli", default="build/irgrid")
    parser.add_argument("--others", action="store_true")
    parser.add_argument("--rounds", type=int, default=3,
                        help="C++ and Python timed in turn this many times (the VM's speed drifts "
                             "between runs: the ratio of each round, and the median, are printed)")
    args = parser.parse_args()
    vertices, triangles = irgrid.load(args.scene)
    scene = irgrid.Scene(vertices, triangles, backend="cpu")
    rays = random_rays(vertices, args.rays)
    reference = scene.cast_rays(rays)["t_hit"]
    cpp, cpp_arrays, python = [], [], []
    for _ in range(args.rounds):
        records, arrays = cli_mrays(args.cli, args.scene, rays)
        cpp.append(records)
        cpp_arrays.append(arrays)
        python.append(args.rays / median_seconds(lambda: scene.cast_rays(rays)) / 1e6)

    def ratio_note(baseline):
        ratios = [p / c for p, c in zip(python, baseline)]
        rounds = ", ".join(f"{r:.2f}" for r in ratios)
        return f"Python / this per round {rounds}, median {np.median(ratios):.2f}"

    rows = [("irgrid C++ trace into Hit records (no normals)", float(np.median(cpp)),
             ratio_note(cpp)),
            ("irgrid C++ trace into cast_rays's arrays", float(np.median(cpp_arrays)),
             ratio_note(cpp_arrays)),
            ("irgrid Python cast_rays", float(np.median(python)), "same rays")]
    if args.others:
        try:
            import open3d as o3d
            o3d_scene = o3d.t.geometry.RaycastingScene()
            o3d_scene.add_triangles(vertices, triangles)
            o3d_rays = o3d.core.Tensor(rays)
            t = o3d_scene.cast_rays(o3d_rays)["t_hit"].numpy()
            hit_agree, t_agree = agreement(reference, t)
            seconds = median_seconds(lambda: o3d_scene.cast_rays(o3d_rays))
            rows.append((f"Open3D {o3d.__version__} RaycastingScene.cast_rays",
                         args.rays / seconds / 1e6,
                         f"hit/miss agree {hit_agree:.4%}, t agree {t_agree:.4%}"))
        except ImportError as e:
            print(f"Open3D not measured: {e}")
        try:
            import trimesh
            from trimesh.ray.ray_pyembree import RayMeshIntersector
            mesh = trimesh.Trimesh(vertices, triangles, process=False)
            intersector = RayMeshIntersector(mesh)
            first = intersector.intersects_first(rays[:, :3], rays[:, 3:])
            hit_agree = float(((first >= 0) == np.isfinite(reference)).mean())
            seconds = median_seconds(lambda: intersector.intersects_first(rays[:, :3], rays[:, 3:]))
            rows.append((f"trimesh {trimesh.__version__} + embreex intersects_first",
                         args.rays / seconds / 1e6, f"hit/miss agree {hit_agree:.4%}"))
        except ImportError as e:
            print(f"trimesh+embreex not measured: {e}")
    print(f"{args.scene}: {len(triangles):,} triangles, {args.rays:,} random rays, "
          f"{cpu_name()}, {os.cpu_count()} threads")
    for name, mrays, note in rows:
        print(f"  {name:<55} {mrays:8.2f} MRays/s  {note}")


if __name__ == "__main__":
    main()
