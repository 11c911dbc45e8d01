"""Broken twins: a copy of an object with one joint made wrong in the ways reconstruction methods get joints wrong,
so that the part moves into its own body (``measure_check_validity``).

Every twin first moves its joint's rest value into the joint's origin (:func:`rest_baked`: the same motion over
a range ``[0, span]``), so the part rests where the intact object rests and only the motion differs:

- ``axis_reversed``: the axis negated; the part leaves its rest pose the other way (SPARK's clockwise rule picked
  the wrong sign, a drawer pushed instead of pulled);
- ``pivot_far_edge``: a hinge moved to the far edge of its part, same axis and sign (a door hinged on its handle
  side: the old hinge edge now swings into the body);
- ``slide_turned``: a prismatic axis turned 90 degrees about the up axis (a drawer sliding into its side panel);
- ``type_swapped``: a door made prismatic along its hinge line (sliding by its own width), a drawer made revolute
  about its front bottom edge (its front tipping out, its box rising into whatever is above it).

A moved hinge keeps the part's meshes as they are: the joint drives a helper link (no geometry) at the new pivot
and the part hangs on it by a fixed joint, so the part's collision hulls come from the same meshes (cached).
Plain functions on :class:`~spark_bench.asset.model.ArticulatedAsset`; whether a twin is a clean break is
:mod:`benchmarks.clean_break`'s to judge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset, Joint, Link
from spark_bench.asset.transforms import axis_angle_matrix, make_transform, unit

#: The kinds of break, in report order.
KINDS = ("axis_reversed", "pivot_far_edge", "slide_turned", "type_swapped")
#: The world's up axis (a URDF's +z; PartNet-Mobility's root joint turns its y-up meshes into it).
UP = np.array([0.0, 0.0, 1.0])
#: A slide within this cosine of the up axis has no horizontal direction to turn (a lid lifted straight up).
VERTICAL_COS = 0.9
#: Range of a drawer made revolute (rad).
SWAPPED_HINGE_RANGE = np.pi / 2
#: Points of the far edge: those at least this fraction of the farthest distance from the axis.
FAR_EDGE_FRACTION = 0.98


@dataclass
class Twin:
    """One broken copy of an object.

    :param kind: one of :data:`KINDS`
    :param joint: the joint broken (its name is kept in the twin)
    :param part: the link that joint moves in the intact object (the part a failure should name)
    :param asset: the twin
    :param description: what was changed, in numbers
    """

    kind: str
    joint: str
    part: str
    asset: ArticulatedAsset
    description: str


def rest_baked(asset: ArticulatedAsset, joint_name: str) -> ArticulatedAsset:
    """A copy in which ``joint_name``'s rest motion is part of its origin: the same poses over ``[0, span]``."""
    out = asset.copy()
    joint = out.joints[joint_name]
    rest = joint.rest_value
    joint.origin = joint.origin @ joint.motion(rest)
    joint.lower, joint.upper = 0.0, float(joint.upper) - rest
    return out


def joint_frame(asset: ArticulatedAsset, joint: Joint) -> np.ndarray:
    """World pose of ``joint``'s frame at rest."""
    return asset.link_poses()[joint.parent] @ joint.origin


def moving_points(asset: ArticulatedAsset, joint: Joint) -> np.ndarray:
    """The vertices of every link ``joint`` moves, in the joint's frame at rest."""
    poses = asset.link_poses()
    to_joint = np.linalg.inv(joint_frame(asset, joint))
    chunks = []
    for name in asset.moving_links(joint.name):
        link = asset.links[name]
        if link.has_geometry:
            mesh = link.merged_mesh()
            pose = to_joint @ poses[name]
            chunks.append(mesh.vertices @ pose[:3, :3].T + pose[:3, 3])
    if not chunks:
        raise ValueError(f"{asset.name}: joint {joint.name} moves no geometry")
    return np.concatenate(chunks)


def axis_reversed(asset: ArticulatedAsset, joint_name: str) -> Twin:
    """The axis negated: from its rest pose the part moves the other way over the same span."""
    twin = rest_baked(asset, joint_name)
    joint = twin.joints[joint_name]
    joint.axis = -np.asarray(joint.axis, float)
    return Twin("axis_reversed", joint_name, joint.child, twin,
                f"axis negated; range [0, {joint.upper:.4g}] from the rest pose")


def far_edge_offset(asset: ArticulatedAsset, joint: Joint) -> np.ndarray:
    """Where the part's far edge is, perpendicular to ``joint``'s axis, in the joint frame: the mean offset of the
    points at least :data:`FAR_EDGE_FRACTION` of the farthest distance from the axis."""
    axis = unit(joint.axis)
    points = moving_points(asset, joint)
    radial = points - np.outer(points @ axis, axis)
    distance = np.linalg.norm(radial, axis=1)
    far = radial[distance >= FAR_EDGE_FRACTION * distance.max()]
    return far.mean(axis=0)


def pivot_far_edge(asset: ArticulatedAsset, joint_name: str) -> Twin:
    """The hinge moved to the far edge of its part, same axis and sign: the part turns about its free edge, and its
    old hinge edge swings the other way (into the body, when it was hinged at the body)."""
    twin = rest_baked(asset, joint_name)
    joint = twin.joints[joint_name]
    if not joint.is_rotational:
        raise ValueError(f"{asset.name}: joint {joint_name} is {joint.type}, not a hinge")
    offset = far_edge_offset(twin, joint)
    helper = f"{joint.child}_pivot_helper"
    if helper in twin.links:
        raise ValueError(f"{asset.name}: a link named {helper} exists")
    twin.links[helper] = Link(helper)
    hang = Joint(f"{joint_name}_pivot_offset", JointType.FIXED, helper, joint.child,
                 origin=make_transform(translation=-offset))
    part = joint.child
    joint.origin = joint.origin @ make_transform(translation=offset)
    joint.child = helper
    twin.joints[hang.name] = hang
    return Twin("pivot_far_edge", joint_name, part, twin,
                f"pivot moved {1000 * np.linalg.norm(offset):.0f} mm to the part's far edge, same axis")


def world_axis(asset: ArticulatedAsset, joint: Joint) -> np.ndarray:
    """``joint``'s axis in the world at rest (unit)."""
    return unit(joint_frame(asset, joint)[:3, :3] @ np.asarray(joint.axis, float))


def slide_turned(asset: ArticulatedAsset, joint_name: str, sign: int = 1) -> Twin:
    """A prismatic axis turned by ``sign`` x 90 degrees about the up axis (a drawer sliding sideways).

    :raises ValueError: the joint is not prismatic, or slides (nearly) vertically
    """
    twin = rest_baked(asset, joint_name)
    joint = twin.joints[joint_name]
    if joint.type != JointType.PRISMATIC:
        raise ValueError(f"{asset.name}: joint {joint_name} is {joint.type}, not a slide")
    world = world_axis(twin, joint)
    if abs(float(world @ UP)) > VERTICAL_COS:
        raise ValueError(f"{asset.name}: joint {joint_name} slides vertically: no horizontal turn")
    turned = axis_angle_matrix(UP, sign * np.pi / 2) @ world
    joint.axis = joint_frame(twin, joint)[:3, :3].T @ turned
    side = "left" if sign > 0 else "right"
    return Twin("slide_turned", joint_name, joint.child, twin,
                f"slide axis turned 90 deg to the {side} about the up axis; range [0, {joint.upper:.4g}] m")


def _door_to_slide(twin: ArticulatedAsset, joint: Joint) -> str:
    """A hinge made a slide along its own axis line, as far as the part reaches from the axis."""
    width = float(np.linalg.norm(far_edge_offset(twin, joint)))
    joint.type = JointType.PRISMATIC
    joint.lower, joint.upper = 0.0, width
    return f"hinge made a slide along its axis line, range [0, {width:.4g}] m (the part's width)"


def _drawer_to_hinge(twin: ArticulatedAsset, joint: Joint) -> str:
    """A slide made a hinge about its part's front bottom edge, the front tipping out."""
    out = world_axis(twin, joint)  # the way it opens: the part's front faces it
    if abs(float(out @ UP)) > VERTICAL_COS:
        raise ValueError(f"{twin.name}: joint {joint.name} slides vertically: no front edge to hinge on")
    out = unit(out - (out @ UP) * UP)
    hinge = unit(np.cross(UP, out))  # so that the front's top tips out: (UP x out) x UP = out
    frame = joint_frame(twin, joint)
    points = moving_points(twin, joint) @ frame[:3, :3].T + frame[:3, 3]  # world
    front = float(np.max(points @ out))
    bottom = float(np.min(points @ UP))
    base = frame[:3, 3]
    pivot_world = base + out * (front - float(base @ out)) + UP * (bottom - float(base @ UP))
    offset = frame[:3, :3].T @ (pivot_world - base)  # in the joint frame
    helper = f"{joint.child}_pivot_helper"
    twin.links[helper] = Link(helper)
    hang = Joint(f"{joint.name}_pivot_offset", JointType.FIXED, helper, joint.child,
                 origin=make_transform(translation=-offset))
    joint.origin = joint.origin @ make_transform(translation=offset)
    joint.child = helper
    twin.joints[hang.name] = hang
    joint.type = JointType.REVOLUTE
    joint.axis = frame[:3, :3].T @ hinge
    joint.lower, joint.upper = 0.0, SWAPPED_HINGE_RANGE
    return "slide made a hinge about the part's front bottom edge, front tipping out, range [0, 90 deg]"


def type_swapped(asset: ArticulatedAsset, joint_name: str) -> Twin:
    """A hinge made a slide along its axis line, or a slide made a hinge about its front bottom edge."""
    twin = rest_baked(asset, joint_name)
    joint = twin.joints[joint_name]
    part = joint.child
    if joint.is_rotational:
        description = _door_to_slide(twin, joint)
    elif joint.type == JointType.PRISMATIC:
        description = _drawer_to_hinge(twin, joint)
    else:
        raise ValueError(f"{asset.name}: joint {joint_name} is {joint.type}")
    return Twin("type_swapped", joint_name, part, twin, description)


def applicable_kinds(joint: Joint) -> tuple[str, ...]:
    """The kinds of break that apply to ``joint``'s type."""
    if joint.type == JointType.REVOLUTE:
        return ("axis_reversed", "pivot_far_edge", "type_swapped")
    if joint.type == JointType.PRISMATIC:
        return ("axis_reversed", "slide_turned", "type_swapped")
    return ()


def make_twin(asset: ArticulatedAsset, joint_name: str, kind: str, sign: int = 1) -> Twin:
    """The twin of ``kind`` (:data:`KINDS`) for ``joint_name``; ``sign`` picks a turned slide's side."""
    if kind == "axis_reversed":
        return axis_reversed(asset, joint_name)
    if kind == "pivot_far_edge":
        return pivot_far_edge(asset, joint_name)
    if kind == "slide_turned":
        return slide_turned(asset, joint_name, sign)
    if kind == "type_swapped":
        return type_swapped(asset, joint_name)
    raise ValueError(f"unknown kind of break {kind!r} (one of {', '.join(KINDS)})")
