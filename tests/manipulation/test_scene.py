"""The opening task's scene (:mod:`spark_bench.manipulation.scene`, :mod:`spark_bench.manipulation.task`): a
scene built for a grasp its caller planned is the scene it plans itself, and the part's samples are memoized
per asset and never served stale."""

from __future__ import annotations

import numpy as np

from spark_bench.envs.assets import load_asset
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.manipulation.scene import plan_grasp
from spark_bench.manipulation.task import build_scene


def test_a_scene_built_for_a_planned_grasp_is_the_scene_built_with_its_own_plan():
    """``build_scene(..., grasp=)`` takes the caller's plan instead of planning one (the opening score's judge
    plans once per joint): the same grasp, the same compiled scene."""
    asset = procedural_cabinet(0)
    planned = plan_grasp(asset, "joint_1")
    given = build_scene(asset, "revolute", "joint_1", visuals=False, grasp=planned)
    own = build_scene(procedural_cabinet(0), "revolute", "joint_1", visuals=False)
    assert given.grasp is planned and own.grasp is not planned
    for name in ("point", "outward", "long_axis"):
        np.testing.assert_array_equal(getattr(given.grasp, name), getattr(own.grasp, name))
    assert (given.grasp.source, given.grasp.reason, given.end_effector) == (own.grasp.source, own.grasp.reason,
                                                                           own.end_effector)
    np.testing.assert_array_equal(given.grasp_local, own.grasp_local)
    np.testing.assert_array_equal(given.rest_qpos, own.rest_qpos)
    assert given.free_fraction == own.free_fraction and given.model.nbody == own.model.nbody


def test_part_points_are_memoized_per_asset_and_not_served_stale():
    """The part's samples are computed once per asset and joint (read-only, shared), a copy of the asset
    gets the same points, and an asset whose part moved in place gets fresh ones."""
    from spark_bench.manipulation.handle_search import N_SAMPLES
    from spark_bench.manipulation.scene import part_points

    asset = load_asset("procedural:0")[0].copy()
    door = next(j for j in asset.joints.values() if j.type == "revolute")
    points = part_points(asset, door.name)
    assert points.shape == (N_SAMPLES, 3) and not points.flags.writeable
    assert part_points(asset, door.name) is points
    copy = load_asset("procedural:0")[0].copy()
    assert np.allclose(part_points(copy, door.name), points, atol=1e-9)
    link = next(name for name in asset.part_of_joint(door.name) if asset.links[name].visuals)
    for visual in asset.links[link].visuals:
        visual.mesh.vertices = np.asarray(visual.mesh.vertices) + np.array([0.0, 0.0, 0.1])
    moved = part_points(asset, door.name)
    assert moved is not points and not np.allclose(moved, points, atol=1e-3)
