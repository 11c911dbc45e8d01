"""The generator's own description of an object: parts made of solids, joined by joints.

Every coordinate is in object coordinates at the rest pose (metres, Y up, front +Z). A part's link
frame is a pure translation of the object frame to its joint's pivot, as in PartNet-Mobility, so the
written meshes stay in object coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.asset.joint_type import JointType, is_movable, is_rotational
from spark_bench.data.synth.primitives import Solid, rotation_about, translation


@dataclass
class JointSpec:
    """How a part moves relative to its parent.

    :param type: ``revolute``, ``continuous``, ``prismatic`` or ``fixed``
    :param pivot: a point on the axis (object coordinates, rest pose); also the child's link-frame origin
    :param axis: unit direction (rotation axis or sliding direction)
    :param lower: lower limit (rad or m), the rest value
    :param upper: upper limit (rad or m)
    :param min_upper: the smallest upper limit the clearance repair may shrink ``upper`` to
    """

    type: str
    pivot: np.ndarray
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    lower: float = 0.0
    upper: float = 0.0
    min_upper: float | None = None

    def __post_init__(self):
        self.pivot = np.asarray(self.pivot, dtype=float)
        axis = np.asarray(self.axis, dtype=float)
        self.axis = axis / np.linalg.norm(axis)

    @property
    def movable(self) -> bool:
        return is_movable(self.type)

    @property
    def open_value(self) -> float:
        """Upper limit; pi/2 for continuous joints (the asset model's open angle)."""
        return float(np.pi / 2) if self.type == JointType.CONTINUOUS else float(self.upper)

    def motion(self, value: float) -> np.ndarray:
        """4x4 motion of the child, in object coordinates of the parent at rest, for joint value ``value``."""
        if is_rotational(self.type):
            return rotation_about(self.axis, value, self.pivot)
        if self.type == JointType.PRISMATIC:
            return translation(self.axis * value)
        return np.eye(4)


@dataclass
class Part:
    """One link of the object.

    :param name: the generator's name for it (``body``, ``door_0``...), not the URDF link name
    :param label: semantic label (``drawer``, ``rotation_door``, ``handle``...)
    :param solids: its convex pieces at rest, object coordinates
    :param parent: name of the parent part; None for the body
    :param joint: the joint to the parent; None for the body
    :param semantic: PartNet-Mobility joint word; derived from the joint when empty
    """

    name: str
    label: str
    solids: list[Solid]
    parent: str | None = None
    joint: JointSpec | None = None
    semantic: str = ""

    @property
    def frame(self) -> np.ndarray:
        """Origin of the link frame (object coordinates, rest)."""
        return np.zeros(3) if self.joint is None else self.joint.pivot

    @property
    def semantic_word(self) -> str:
        if self.semantic:
            return self.semantic
        if self.joint is None or self.joint.type == JointType.FIXED:
            return "static"
        return "slider" if self.joint.type == JointType.PRISMATIC else "hinge"


@dataclass
class ObjectSpec:
    """A whole generated object.

    :param category: PartNet-Mobility category name
    :param parts: the body first, then the other parts (a parent always before its children)
    :param params: the sampled parameters, for ``meta.json``
    """

    category: str
    parts: list[Part] = field(default_factory=list)
    params: dict = field(default_factory=dict)

    def part(self, name: str) -> Part:
        for part in self.parts:
            if part.name == name:
                return part
        raise KeyError(name)

    def add(self, name: str, label: str, solids: list[Solid], parent: str | None = None,
            joint: JointSpec | None = None, semantic: str = "") -> Part:
        """Append a part (names made unique with a numeric suffix) and return it."""
        taken = {p.name for p in self.parts}
        unique, k = name, 0
        while unique in taken:
            k += 1
            unique = f"{name}_{k}"
        part = Part(unique, label, list(solids), parent, joint, semantic)
        self.parts.append(part)
        return part

    def movable_parts(self) -> list[Part]:
        return [p for p in self.parts if p.joint is not None and p.joint.movable]

    def rest(self) -> dict[str, float]:
        return {p.name: float(p.joint.lower) for p in self.movable_parts()}

    def open(self) -> dict[str, float]:
        return {p.name: p.joint.open_value for p in self.movable_parts()}

    def poses(self, q: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        """Rigid motion (4x4, rest object coordinates -> posed) of each part at joint values ``q``."""
        values = self.rest()
        values.update(q or {})
        out: dict[str, np.ndarray] = {}
        for part in self.parts:  # parents come first
            if part.joint is None:
                out[part.name] = np.eye(4)
                continue
            out[part.name] = out[part.parent] @ part.joint.motion(values.get(part.name, 0.0))
        return out

    def rigid_group(self) -> dict[str, str]:
        """Each part's rigid group: the nearest ancestor-or-self reached through movable joints only."""
        group: dict[str, str] = {}
        for part in self.parts:
            if part.joint is not None and part.joint.type == JointType.FIXED:
                group[part.name] = group[part.parent]
            else:
                group[part.name] = part.name
        return group
