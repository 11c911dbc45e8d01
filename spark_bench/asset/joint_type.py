"""The types of a joint, as URDF names them: one :class:`JointType` (a ``StrEnum``, so a member is equal to
its string, and the strings stored in assets, files and results rows stay as they are).

What a type is (rotational, movable) is said once, here.
"""

from __future__ import annotations

from enum import StrEnum


class JointType(StrEnum):
    """A URDF joint type; ``JointType.REVOLUTE == "revolute"``."""

    PRISMATIC = "prismatic"
    REVOLUTE = "revolute"
    CONTINUOUS = "continuous"
    FIXED = "fixed"
    FLOATING = "floating"
    PLANAR = "planar"

    def __repr__(self) -> str:
        # shown as its string, so a message naming a type reads as it did when types were plain strings
        return repr(self.value)

    @property
    def is_rotational(self) -> bool:
        """Whether the joint turns its part about an axis (revolute, continuous)."""
        return is_rotational(self)

    @property
    def is_movable(self) -> bool:
        """Whether the joint moves its part along one degree of freedom (revolute, continuous, prismatic)."""
        return is_movable(self)


#: The types that turn a part about an axis.
ROTATIONAL_TYPES = frozenset({JointType.REVOLUTE, JointType.CONTINUOUS})
#: The types with one degree of freedom, the ones an articulated object's parts open by (a revolute, a
#: continuous or a prismatic joint).
MOVABLE_TYPES = (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)


def is_rotational(joint_type: str) -> bool:
    """Whether ``joint_type`` (a :class:`JointType` or its string) turns its part: revolute or continuous.

    :param joint_type: the type
    """
    return joint_type in ROTATIONAL_TYPES


def is_movable(joint_type: str) -> bool:
    """Whether ``joint_type`` (a :class:`JointType` or its string) is one of :data:`MOVABLE_TYPES`.

    :param joint_type: the type
    """
    return joint_type in MOVABLE_TYPES
