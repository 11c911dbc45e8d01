"""What the grasp planner (:mod:`spark_bench.manipulation.grasp`) answers for one joint: where the TCP
goes, from which side, how the fingers (or the cup) hold, or why a parallel gripper cannot pull the part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class GraspTarget:
    """A grasp on the moving part of one joint, world frame at the rest configuration.

    :param point: the grasp point (where the TCP should go)
    :param outward: unit direction out of the part's front (the gripper approaches along ``-outward``)
    :param long_axis: the handle's long direction (perpendicular to ``outward``); fingers close across it
    :param has_handle: whether a handle was found (label or geometry)
    :param source: ``label``, ``geometry``, ``notch`` (a finger-pull notch), ``tab`` (a lid's tab past its
        free edge), ``edge`` (the whole front pinched by its edges) or ``face`` (no handle)
    :param grip: ``pinch`` (fingers close across the handle) or ``inside`` (a notch: the closed fingers
        enter it, the hand presses towards its inner wall, the fingers open against its sides)
    :param press: for an ``inside`` grip, the unit direction (in the front plane) from the notch's open
        edge to its inner wall, which the hand presses against while it opens the part
    :param notch_size: for a notch, its extent across the fingers' closing direction and along it, m
    :param opening: finger opening per side (m) to approach with, when a neighbouring feature is in the
        open fingers' sweep (None: approach fully open)
    :param pad_thickness: pad thickness (m) the pads must not exceed to fit beside the handle (None: any)
    :param clearance: room (m) left on each side of a pad placed in a gap beside the handle
    :param reason: why a parallel gripper cannot pull this part open (one line), or None when it can
    :param landing: an open pad comes down on the object (kept only when no other candidate is clear)
    :param declined: why the planner declined the part, as a word (None when it did not): ``no_handle``
        (nothing stands out of the front to pinch), ``too_wide`` (a handle wider than the open fingers),
        ``blocked`` (the object stands in the hand's way in), ``button`` (a push button), ``unholdable``
        (handle candidates, but none the pads can hold: their sides slope too gently, as a low rounded rib's,
        or the simulated collision shape has no side to hold); a part declined
        for ``no_handle``, ``too_wide`` or ``unholdable`` has nothing to pinch, and the environments'
        ``end_effector="auto"`` opens it with the suction cup
        (:func:`~spark_bench.manipulation.suction.choose_end_effector`). The scene's drive check adds ``weak_pinch``
        (a pinch whose part starts to move along the fingers' closing, too heavy for one finger's servo:
        :func:`~spark_bench.manipulation.drive_check.stuck_reason`), where ``auto`` takes the cup when the cup opens it
    :param cup_radius: for the suction cup, the radius (m) of the cup planned (one of
        :func:`~spark_bench.manipulation.suction.cup_sizes`; None: the gripper)
    :param broad_face: the grasp is on a sliding plate's broad face, not on its front (``outward`` is that
        face's; :func:`~spark_bench.manipulation.plate_front.plate_face`)
    """

    point: np.ndarray
    outward: np.ndarray
    long_axis: np.ndarray
    has_handle: bool
    source: str
    grip: str = "pinch"
    press: np.ndarray | None = None
    notch_size: tuple[float, float] | None = None
    opening: float | None = None
    pad_thickness: float | None = None
    clearance: float | None = None
    reason: str | None = None
    landing: bool = False
    declined: str | None = None
    cup_radius: float | None = None
    broad_face: bool = False

    @property
    def inside_grip(self) -> bool:
        """Whether the grasp is from inside a notch (the fingers grip by opening)."""
        return self.grip == "inside"

    @property
    def closing(self) -> np.ndarray:
        """The direction the fingers close along: across the handle, in the front plane."""
        c = np.cross(self.outward, self.long_axis)
        return c / np.linalg.norm(c)
