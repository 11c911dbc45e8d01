"""A flat-faced part turned in its own file is decomposed in the frame of its own planes
(:func:`spark_bench.sim.decompose.flat_frame`): CoACD cuts along the coordinate planes only, and on a
cabinet carcass turned 7 degrees it ran past 600 s where the same part, turned back, takes a second."""

from __future__ import annotations

import numpy as np
import trimesh

from spark_bench.sim.decompose import DecomposeStats, decompose_many, flat_frame
from spark_bench.sim.options import CoacdParams

PARAMS = CoacdParams(mcts_iterations=20, mcts_nodes=8, resolution=500)


def _carcass() -> trimesh.Trimesh:
    """An open-fronted box of 2 cm panels (a cabinet body), axis-aligned."""
    panels = [((0.6, 0.4, 0.02), (0.0, 0.0, 0.39)), ((0.6, 0.4, 0.02), (0.0, 0.0, -0.39)),
              ((0.02, 0.4, 0.8), (0.29, 0.0, 0.0)), ((0.02, 0.4, 0.8), (-0.29, 0.0, 0.0)),
              ((0.6, 0.02, 0.8), (0.0, 0.19, 0.0))]
    boxes = [trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c))
             for e, c in panels]
    return trimesh.boolean.union(boxes)


def _turned_mesh(mesh: trimesh.Trimesh, degrees: float, axis=(0.0, 0.0, 1.0)) -> trimesh.Trimesh:
    turned = mesh.copy()
    turned.apply_transform(trimesh.transformations.rotation_matrix(np.radians(degrees), axis))
    return turned


def _volume(hulls) -> float:
    return sum(trimesh.convex.convex_hull(v).volume for v, _ in hulls)


def test_flat_frame_turns_only_flat_faced_parts_that_are_turned():
    box = trimesh.creation.box(extents=(0.3, 0.5, 0.7))
    assert flat_frame(box.vertices, box.faces) is None  # axis-aligned: decomposed as before
    turned = _turned_mesh(box, 7.0)
    rotation = flat_frame(turned.vertices, turned.faces)
    assert rotation is not None
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-9)
    assert np.linalg.det(rotation) > 0
    # in the frame found the part is axis-aligned again, its sides in the same order
    np.testing.assert_allclose(np.ptp(turned.vertices @ rotation.T, axis=0), (0.3, 0.5, 0.7), atol=1e-9)
    slight = _turned_mesh(box, 0.5)
    assert flat_frame(slight.vertices, slight.faces) is None  # within a degree of the axes: kept
    # a curved part has no planes to align (a tilted 64-sided cylinder: caps are a quarter of its area)
    cylinder = trimesh.creation.cylinder(radius=0.3, height=1.0, sections=64)
    cylinder.apply_transform(trimesh.transformations.rotation_matrix(0.3, (1.0, 0.0, 0.0)))
    assert flat_frame(cylinder.vertices, cylinder.faces) is None


def test_a_turned_carcass_gets_the_hulls_of_the_upright_one_turned():
    upright = _carcass()
    turned = _turned_mesh(upright, 7.0, axis=(0.0, 1.0, 0.0))
    stats = DecomposeStats()
    hulls_upright = decompose_many([(upright.vertices, upright.faces)], PARAMS, workers=1)[0]
    hulls_turned = decompose_many([(turned.vertices, turned.faces)], PARAMS, workers=1, stats=stats)[0]
    assert stats.turned == 1 and not stats.failed
    assert len(hulls_turned) == len(hulls_upright) >= 5  # one hull per panel at least
    # the turned part's hulls are the upright part's hulls, turned: in the part's own coordinates
    back = trimesh.transformations.rotation_matrix(np.radians(-7.0), (0.0, 1.0, 0.0))[:3, :3]
    np.testing.assert_allclose(_volume(hulls_turned), _volume(hulls_upright), rtol=1e-6)
    turned_back = np.concatenate([v for v, _ in hulls_turned]) @ back.T
    np.testing.assert_allclose(np.sort(turned_back, axis=0),
                               np.sort(np.concatenate([v for v, _ in hulls_upright]), axis=0), atol=1e-6)
    # and they fill the carcass, not its turned bounding box
    assert _volume(hulls_turned) < 1.2 * upright.volume
