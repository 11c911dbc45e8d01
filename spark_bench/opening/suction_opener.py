"""The scripted opener of the suction cup (``end_effector="suction"``, :mod:`spark_bench.manipulation.suction`): its
own phases on :class:`~spark_bench.opening.opener.ScriptedOpener`'s pre-grasp and opening trajectory, planned from
the given (predicted) joint as the gripper's opener is. :func:`~spark_bench.opening.episodes.opener_for` makes it
for an environment with the cup.
"""

from __future__ import annotations

import numpy as np

from spark_bench.opening.opener import (
    APPROACH_STEPS,
    MAX_REGRASPS,
    PREGRASP_OFFSET,
    PULL_STEP,
    WAYPOINT_TOLERANCE,
    Move,
    Reading,
    ScriptedOpener,
)

#: The suction opener (:class:`SuctionOpener`): how far (m) behind the face the approach and the attach aim
#: (the servo then presses the cup on with about ``kp * CUP_PRESS`` = 15 N, sealing it), the steps spent
#: pressing with suction on before the pull, the cup's touch reading (force / 10 N) that ends the approach
#: and tells a cup on the face (a vacuum gripper's part-present switch), and how far (m) the grasp point must
#: lie from a cup reading no touch for the cup to count as torn off (a cup sliding over a heavy door's face
#: under the pull drifts 2 cm from its place and still holds: only a cup off the face is released).
CUP_PRESS = 0.005
ATTACH_STEPS = 4
CUP_TOUCH = 0.05
DETACH_DISTANCE = 0.02


class SuctionOpener(ScriptedOpener):
    """The scripted opener of the suction cup (``end_effector="suction"``): pre-grasp in front of the cup's
    place, approach along the face's normal with suction off until the cup touches, ``attach`` (suction on,
    pressing the cup onto the face for :data:`ATTACH_STEPS` steps), then ``open``: the cup pulled along the
    planned line (drawer) or swung along the planned arc about the planned axis through the planned pivot
    (door, lid), as the gripper's opener pulls (:meth:`ScriptedOpener._open_target`). A cup torn off the
    face (no touch, :data:`DETACH_DISTANCE` from its place) is released and attached again from the pre-grasp, at most
    :data:`MAX_REGRASPS` times: a wrong axis pulls it off each time, or drags a part that does not follow.

    The action's last entry is the suction command: -1 released, +1 the cup's full holding force. Parameters
    as :class:`ScriptedOpener`'s (no grip, no door edge: a cup has nothing to push with from inside).
    """

    def __init__(self, axis, pivot, joint_type: str, outward, pull_step: float = PULL_STEP):
        super().__init__(axis, pivot, joint_type, outward, pull_step)

    def _cup_approach(self, r: Reading) -> Move:
        """In along the face's normal to just behind the cup's place, suction off, until the cup touches."""
        outward = self._turned(self.outward, r.grasp)
        distance = float(np.linalg.norm(r.grasp - r.tcp))
        touching = float(np.max(r.touch)) > CUP_TOUCH
        then = None
        if touching or distance < WAYPOINT_TOLERANCE or self.state.phase_steps > APPROACH_STEPS or self._stalled(distance):
            then = "attach"
        return Move(r.grasp - CUP_PRESS * outward, r.travel, then)

    def _attach(self, r: Reading) -> Move:
        """Suction on, pressing the cup onto the face."""
        target = r.grasp - CUP_PRESS * self._turned(self.outward, r.grasp)
        return Move(target, r.hold, "open" if self.state.phase_steps >= ATTACH_STEPS else None)

    def _pull(self, r: Reading) -> Move:
        """Along the planned line or arc, suction on; a cup torn off is released and attached again."""
        state = self.state
        off = float(np.max(r.touch)) <= CUP_TOUCH and np.linalg.norm(r.grasp - r.tcp) > DETACH_DISTANCE
        if off and state.regrasps < MAX_REGRASPS:
            state.regrasps += 1
            state.radius = None
            return Move(r.grasp + PREGRASP_OFFSET * self._turned(self.outward, r.grasp), r.travel, "pregrasp")
        return Move(self._open_target(r.tcp, np.zeros(3)), r.hold)

    #: The method of each phase: the gripper's pre-grasp (its phase table's), then the cup's own.
    PHASES = {"pregrasp": ScriptedOpener.PHASES["pregrasp"], "approach": _cup_approach, "attach": _attach,
              "open": _pull}
