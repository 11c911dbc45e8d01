"""The environments' observation, defined once: where each quantity lies in the vector.

``basic`` observations are the first :data:`OBS_SIZE` entries; ``frame`` observations
(``observation="frame"``) add the grasp frame and the joint, :data:`FRAME_OBS_SIZE` in all. Vectors are
slices, scalars are indices; world frame, metres, seconds. Every entry is clipped to ``[-10, 10]``.
The environments write these (:mod:`spark_bench.envs.base`), the scripted opener
(:mod:`spark_bench.opening.opener`) and the generalist policies (:mod:`spark_bench.rl.generalist`) read them;
:data:`LAYOUT` describes each for the environments' docstrings.
"""

from __future__ import annotations

#: The TCP (tool centre point, between the fingertips) position.
TCP = slice(0, 3)
#: The passive wrist's angle, rad.
WRIST = 3
#: The finger opening, 0 closed, 1 fully open.
FINGERS = 4
#: The TCP's velocity, m/s.
TCP_VELOCITY = slice(5, 8)
#: The grasp point (it moves with the part).
GRASP = slice(8, 11)
#: The grasp point minus the TCP.
TO_GRASP = slice(11, 14)
#: With the suction cup (``end_effector="suction"``) the same entries read: :data:`SUCTION` (where the
#: gripper's finger opening is) the suction command, 0 released to 1 the cup's full holding force;
#: :data:`CUP_TOUCH` (the two pads' entries) the cup's contact normal force / 10 N, clipped to 1, in both;
#: ``frame``'s :data:`CLOSING` a direction across the approach, :data:`INSIDE_GRIP` 0, :data:`APPROACH_GRIP`
#: -1 (released), :data:`PRESS` 0. The size of either layout does not change.
SUCTION = FINGERS
#: The joint's position as a fraction of its range (0 rest, 1 fully open).
JOINT_FRACTION = 14
#: The joint's velocity divided by its range.
JOINT_VELOCITY = 15
#: The two finger pads' contact normal forces / 10 N, clipped to 1.
TOUCH = slice(16, 18)
#: Suction cup: its contact normal force / 10 N, clipped to 1, in both entries.
CUP_TOUCH = TOUCH
#: The distance from the TCP to the grasp point.
GRASP_DISTANCE = 18
OBS_SIZE = 19

#: ``frame`` only: the part's outward direction at the grasp (turns with the part).
OUTWARD = slice(19, 22)
#: ``frame`` only: the fingers' closing direction (turns with the part).
CLOSING = slice(22, 25)
#: ``frame`` only: the reported joint's axis (the simulated one, or the ``joint_estimate``).
AXIS = slice(25, 28)
#: ``frame`` only: from the grasp point to the reported joint's axis, perpendicular to it (0 for prismatic).
TO_AXIS = slice(28, 31)
#: ``frame`` only: 1 for a rotational joint (revolute, continuous), 0 for a prismatic one.
REVOLUTE = 31
#: ``frame`` only: 1 when the part is gripped from inside a notch, else 0.
INSIDE_GRIP = 32
#: ``frame`` only: the finger command to approach with.
APPROACH_GRIP = 33
#: ``frame`` only: inside grip: the press direction towards the notch's inner wall (turns with the part).
PRESS = slice(34, 37)
FRAME_OBS_SIZE = 37

#: ``(name, entries, meaning)`` in order, for documentation and checks.
LAYOUT = (
    ("TCP", TCP, "TCP position (world, m)"),
    ("WRIST", WRIST, "passive wrist angle (rad)"),
    ("FINGERS", FINGERS, "finger opening (0 closed, 1 fully open)"),
    ("TCP_VELOCITY", TCP_VELOCITY, "TCP velocity (m/s)"),
    ("GRASP", GRASP, "grasp point (world, m; moves with the part)"),
    ("TO_GRASP", TO_GRASP, "grasp point minus TCP"),
    ("JOINT_FRACTION", JOINT_FRACTION, "joint position as a fraction of its range"),
    ("JOINT_VELOCITY", JOINT_VELOCITY, "joint velocity / range"),
    ("TOUCH", TOUCH, "finger pad contact forces / 10 N, clipped to 1"),
    ("GRASP_DISTANCE", GRASP_DISTANCE, "TCP to grasp point distance"),
    ("OUTWARD", OUTWARD, "frame: outward direction at the grasp (turns with the part)"),
    ("CLOSING", CLOSING, "frame: fingers' closing direction (turns with the part)"),
    ("AXIS", AXIS, "frame: the reported joint's axis"),
    ("TO_AXIS", TO_AXIS, "frame: from the grasp point to the reported axis (0 for prismatic)"),
    ("REVOLUTE", REVOLUTE, "frame: 1 rotational joint, 0 prismatic"),
    ("INSIDE_GRIP", INSIDE_GRIP, "frame: 1 inside grip (a notch), else 0"),
    ("APPROACH_GRIP", APPROACH_GRIP, "frame: the finger command to approach with"),
    ("PRESS", PRESS, "frame: inside grip's press direction (turns with the part)"),
)


def entries(where: int | slice) -> range:
    """The indices an entry of :data:`LAYOUT` covers."""
    return range(where, where + 1) if isinstance(where, int) else range(where.start, where.stop)
