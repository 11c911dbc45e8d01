"""Forward kinematics, configurations and whole-asset operations of ArticulatedAsset."""

from __future__ import annotations

import numpy as np
import pytest
from helpers_assets import tiny_cabinet

from spark_bench.asset.ops import (
    denormalization,
    normalize_asset,
    scale_asset,
    similarity_asset,
    translate_asset,
)
from spark_bench.asset.transforms import axis_angle_matrix, matrix_to_rpy, origin_to_matrix, rpy_to_matrix


def test_rpy_matches_urdf_convention_and_inverts():
    # URDF: roll about X, then pitch about Y, then yaw about Z, all fixed axes: R = Rz Ry Rx
    r, p, y = 0.3, -0.7, 1.2
    expected = axis_angle_matrix([0, 0, 1], y) @ axis_angle_matrix([0, 1, 0], p) @ axis_angle_matrix([1, 0, 0], r)
    np.testing.assert_allclose(rpy_to_matrix([r, p, y]), expected, atol=1e-12)
    np.testing.assert_allclose(matrix_to_rpy(expected), [r, p, y], atol=1e-12)


def test_partnet_root_rotation_maps_mesh_frame_to_world():
    # meshes are Y-up with the front towards +Z; after the root joint the world is Z-up, front -X
    root = origin_to_matrix(rpy=(1.570796, 0, -1.570796))[:3, :3]
    np.testing.assert_allclose(root @ [0, 1, 0], [0, 0, 1], atol=1e-6)
    np.testing.assert_allclose(root @ [0, 0, 1], [-1, 0, 0], atol=1e-6)


def test_fk_prismatic_and_revolute():
    asset = tiny_cabinet()
    assert asset.root == "base"
    poses = asset.link_poses({"joint_drawer": 0.25, "joint_door": np.pi / 2})
    np.testing.assert_allclose(poses["drawer"][:3, 3], [-0.25, 0, 0], atol=1e-12)
    # the door's far edge (y = 0.28 at rest) swings about the vertical axis at x=-0.22, y=0
    rest_edge = np.array([-0.22, 0.28, 0.25])
    moved = poses["door"][:3, :3] @ (rest_edge - [-0.22, 0, 0]) + poses["door"][:3, 3]
    np.testing.assert_allclose(moved, [-0.22 - 0.28, 0.0, 0.25], atol=1e-12)


def test_configurations_and_joint_frames():
    asset = tiny_cabinet()
    assert asset.rest_configuration() == {"joint_drawer": 0.0, "joint_door": 0.0}
    assert asset.open_configuration() == {"joint_drawer": 0.3, "joint_door": pytest.approx(np.pi / 2)}
    point, direction = asset.joint_frames()["joint_door"]
    # FK composes 4x4 products of magnitude ~1: a few ulps (~1e-16) each; 1e-12 leaves a wide margin,
    # and an absolute tolerance is needed for the zero components (rtol alone would demand exact zeros)
    np.testing.assert_allclose(point, [-0.22, 0, 0], atol=1e-12)
    np.testing.assert_allclose(direction, [0, 0, 1], atol=1e-12)
    with pytest.raises(KeyError, match="no joint named"):
        asset.link_poses({"nope": 1.0})


def test_normalize_in_place_gives_the_copy_s_result_on_the_asset_itself():
    asset, other = tiny_cabinet(), tiny_cabinet()
    copied, center, scale = normalize_asset(other)
    np.testing.assert_array_equal(other.mesh().vertices, tiny_cabinet().mesh().vertices)  # input untouched
    same, center2, scale2 = normalize_asset(asset, copy=False)
    assert same is asset
    # the same operations on the same numbers, in the same order: equal to rounding
    np.testing.assert_allclose(center2, center, atol=1e-15)
    assert scale2 == pytest.approx(scale, rel=1e-15)
    np.testing.assert_allclose(asset.mesh().vertices, copied.mesh().vertices, atol=1e-12)
    np.testing.assert_allclose(asset.joints["joint_door"].origin, copied.joints["joint_door"].origin, atol=1e-12)


def test_moving_links_and_parts():
    asset = tiny_cabinet()
    assert asset.moving_links("joint_door") == ["door"]
    assert asset.part_of_joint("joint_drawer") == ["drawer"]
    assert [j.name for j in asset.topological_joints()][0] == "root"


def test_normalize_fits_unit_box_and_preserves_kinematics():
    asset = tiny_cabinet()
    normalized, center, scale = normalize_asset(asset)
    # tolerances below: the normalization and the expected values are two computations of the same
    # similarity on coordinates of magnitude <= 2, each a few float64 roundings (~1e-16): 1e-12 is safe
    bounds = normalized.bounds()
    np.testing.assert_allclose(bounds.mean(0), 0, atol=1e-12)
    assert (bounds[1] - bounds[0]).max() == pytest.approx(2.0)
    # the open state maps through the same similarity transform
    q = asset.open_configuration()
    q_norm = normalized.open_configuration()
    assert q_norm["joint_drawer"] == pytest.approx(q["joint_drawer"] * scale)
    np.testing.assert_allclose(normalized.mesh(q_norm).vertices, (asset.mesh(q).vertices - center) * scale,
                               atol=1e-12)
    point, direction = normalized.joint_frames()["joint_door"]
    np.testing.assert_allclose(point, (np.array([-0.22, 0, 0]) - center) * scale, atol=1e-12)
    np.testing.assert_allclose(direction, [0, 0, 1], atol=1e-12)


def test_scale_and_translate_reject_bad_values_and_do_not_mutate():
    asset = tiny_cabinet()
    before = asset.mesh().vertices.copy()
    moved = translate_asset(asset, [1.0, 2.0, 3.0])
    # the translation through the FK's 4x4 product vs. a plain addition: a few ulps of magnitude ~3
    np.testing.assert_allclose(moved.mesh().vertices, before + [1, 2, 3], rtol=0, atol=1e-12)
    np.testing.assert_allclose(asset.mesh().vertices, before)
    with pytest.raises(ValueError):
        scale_asset(asset, 0.0)
    with pytest.raises(ValueError):
        scale_asset(asset, float("nan"))


def test_similarity_moves_geometry_joints_and_collisions_and_undoes_normalization():
    asset = tiny_cabinet()
    rotation = axis_angle_matrix(np.array([0.0, 0.0, 1.0]), 0.7)
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = 1.5 * rotation, [0.2, -0.1, 0.4]
    moved = similarity_asset(asset, matrix)
    # the similarity applied by the asset (FK, 4x4 products) vs. here (3x3 product + translation):
    # float64 roundings on coordinates of magnitude ~1, so 1e-12 absolute is ~1e4 ulps of margin
    q, q_moved = asset.open_configuration(), moved.open_configuration()
    assert q_moved["joint_drawer"] == pytest.approx(1.5 * q["joint_drawer"])  # prismatic limits scale
    expected = asset.mesh(q).vertices @ matrix[:3, :3].T + matrix[:3, 3]
    np.testing.assert_allclose(moved.mesh(q_moved).vertices, expected, atol=1e-12)
    for name, (point, direction) in asset.joint_frames().items():
        moved_point, moved_direction = moved.joint_frames()[name]
        np.testing.assert_allclose(moved_point, matrix[:3, :3] @ point + matrix[:3, 3], atol=1e-12)
        np.testing.assert_allclose(moved_direction, rotation @ direction, atol=1e-12)
    # collision shapes, in the world: where the similarity puts them
    world = asset.link_poses()["body"] @ asset.links["body"].collisions[0].origin
    moved_world = moved.link_poses()["body"] @ moved.links["body"].collisions[0].origin
    np.testing.assert_allclose(moved_world[:3, 3], matrix[:3, :3] @ world[:3, 3] + matrix[:3, 3], atol=1e-12)
    np.testing.assert_allclose(moved_world[:3, :3], rotation @ world[:3, :3], atol=1e-12)
    np.testing.assert_allclose(moved.links["body"].collisions[0].size, 1.5 * asset.links["body"].collisions[0].size,
                               rtol=1e-12)
    # the benchmark frame and back: the source object again
    normalized, center, scale = normalize_asset(asset)
    back = similarity_asset(normalized, denormalization(center, scale))
    np.testing.assert_allclose(back.mesh(q).vertices, asset.mesh(q).vertices, atol=1e-12)
    with pytest.raises(ValueError, match="similarity"):
        similarity_asset(asset, np.diag([1.0, 2.0, 1.0, 1.0]))


def test_copy_without_visuals_copies_everything_else():
    asset = tiny_cabinet()
    bare = asset.copy(visuals=False)
    assert all(link.visuals == [] for link in bare.links.values())
    assert all(link.visuals for link in asset.links.values() if link.has_geometry)  # the original keeps its own
    assert set(bare.links) == set(asset.links) and set(bare.joints) == set(asset.joints)
    assert bare.links["door"] is not asset.links["door"]
    bare.links["door"].visuals.append("x")  # a new list per link, not shared with the original or another link
    assert "x" not in asset.links["door"].visuals
    assert sum(len(link.visuals) for link in bare.links.values()) == 1
    np.testing.assert_array_equal(bare.joints["joint_door"].origin, asset.joints["joint_door"].origin)
