"""irgrid.dask on a local two-worker cluster: same answers as one Scene, one build per worker."""

import numpy as np
import pytest

import irgrid

da = pytest.importorskip("dask.array")
distributed = pytest.importorskip("distributed")
import irgrid.dask  # noqa: E402  (needs dask: skips cleanly without it)


def test_cast_rays_on_a_two_worker_cluster():
    from conftest import cube
    vertices, triangles = cube()
    rng = np.random.default_rng(2)
    rays = np.concatenate([rng.uniform(-3, 3, (4000, 3)), rng.normal(size=(4000, 3))], axis=1)
    rays = rays.astype(np.float32)
    expected = irgrid.Scene(vertices, triangles).cast_rays(rays)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        hits = irgrid.dask.cast_rays(vertices, triangles, da.from_array(rays, chunks=(250, 6)))
        assert isinstance(hits["t_hit"], da.Array)
        computed = {key: value.compute() for key, value in hits.items()}
        for key in expected:
            assert np.array_equal(computed[key], expected[key]), key
        builds = client.run(irgrid.dask.scenes_built)
        assert len(builds) == 2
        # 16 chunks over 2 workers: each worker that took chunks built its Scene once.
        assert all(count <= 1 for count in builds.values()) and sum(builds.values()) >= 1
