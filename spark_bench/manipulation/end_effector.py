"""What the hand opening a part holds it with: one :class:`EndEffector` (a ``StrEnum``, so a member is equal
to its string, and the strings stored in results rows and reports stay as they are).
"""

from __future__ import annotations

from enum import StrEnum


class EndEffector(StrEnum):
    """The parallel gripper, the suction cup, or ``auto`` (the gripper where it can pinch the part, else the
    cup: :func:`~spark_bench.manipulation.suction.choose_end_effector`)."""

    GRIPPER = "gripper"
    SUCTION = "suction"
    AUTO = "auto"

    def __repr__(self) -> str:
        # shown as its string, so a message naming an end-effector reads as it did when they were strings
        return repr(self.value)


#: The end-effectors of the environments' ``end_effector`` option, in this order; ``auto`` picks one per part.
END_EFFECTORS = (EndEffector.GRIPPER, EndEffector.SUCTION, EndEffector.AUTO)
