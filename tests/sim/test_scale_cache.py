"""The conversion caches are keyed and stored in units of the object's size: a part or an object scaled
as a whole (a benchmark case's ground truth in the benchmark frame and in metres) is converted once."""

from __future__ import annotations

import os

import numpy as np
import pytest
import trimesh

os.environ.setdefault("MUJOCO_GL", "egl")

from helpers_assets import tiny_cabinet  # noqa: E402
from helpers_boxes import v_shape  # noqa: E402

from spark_bench.asset.ops import scale_asset  # noqa: E402
from spark_bench.sim.decompose import DecomposeStats, decompose_many  # noqa: E402
from spark_bench.sim.hulls import simplify, weld  # noqa: E402
from spark_bench.sim.mjcf import prepare  # noqa: E402
from spark_bench.sim.options import CoacdParams  # noqa: E402

PARAMS = CoacdParams(mcts_iterations=20, mcts_nodes=8, resolution=500)


def _normalized_points(hulls) -> np.ndarray:
    points = np.concatenate([v for v, _ in hulls])
    lo, hi = points.min(0), points.max(0)
    return np.sort((points - 0.5 * (lo + hi)) / np.max(hi - lo), axis=0)


def test_coacd_hulls_scale_with_the_mesh():
    # decompose_many feeds CoACD the normalized mesh (rounded to 2^-30), so a scaled copy's hulls are the
    # same hulls, scaled: what makes a scale-invariant key right
    vee = v_shape()
    small, large = (decompose_many([(vee.vertices * s, vee.faces)], PARAMS, cache=None, workers=1)[0]
                    for s in (0.013, 7.3))
    assert len(small) == len(large) >= 2
    np.testing.assert_allclose(_normalized_points(small), _normalized_points(large), atol=1e-6)


@pytest.mark.parametrize("factor", [0.8122090000000002, 3.7])
def test_a_scaled_copy_simplifies_and_welds_the_same(factor):
    # the decimation turns float noise into other choices (a real part and its copy scaled by 0.81:
    # 2498 and 2497 vertices), so it runs on rounded normalized coordinates
    rng = np.random.default_rng(0)
    sphere = trimesh.creation.icosphere(subdivisions=4)
    sphere.vertices = sphere.vertices * (1.0 + 0.05 * rng.random((len(sphere.vertices), 1))) + [0.3, -0.1, 0.2]
    a = simplify(sphere, 1000)
    b = simplify(trimesh.Trimesh(sphere.vertices * factor, sphere.faces, process=False), 1000)
    assert len(a.faces) < 1100 and a.faces.shape == b.faces.shape
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_allclose(b.vertices, a.vertices * factor, rtol=0, atol=1e-12)
    # welding: vertices within the tolerance merge, at any scale the same
    split = trimesh.Trimesh(np.concatenate([sphere.vertices, sphere.vertices[:10] + 1e-12]),
                            np.concatenate([sphere.faces, [[len(sphere.vertices) + k, 1, 2] for k in range(10)]]),
                            process=False)
    for scale in (1.0, factor):
        welded = weld(trimesh.Trimesh(split.vertices * scale, split.faces, process=False), 1e-7 * scale)
        assert len(welded.vertices) == len(sphere.vertices)


def test_scaled_part_is_a_cache_hit_with_scaled_hulls(tmp_path):
    vee = v_shape()
    first = decompose_many([(vee.vertices, vee.faces)], PARAMS, cache=tmp_path, workers=1)[0]
    stats = DecomposeStats()
    moved = vee.vertices * 3.7 + [1.0, -2.0, 0.5]
    second = decompose_many([(moved, vee.faces)], PARAMS, cache=tmp_path, workers=1, stats=stats)[0]
    assert stats.calls == 0 and stats.cache_hits == 1
    assert len(second) == len(first)
    for (a, _), (b, _) in zip(first, second):
        np.testing.assert_allclose(b, a * 3.7 + [1.0, -2.0, 0.5], atol=1e-9)


def test_scaled_object_reuses_link_shapes_and_contact_decisions(isolated_home):
    asset = tiny_cabinet()
    first = prepare(asset)
    objects = isolated_home / "coacd" / "objects"
    entries = sorted(objects.rglob("*.json"))
    assert len(entries) == 1
    scaled = prepare(scale_asset(asset, 2.5))
    assert scaled.size == pytest.approx(2.5 * first.size)
    assert scaled.report.cached_links == sum(1 for s in first.shapes.values() if s) - 1  # the given box: no cache
    assert sorted(objects.rglob("*.json")) == entries  # the contact resolution was read, not made again
    assert sorted(scaled.excluded) == sorted(first.excluded)
    for pair, depth in first.excluded.items():
        assert scaled.excluded[pair] == pytest.approx(2.5 * depth)
    assert [(c.joint, c.geom) for c in scaled.relief] == [(c.joint, c.geom) for c in first.relief]
    for name, shapes in first.shapes.items():
        for a, b in zip(shapes, scaled.shapes[name]):
            if a.kind == "mesh":
                np.testing.assert_allclose(b.vertices, 2.5 * a.vertices, atol=1e-9)
            else:
                np.testing.assert_allclose(b.size, 2.5 * a.size, atol=1e-12)
                np.testing.assert_allclose(b.origin[:3, 3], 2.5 * a.origin[:3, 3], atol=1e-12)
