"""Forward kinematics, configurations and whole-asset operations of ArticulatedAsset."""

from __future__ import annotations

import numpy as np
import pytest
from helpers_assets import tiny_cabinet

from spark_bench.asset.ops import normalize_asset, scale_asset, translate_asset
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
    np.testing.assert_allclose(point, [-0.22, 0, 0])
    np.testing.assert_allclose(direction, [0, 0, 1])
    with pytest.raises(KeyError, match="no joint named"):
        asset.link_poses({"nope": 1.0})


def test_moving_links_and_parts():
    asset = tiny_cabinet()
    assert asset.moving_links("joint_door") == ["door"]
    assert asset.part_of_joint("joint_drawer") == ["drawer"]
    assert [j.name for j in asset.topological_joints()][0] == "root"


def test_normalize_fits_unit_box_and_preserves_kinematics():
    asset = tiny_cabinet()
    normalized, center, scale = normalize_asset(asset)
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
    np.testing.assert_allclose(direction, [0, 0, 1])


def test_scale_and_translate_reject_bad_values_and_do_not_mutate():
    asset = tiny_cabinet()
    before = asset.mesh().vertices.copy()
    moved = translate_asset(asset, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(moved.mesh().vertices, before + [1, 2, 3])
    np.testing.assert_allclose(asset.mesh().vertices, before)
    with pytest.raises(ValueError):
        scale_asset(asset, 0.0)
    with pytest.raises(ValueError):
        scale_asset(asset, float("nan"))
