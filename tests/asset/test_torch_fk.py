"""The torch FK matches the NumPy FK and differentiates correctly (joint values, axes, origins)."""

import numpy as np
import pytest
import torch
from helpers_real import real_object_path
from helpers_toy import toy_cabinet

from spark_bench.asset.torch_fk import link_poses_torch
from spark_bench.methods.ours.assemble import apply_pivot_offset


def _random_q(asset, rng):
    return {j.name: float(rng.uniform(j.lower, j.lower + min(j.upper - j.lower, 2.0)))
            for j in asset.movable_joints()}


def _check_parity(asset, q):
    """Torch (float64) and NumPy FK are two implementations of the same products of 4x4 transforms:
    they differ by float64 rounding (and BLAS/FMA order), ~1e-15 per product on poses of magnitude ~1,
    so 1e-10 absolute leaves orders of magnitude of margin while any real bug moves poses by far more."""
    ref = asset.link_poses(q)
    got = link_poses_torch(asset, {k: torch.tensor(v, dtype=torch.float64) for k, v in q.items()})
    assert set(ref) == set(got)
    for name in ref:
        np.testing.assert_allclose(got[name].numpy(), ref[name], atol=1e-10, rtol=0)


def test_matches_numpy_fk_on_toy():
    asset = toy_cabinet()
    rng = np.random.default_rng(0)
    for _ in range(5):
        _check_parity(asset, _random_q(asset, rng))
    _check_parity(asset, {})


@pytest.mark.real
@pytest.mark.parametrize("object_id", ["3763", "7179", "45780"])
def test_matches_numpy_fk_on_real_objects(object_id):
    from spark_bench.data import load_object

    asset = load_object(real_object_path(object_id), load_meshes=False)
    _check_parity(asset, _random_q(asset, np.random.default_rng(1)))


def test_overrides_match_an_edited_asset():
    asset = toy_cabinet()
    q = {"joint_0": 0.7, "joint_1": 0.2}
    offset = np.array([0.05, -0.02, 0.03])
    axis = np.array([0.3, -1.0, 0.2])
    edited = asset.copy()
    edited.joints["joint_0"].origin[:3, 3] += offset
    edited.joints["joint_0"].axis = axis / np.linalg.norm(axis)
    ref = edited.link_poses(q)
    got = link_poses_torch(asset, q, origin_offsets={"joint_0": torch.tensor(offset)},
                           axes={"joint_0": torch.tensor(axis)})
    for name in ref:
        np.testing.assert_allclose(got[name].numpy(), ref[name], atol=1e-10, rtol=0)


def test_pivot_offset_keeps_rest_pose_and_matches_apply_pivot_offset():
    asset = toy_cabinet()
    offset = np.array([0.1, 0.0, -0.07])
    rest = link_poses_torch(asset, pivot_offsets={"joint_0": torch.tensor(offset)})
    for name, pose in asset.link_poses().items():
        np.testing.assert_allclose(rest[name].numpy(), pose, atol=1e-12)
    moved = asset.copy()
    apply_pivot_offset(moved, "joint_0", offset)
    q = {"joint_0": 1.1}
    opened = link_poses_torch(asset, q, pivot_offsets={"joint_0": torch.tensor(offset)})
    want = moved.mesh(q).vertices
    door = asset.links["door"].merged_mesh().vertices
    pose = opened["door"].numpy()
    np.testing.assert_allclose(door @ pose[:3, :3].T + pose[:3, 3],
                               moved.link_meshes(q)["door"].vertices, atol=1e-10)
    assert np.abs(want - asset.mesh(q).vertices).max() > 0.05  # the offset really moved the door


def test_gradcheck_values_axes_origins_pivots():
    asset = toy_cabinet()

    def door_pose(value, axis, origin_offset, pivot_offset):
        poses = link_poses_torch(asset, {"joint_0": value, "joint_1": value * 0.3},
                                 axes={"joint_0": axis}, origin_offsets={"joint_1": origin_offset},
                                 pivot_offsets={"joint_0": pivot_offset})
        return torch.cat([poses["door"].reshape(-1), poses["drawer"].reshape(-1)])

    inputs = (torch.tensor(0.8, dtype=torch.float64, requires_grad=True),
              torch.tensor([0.1, -1.0, 0.2], dtype=torch.float64, requires_grad=True),
              torch.tensor([0.01, 0.02, -0.03], dtype=torch.float64, requires_grad=True),
              torch.tensor([0.05, 0.0, 0.04], dtype=torch.float64, requires_grad=True))
    assert torch.autograd.gradcheck(door_pose, inputs, eps=1e-6, atol=1e-8)


def test_unknown_joint_is_an_error():
    with pytest.raises(KeyError):
        link_poses_torch(toy_cabinet(), {"nope": 0.1})
