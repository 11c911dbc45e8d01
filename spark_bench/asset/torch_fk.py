"""Differentiable forward kinematics in torch, the twin of :meth:`ArticulatedAsset.link_poses`.

``T_child = T_parent @ origin @ motion(axis, q)`` as in URDF, with every quantity that the SPARK joint
optimization refines exposed as a tensor: the joint values ``q``, the joint axes, and two kinds of
origin change:

- ``origin_offsets`` (URDF semantics): added to the joint origin's translation, in the parent frame.
  The child subtree moves with it, at rest too.
- ``pivot_offsets`` (SPARK semantics, paper section 3.3): the *axis line* moves by the offset (parent
  frame) but the child stays where it is at rest, ``T_child = T_parent @ O' @ motion(q) @ O'^-1 @ O``
  with ``O'`` the origin shifted by the offset. This is what refining a hinge under fixed geometry means;
  :func:`spark_bench.methods.ours.assemble.apply_pivot_offset` writes the result back as a plain URDF.

Everything is plain torch, so autograd gives gradients with respect to all of these.
"""

from __future__ import annotations

from collections.abc import Mapping

import torch

from spark_bench.asset.joint_type import JointType, is_rotational
from spark_bench.asset.model import ArticulatedAsset, Joint

TensorLike = torch.Tensor | float


def skew(vector: torch.Tensor) -> torch.Tensor:
    """3x3 cross-product matrix of a 3-vector (differentiable)."""
    zero = vector.new_zeros(())
    x, y, z = vector[0], vector[1], vector[2]
    return torch.stack([torch.stack([zero, -z, y]), torch.stack([z, zero, -x]), torch.stack([-y, x, zero])])


def axis_angle_matrix_torch(axis: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """3x3 rotation by ``angle`` about ``axis`` (normalized here), by Rodrigues' formula.

    :param axis: (3,) tensor, any non-zero length
    :param angle: scalar tensor, radians
    """
    unit = axis / torch.linalg.norm(axis)
    k = skew(unit)
    eye = torch.eye(3, dtype=axis.dtype, device=axis.device)
    return eye + torch.sin(angle) * k + (1.0 - torch.cos(angle)) * (k @ k)


def joint_motion_torch(joint_type: str, axis: torch.Tensor, value: torch.Tensor) -> torch.Tensor:
    """4x4 motion of a joint's child in the joint frame (identity for ``fixed``).

    :param joint_type: ``revolute``, ``continuous``, ``prismatic`` or ``fixed``
    :param axis: (3,) axis in the joint frame (normalized here)
    :param value: scalar joint value (rad or m)
    """
    dtype, device = axis.dtype, axis.device
    top_left = torch.eye(3, dtype=dtype, device=device)
    translation = torch.zeros(3, dtype=dtype, device=device)
    if is_rotational(joint_type):
        top_left = axis_angle_matrix_torch(axis, value)
    elif joint_type == JointType.PRISMATIC:
        translation = axis / torch.linalg.norm(axis) * value
    return homogeneous(top_left, translation)


def homogeneous(rotation: torch.Tensor, translation: torch.Tensor) -> torch.Tensor:
    """4x4 transform from a 3x3 rotation and a 3-vector, differentiable in both."""
    bottom = torch.tensor([[0.0, 0.0, 0.0, 1.0]], dtype=rotation.dtype, device=rotation.device)
    return torch.cat([torch.cat([rotation, translation.reshape(3, 1)], dim=1), bottom], dim=0)


def invert_rigid_torch(transform: torch.Tensor) -> torch.Tensor:
    """Inverse of a rigid 4x4 transform."""
    rot_t = transform[:3, :3].T
    return homogeneous(rot_t, -rot_t @ transform[:3, 3])


def _as_tensor(value: TensorLike, dtype, device) -> torch.Tensor:
    if isinstance(value, torch.Tensor):
        return value.to(dtype=dtype, device=device)
    return torch.as_tensor(float(value), dtype=dtype, device=device)


def joint_transform_torch(joint: Joint, value: TensorLike, *, axis: torch.Tensor | None = None,
                          origin_offset: torch.Tensor | None = None, pivot_offset: torch.Tensor | None = None,
                          joint_type: str | None = None, dtype=torch.float64, device=None) -> torch.Tensor:
    """The 4x4 transform from a joint's parent link frame to its child link frame.

    :param joint: the joint (its origin, axis and type are the defaults)
    :param value: joint value
    :param axis: overrides ``joint.axis`` (joint frame; normalized inside)
    :param origin_offset: added to the origin translation (parent frame); moves the child at rest
    :param pivot_offset: moves the axis line (parent frame) and keeps the child's rest pose
    :param joint_type: overrides ``joint.type`` (for the discrete type refinement)
    """
    origin = torch.as_tensor(joint.origin, dtype=dtype, device=device)
    if origin_offset is not None:
        origin = homogeneous(origin[:3, :3], origin[:3, 3] + origin_offset.to(dtype))
    the_axis = axis.to(dtype) if axis is not None else torch.as_tensor(joint.axis, dtype=dtype, device=device)
    motion = joint_motion_torch(joint_type or joint.type, the_axis, _as_tensor(value, dtype, device))
    if pivot_offset is None:
        return origin @ motion
    shifted = homogeneous(origin[:3, :3], origin[:3, 3] + pivot_offset.to(dtype))
    return shifted @ motion @ invert_rigid_torch(shifted) @ origin


def link_poses_torch(asset: ArticulatedAsset, q: Mapping[str, TensorLike] | None = None,
                     origin_offsets: Mapping[str, torch.Tensor] | None = None,
                     axes: Mapping[str, torch.Tensor] | None = None,
                     pivot_offsets: Mapping[str, torch.Tensor] | None = None,
                     types: Mapping[str, str] | None = None,
                     dtype=torch.float64, device=None) -> dict[str, torch.Tensor]:
    """World pose (4x4 tensor) of every link, differentiable w.r.t. joint values, axes and origins.

    Joints missing from ``q`` are at rest, exactly as :meth:`ArticulatedAsset.link_poses`.

    :param asset: the asset (read only)
    :param q: joint values by joint name (floats or scalar tensors)
    :param origin_offsets: per joint, (3,) added to the origin translation (parent frame)
    :param axes: per joint, (3,) replacing ``joint.axis`` (normalized inside)
    :param pivot_offsets: per joint, (3,) moving the axis line while keeping the rest pose (parent frame)
    :param types: per joint, a joint type replacing ``joint.type``
    :param dtype: floating type of the result
    :param device: torch device of the result
    """
    q = dict(q or {})
    unknown = set(q) | set(origin_offsets or {}) | set(axes or {}) | set(pivot_offsets or {}) | set(types or {})
    unknown -= set(asset.joints)
    if unknown:
        raise KeyError(f"{asset.name}: no joint named {sorted(unknown)}")
    values: dict[str, TensorLike] = dict(asset.rest_configuration())
    values.update(q)
    poses = {asset.root: torch.eye(4, dtype=dtype, device=device)}
    for joint in asset.topological_joints():
        local = joint_transform_torch(
            joint, values.get(joint.name, 0.0),
            axis=(axes or {}).get(joint.name),
            origin_offset=(origin_offsets or {}).get(joint.name),
            pivot_offset=(pivot_offsets or {}).get(joint.name),
            joint_type=(types or {}).get(joint.name),
            dtype=dtype, device=device,
        )
        poses[joint.child] = poses[joint.parent] @ local
    return poses
