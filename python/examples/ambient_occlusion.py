"""Ambient occlusion of a scene, rendered from numpy with irgrid, written as a PNG.

    python python/examples/ambient_occlusion.py ../shared/scenes/crytek-sponza/sponza.obj.xz \
        --eye -10,2,0 --target 10,4,0 -o sponza_ao.png

Without --eye/--target the camera looks at the scene's box from an oblique direction.
Needs numpy and Pillow (pip install pillow) or matplotlib for the PNG.
"""

import argparse
import time

import numpy as np

import irgrid


def camera_rays(eye, target, width, height, fov_deg=60.0):
    """One pinhole ray per pixel centre, (height, width, 6), row 0 at the top."""
    eye, target = np.asarray(eye, np.float64), np.asarray(target, np.float64)
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = np.tan(np.radians(fov_deg) / 2)
    xs = ((np.arange(width) + 0.5) / width * 2 - 1) * half * width / height
    ys = (1 - (np.arange(height) + 0.5) / height * 2) * half
    directions = forward + xs[None, :, None] * right + ys[:, None, None] * up
    origins = np.broadcast_to(eye, directions.shape)
    return np.concatenate([origins, directions], axis=-1).astype(np.float32)


def ambient_occlusion(scene, rays, samples, radius, seed=0):
    """Fraction of `samples` cosine-weighted rays per primary hit that escape within radius."""
    hits = scene.cast_rays(rays)
    hit = hits["primitive_ids"] != irgrid.MISS
    normals = hits["primitive_normals"][hit]
    directions = rays[hit][:, 3:]
    facing = np.sign(np.einsum("ij,ij->i", normals, directions))[:, None]
    normals = -normals * np.where(facing == 0, 1, facing)        # towards the camera
    points = rays[hit][:, :3] + hits["t_hit"][hit][:, None] * directions
    points += normals * (1e-4 * radius * 10)
    rng = np.random.default_rng(seed)
    helper = np.where(np.abs(normals[:, :1]) > 0.9, [[0, 1, 0]], [[1, 0, 0]])
    tangent = np.cross(normals, helper)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    bitangent = np.cross(normals, tangent)
    visible = np.zeros(len(points))
    for _ in range(samples):
        u1, u2 = rng.random(len(points)), rng.random(len(points))
        r, phi = np.sqrt(u1), 2 * np.pi * u2
        d = (tangent * (r * np.cos(phi))[:, None] + bitangent * (r * np.sin(phi))[:, None]
             + normals * np.sqrt(1 - u1)[:, None])
        occlusion_rays = np.concatenate([points, d], axis=1).astype(np.float32)
        visible += ~scene.test_occlusions(occlusion_rays, tmax=radius)
    image = np.zeros(rays.shape[:-1])
    image[hit] = visible / samples
    return image


def write_png(path, image):
    pixels = (np.clip(image, 0, 1) * 255).astype(np.uint8)
    try:
        from PIL import Image
        Image.fromarray(pixels, mode="L").save(path)
    except ImportError:
        import matplotlib.pyplot as plt
        plt.imsave(path, pixels, cmap="gray", vmin=0, vmax=255)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="OBJ or PLY file (also .gz / .xz)")
    parser.add_argument("--eye"), parser.add_argument("--target")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("-o", "--output", default="ao.png")
    args = parser.parse_args()
    start = time.perf_counter()
    scene = irgrid.Scene.from_file(args.scene)
    print(f"{scene} built in {time.perf_counter() - start:.2f} s")
    lo, hi = scene.vertices.min(axis=0), scene.vertices.max(axis=0)
    diagonal = float(np.linalg.norm(hi - lo))
    eye = [float(x) for x in args.eye.split(",")] if args.eye else (lo + hi) / 2 + diagonal * \
        np.array([0.6, 0.4, 0.8])
    target = [float(x) for x in args.target.split(",")] if args.target else (lo + hi) / 2
    rays = camera_rays(eye, target, args.size, args.size)
    start = time.perf_counter()
    image = ambient_occlusion(scene, rays, args.samples, radius=0.1 * diagonal)
    rays_traced = rays.shape[0] * rays.shape[1] * (1 + args.samples)
    seconds = time.perf_counter() - start
    print(f"{rays_traced / 1e6:.1f} M rays in {seconds:.2f} s "
          f"({rays_traced / seconds / 1e6:.1f} MRays/s, shading in numpy included)")
    write_png(args.output, image)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
