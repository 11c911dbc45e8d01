"""The scripted opener: grasp the handle, then pull along the joint's axis or swing along its arc (and
push a door that slipped out of the fingers far open from inside, round its free edge).

It plans from *given* joint parameters (a world-frame axis direction, a point on the axis, a type), so
the same controller measures two things:

- with the ground-truth parameters, that an environment is solvable;
- with a reconstruction's *predicted* parameters acting on the *ground-truth* object, whether the
  predicted articulation is good enough to act on (a wrong axis drags the handle sideways, a wrong
  pivot tears it out of the grasp).

It sees what a robot would see in the environment's observation: the TCP and the grasp point; of the
part's shape, what the grasp planner read from it and the door's free edge and thickness (:func:`door_edge`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.asset.joint_type import MOVABLE_TYPES, JointType
from spark_bench.asset.transforms import unit
from spark_bench.envs import observation as OBS
from spark_bench.manipulation.gripper import MAX_STEP
from spark_bench.opening.door_geometry import DoorEdge

#: Distance (m) in front of the grasp point where the approach starts.
PREGRASP_OFFSET = 0.06
#: How close (m) the TCP must come to a waypoint before the next phase.
WAYPOINT_TOLERANCE = 0.008
#: Steps after which the pre-grasp and the (direct) approach phases move on even if short of their waypoint.
PREGRASP_STEPS = 30
APPROACH_STEPS = 20
#: Steps spent closing the fingers.
CLOSE_STEPS = 6
#: Path length (m) the opening target leads the TCP by (the action saturates at 0.02 m per step).
PULL_STEP = 0.03
#: Inside grip (a notch): how far (m) past the notch's inner wall the TCP target lies, so the hand
#: presses on it (about ``kp * PRESS_OFFSET`` = 15 N), and the steps spent pressing before the fingers open.
PRESS_OFFSET = 0.01
PRESS_STEPS = 5
#: Aligned approach (pads going into narrow gaps beside the handle): the TCP advances along the approach
#: line by at most this much (m) per step, and only while it is within the lateral tolerance of that line.
ALIGNED_STEP = 0.005
ALIGNED_APPROACH_STEPS = 50
#: A travel phase (pre-grasp, approach) whose distance to its waypoint shrank by less than
#: :data:`STALL_PROGRESS` (m) over the last :data:`STALL_STEPS` steps has stalled (a pad or the palm rests on
#: a lip beside the handle): it moves on rather than spend the episode's steps pushing (a real table's
#: drawer lost 50 of its 100 steps so).
STALL_STEPS = 6
STALL_PROGRESS = 0.002
#: While opening, a grasp point this far (m) from the TCP has slipped out of the fingers (held, it stays
#: within about 2.5 cm, the handle turning between the pads): the opener grasps it again, from the
#: pre-grasp in front of where it now is, at most :data:`MAX_REGRASPS` times an episode.
REGRASP_DISTANCE = 0.05
MAX_REGRASPS = 3
#: Re-grasping a door (a part on a hinge) that slipped out of the fingers part-way open, where nothing holds
#: it but its own damping and the hand must not swing it shut: the hand first backs out along the door's
#: outward direction to :data:`PREGRASP_OFFSET` (the swing left it beside the handle, the fingers over the
#: face), waits at the pre-grasp while the door still moves by more than :data:`PUSH_GUARD` (m) a step,
#: comes in by at most :data:`REGRASP_STEP` (m) a step, and stops there and closes as soon as a pad's touch
#: reading (the observation's, force / 10 N) passes :data:`REGRASP_TOUCH` or the door is knocked towards
#: closing (it moves so by more than :data:`PUSH_GUARD` and faster than the step before: swinging shut by
#: itself it only slows down). A door within :data:`AJAR_DISTANCE` (m) of rest, against its stop, is
#: approached as at first. A drawer's re-grasp is the first approach again: its hand ran on along the pull,
#: in front of the handle and square to it (a guarded approach lost a real table's drawer whose handle
#: the full-speed approach seats deeper).
PUSH_GUARD = 0.001
REGRASP_STEP = 0.01
REGRASP_TOUCH = 0.05
AJAR_DISTANCE = 0.01
#: Pushing a door open from inside (:func:`door_edge`): when a door's handle slips out of the fingers with the
#: door open so far that the hand fits behind its free edge, the hand does not re-grasp the handle (a passive
#: wrist sprung back leaves the fingers far off square to a door swung past a right angle) but backs out
#: to :data:`PREGRASP_OFFSET` in front of the door with its fingers open, closes them, goes round its free edge
#: (:data:`EDGE_CLEARANCE` (m) past it), behind its inside face (:data:`INSIDE_CLEARANCE` (m) from it), in to
#: :data:`PUSH_INSET` (m) from the free edge, and then swings along the opening arc, pushing the inside face.
#: The door fits the hand when the waypoints behind it stand at least :data:`FIT_CLEARANCE` (m) in front of
#: the plane of the closed door's inside face (the body's front): the hand's reach from the TCP (its palm,
#: 12 cm wide, lies 4-6 cm behind the TCP: its corners 8.6 cm from it). A waypoint counts as reached within
#: :data:`AROUND_TOLERANCE` (m), after :data:`AROUND_STEPS` steps, or when the travel stalls; the last (in
#: behind the door) also as soon as the hand touches the door or knocks it towards closing (as the re-grasp's
#: guarded approach), and the push starts from there.
EDGE_CLEARANCE = 0.08
INSIDE_CLEARANCE = 0.05
PUSH_INSET = 0.05
FIT_CLEARANCE = 0.09
AROUND_TOLERANCE = 0.015
AROUND_STEPS = 15


def _met(touch: np.ndarray, closing: float, closing_before: float) -> bool:
    """Whether the hand, coming in on a door (the re-grasp's guarded approach, the way in behind it), has met
    it: a pad's touch reading passes :data:`REGRASP_TOUCH`, or the door is knocked towards closing (it moved
    so by more than :data:`PUSH_GUARD` in the last step and faster than in the step before: swinging shut by
    itself it only slows down).

    :param touch: the pads' touch readings (the observation's, force / 10 N)
    :param closing: how far (m) the grasp point moved towards closing in the last step
    :param closing_before: the same in the step before
    """
    knocked = closing > PUSH_GUARD and closing > closing_before + 0.5 * PUSH_GUARD
    return knocked or float(np.max(touch)) > REGRASP_TOUCH


def rotate_about(point: np.ndarray, pivot: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``point`` rotated by ``angle`` about the line through ``pivot`` along unit ``axis`` (Rodrigues)."""
    v = point - pivot
    c, s = np.cos(angle), np.sin(angle)
    return pivot + v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1 - c)


@dataclass
class Reading:
    """What one step of the opener reads of the observation, and what it derives first.

    :param tcp: the TCP's position
    :param grasp: the grasp point's position
    :param touch: the pads' touch readings (force / 10 N, clipped to 1)
    :param closing: how far (m) the grasp point moved towards closing in the last step
    :param closing_before: the same in the step before
    :param press: the press offset turned with the part (zero unless an inside grip)
    :param travel: the finger command while travelling to the grasp
    :param hold: the finger command that holds the part
    """

    tcp: np.ndarray
    grasp: np.ndarray
    touch: np.ndarray
    closing: float
    closing_before: float
    press: np.ndarray
    travel: float
    hold: float


@dataclass
class Move:
    """What a phase decides: the TCP target, the finger command, and the phase to go to (None: stay)."""

    target: np.ndarray
    grip: float
    then: str | None = None


@dataclass
class EpisodeState:
    """The opener's memory of its episode (reset at each episode's start).

    :param phase: the current phase (``pregrasp``, ``approach``, ``press``, ``close``, ``open``, ``around``,
        ``push``)
    :param phase_steps: steps spent in it
    :param distances: the phase's distances to its waypoint, step by step (the stall test)
    :param radius: the grasp's radius about the planned axis while opening (set on the first opening step)
    :param rest_grasp: the grasp point at the episode's start
    :param last_grasp: the grasp point a step ago
    :param closing: how far the part moved towards closing in the last step
    :param regrasps: re-grasps so far
    :param cleared: a door's re-grasp has backed out of the door's face
    :param hold: where the hand stopped on meeting a door (closes there), None otherwise
    :param around: the waypoints left of the way round a door's free edge (door frame, at rest)
    """

    phase: str = "pregrasp"
    phase_steps: int = 0
    distances: list[float] = field(default_factory=list)
    radius: float | None = None
    rest_grasp: np.ndarray | None = None
    last_grasp: np.ndarray | None = None
    closing: float = 0.0
    regrasps: int = 0
    cleared: bool = True
    hold: np.ndarray | None = None
    around: list[np.ndarray] = field(default_factory=list)


class ScriptedOpener:
    """A four-phase controller: pre-grasp, approach, close, open along the given joint (and back to the
    pre-grasp when the handle slips out of the fingers while opening, :data:`REGRASP_DISTANCE`; a door's
    re-grasp backs out, waits and comes in guarded so as not to swing it shut, :data:`PUSH_GUARD`; a door
    open so far that the hand fits behind it is instead pushed open from inside, round its free edge,
    :data:`EDGE_CLEARANCE`).

    Each phase is one method taking the step's :class:`Reading` and returning a :class:`Move`; the episode's
    memory is one :class:`EpisodeState`.

    With ``inside_grip`` (a finger-pull notch instead of a handle) the fingers close *before* the
    approach, enter the notch, the hand presses towards the notch's inner wall (``press``) and the
    fingers then open against the notch's sides: gripping means opening. The press is kept while
    opening (turned with the part for a door).

    :param axis: joint axis direction, world frame (opening = increasing joint value)
    :param pivot: a point on the joint axis, world frame (ignored for prismatic joints)
    :param joint_type: ``prismatic``, ``revolute`` or ``continuous``
    :param outward: the part's outward direction (the gripper approaches along its opposite)
    :param pull_step: path length per step while opening, m
    :param inside_grip: grip from inside a notch (see above)
    :param press: unit direction towards the notch's inner wall at rest, world frame (inside grip)
    :param approach_grip: the gripper command (the action's last entry) while travelling to the grasp;
        None: fully open (closed for an inside grip)
    :param lateral_tolerance: aligned approach (see above) with this tolerance, m; None: direct approach
    :param edge: a door's free edge (:func:`door_edge`): a door that slips out of the fingers open far enough
        for the hand to fit behind it is pushed open from inside (:data:`EDGE_CLEARANCE`); None: re-grasped
    :param in_place: a rotational part that turns in place about an axis through itself (a cap, a dial:
        :func:`turns_in_place`): re-grasped as a drawer is, never pushed
    """

    def __init__(self, axis, pivot, joint_type: str, outward, pull_step: float = PULL_STEP,
                 inside_grip: bool = False, press=None, approach_grip: float | None = None,
                 lateral_tolerance: float | None = None, edge: DoorEdge | None = None, in_place: bool = False):
        if joint_type not in MOVABLE_TYPES:
            raise ValueError(f"cannot open a {joint_type!r} joint")
        self.axis = unit(axis)
        self.pivot = np.asarray(pivot, float)
        self.rotational = joint_type != JointType.PRISMATIC
        self.outward = unit(outward)
        self.pull_step = float(pull_step)
        self.inside_grip = bool(inside_grip)
        if self.inside_grip and press is None:
            raise ValueError("an inside grip needs a press direction")
        self.press = unit(press) if self.inside_grip else np.zeros(3)
        self.approach_grip = None if approach_grip is None else float(np.clip(approach_grip, -1.0, 1.0))
        self.lateral_tolerance = None if lateral_tolerance is None else float(lateral_tolerance)
        self.edge = edge if self.rotational else None
        self.in_place = bool(in_place)
        self.reset()

    @property
    def swinging(self) -> bool:
        """Whether the part swings like a door (rotational and not turning in place, :func:`turns_in_place`)."""
        return self.rotational and not self.in_place

    @property
    def aligned(self) -> bool:
        """Whether the approach is aligned (pads going into narrow gaps beside the handle)."""
        return self.lateral_tolerance is not None

    def reset(self) -> None:
        """Back to the first phase (call at each episode start)."""
        self.state = EpisodeState()

    @property
    def phase(self) -> str:
        """The current phase."""
        return self.state.phase

    @phase.setter
    def phase(self, value: str) -> None:
        if value not in self.PHASES:
            raise ValueError(f"unknown phase {value!r}; phases: {', '.join(self.PHASES)}")
        self.state.phase = value

    @property
    def regrasps(self) -> int:
        """Re-grasps so far in this episode."""
        return self.state.regrasps

    @property
    def rest_grasp(self) -> np.ndarray | None:
        """The grasp point at the episode's start (None before its first step)."""
        return self.state.rest_grasp

    @rest_grasp.setter
    def rest_grasp(self, value) -> None:
        self.state.rest_grasp = value

    def _next(self, phase: str) -> None:
        self.state.phase, self.state.phase_steps, self.state.distances = phase, 0, []

    def _stalled(self, distance: float) -> bool:
        """Record this step's distance to the phase's waypoint; whether the travel has stalled."""
        distances = self.state.distances
        distances.append(float(distance))
        return len(distances) > STALL_STEPS and distances[-1 - STALL_STEPS] - distances[-1] < STALL_PROGRESS

    def _opening_direction(self, grasp: np.ndarray) -> np.ndarray:
        """The direction in which the grasp point moves when the part opens (the axis for a drawer, the
        tangent of its circle about the planned axis for a door)."""
        if not self.rotational:
            return self.axis
        tangent = np.cross(self.axis, grasp - self.pivot)
        norm = float(np.linalg.norm(tangent))
        return tangent / norm if norm > 1e-6 else self._turned(self.outward, grasp)

    def _angle(self, grasp: np.ndarray) -> float:
        """The angle the grasp point has swung about the planned axis since the episode began."""
        a, b = self.state.rest_grasp - self.pivot, grasp - self.pivot
        a, b = a - np.dot(a, self.axis) * self.axis, b - np.dot(b, self.axis) * self.axis
        return float(np.arctan2(np.dot(self.axis, np.cross(a, b)), np.dot(a, b)))

    def _turned(self, direction: np.ndarray, grasp: np.ndarray) -> np.ndarray:
        """``direction`` (at rest) turned with the part: by the angle the grasp point has swung about the
        planned axis since the episode began (unchanged for a prismatic joint)."""
        if not self.rotational:
            return direction
        return rotate_about(direction, np.zeros(3), self.axis, self._angle(grasp))

    def _push_path(self, tcp: np.ndarray, grasp: np.ndarray) -> list[np.ndarray] | None:
        """The waypoints (door frame: at rest) of the way round a door's free edge to behind its inside face
        (:data:`EDGE_CLEARANCE`), from the hand at ``tcp``; None when the door is not open far enough for
        the hand to fit behind it there, or its edge is unknown."""
        if self.edge is None:
            return None
        rest_grasp = self.state.rest_grasp
        angle = self._angle(grasp)
        n, edge = self.outward, self.edge.point
        if np.linalg.norm(edge - rest_grasp) <= 1e-6:
            return None
        u = unit(edge - rest_grasp)
        back = -(self.edge.depth + INSIDE_CLEARANCE) * n
        out = rotate_about(tcp, self.pivot, self.axis, -angle)  # the hand, in the door's frame at rest
        out = out + max(PREGRASP_OFFSET - float((out - rest_grasp) @ n), 0.0) * n
        path = [out, edge + EDGE_CLEARANCE * u + PREGRASP_OFFSET * n, edge + EDGE_CLEARANCE * u + back,
                edge - PUSH_INSET * u + back]
        front = float(rest_grasp @ n) - self.edge.depth  # the closed door's inside face: the body's front
        behind = [rotate_about(p, self.pivot, self.axis, angle) for p in path[2:]]
        if min(float(p @ n) for p in behind) < front + FIT_CLEARANCE:
            return None
        return path

    def _open_target(self, tcp: np.ndarray, press: np.ndarray) -> np.ndarray:
        """The next TCP target while opening: ``pull_step`` along the planned line or arc, plus ``press``."""
        if not self.rotational:
            return tcp + self.pull_step * self.axis + press
        v = tcp - self.pivot
        radial = v - np.dot(v, self.axis) * self.axis
        if self.state.radius is None:
            self.state.radius = max(float(np.linalg.norm(radial)), 1e-3)
        radius = self.state.radius
        center = self.pivot + np.dot(v, self.axis) * self.axis
        # keep the grasp on the planned circle: correct radial drift, then advance along the arc
        on_circle = center + radial / max(np.linalg.norm(radial), 1e-9) * radius
        return rotate_about(on_circle, self.pivot, self.axis, self.pull_step / radius) + press

    def _aligned_target(self, tcp: np.ndarray, grasp: np.ndarray, outward: np.ndarray) -> np.ndarray:
        """The next waypoint of an aligned approach: down the line ``grasp + s * outward`` by at most
        :data:`ALIGNED_STEP`, or no further down it while the TCP is off it by more than the tolerance."""
        rel = tcp - grasp
        depth = float(rel @ outward)
        off_line = np.linalg.norm(rel - depth * outward)
        advance = ALIGNED_STEP if off_line <= self.lateral_tolerance else 0.0
        return grasp + max(depth - advance, 0.0) * outward

    # ----- one step ---------------------------------------------------------------------------------
    def _read(self, obs: np.ndarray) -> Reading:
        """The step's :class:`Reading`; remembers the grasp point (and, on the first step, where it rests)."""
        state = self.state
        tcp, grasp = obs[OBS.TCP].astype(float), obs[OBS.GRASP].astype(float)
        if state.rest_grasp is None:
            state.rest_grasp = grasp
        last, state.last_grasp = state.last_grasp, grasp
        # how far the part moved towards closing in the last step, and in the step before
        closing = 0.0 if last is None else -float((grasp - last) @ self._opening_direction(grasp))
        closing_before, state.closing = state.closing, closing
        # an inside grip travels with closed fingers and grips by opening them
        travel, hold = (1.0, -1.0) if self.inside_grip else (-1.0, 1.0)
        press = PRESS_OFFSET * self._turned(self.press, grasp)
        return Reading(tcp, grasp, obs[OBS.TOUCH], closing, closing_before, press, travel, hold)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for observation ``obs`` (the environments' layout, :mod:`spark_bench.envs.observation`)."""
        reading = self._read(obs)
        self.state.phase_steps += 1
        move = self.PHASES[self.state.phase](self, reading)
        if move.then is not None:
            self._next(move.then)
        action = np.empty(4, dtype=np.float32)
        action[:3] = np.clip((move.target - reading.tcp) / MAX_STEP, -1.0, 1.0)
        action[3] = move.grip
        return action

    def _travel_grip(self, reading: Reading) -> float:
        """The finger command while travelling to the grasp."""
        return reading.travel if self.approach_grip is None else self.approach_grip

    # ----- the phases ---------------------------------------------------------------------------------
    def _pregrasp(self, r: Reading) -> Move:
        """In front of the grasp point, along the part's outward direction (a door's re-grasp backs straight
        out of its face first, and waits while the door still swings)."""
        state = self.state
        outward = self._turned(self.outward, r.grasp)
        target = r.grasp + PREGRASP_OFFSET * outward
        then = None
        if not state.cleared:  # a door's re-grasp: straight out first, away from its face
            depth = float((r.tcp - r.grasp) @ outward)
            if depth < PREGRASP_OFFSET - WAYPOINT_TOLERANCE and state.phase_steps <= PREGRASP_STEPS // 2:
                target = r.tcp + (PREGRASP_OFFSET - depth) * outward
            else:
                state.cleared, state.distances = True, []
        if state.cleared:
            error = target - r.tcp
            if self.aligned:  # on the approach line, not just near the waypoint
                error = error - np.dot(error, outward) * outward
            tolerance = self.lateral_tolerance if self.aligned else WAYPOINT_TOLERANCE
            distance = float(np.linalg.norm(error))
            swinging = state.regrasps and self.swinging and abs(r.closing) > PUSH_GUARD
            if swinging and state.phase_steps <= 2 * PREGRASP_STEPS:
                state.distances = []  # a door still swinging: wait for it to come to rest (not for ever)
            elif distance < tolerance or state.phase_steps > PREGRASP_STEPS or self._stalled(distance):
                then = "approach"
        return Move(target, self._travel_grip(r), then)

    def _approach(self, r: Reading) -> Move:
        """In to the grasp point (aligned: down the approach line; a door's re-grasp: slowly, stopping where
        the hand meets the door)."""
        state = self.state
        target = self._aligned_target(r.tcp, r.grasp, self._turned(self.outward, r.grasp)) if self.aligned else r.grasp
        ajar = (state.regrasps > 0 and self.swinging
                and float(np.linalg.norm(r.grasp - state.rest_grasp)) > AJAR_DISTANCE)
        if ajar:  # a door's re-grasp: slowly
            step = target - r.tcp
            target = r.tcp + step * min(1.0, REGRASP_STEP / max(float(np.linalg.norm(step)), 1e-9))
        limit = ALIGNED_APPROACH_STEPS if self.aligned else APPROACH_STEPS
        distance = float(np.linalg.norm(r.grasp - r.tcp))
        pushed = ajar and _met(r.touch, r.closing, r.closing_before)
        if pushed:  # close where the hand is, and stay there (not following the door)
            target = state.hold = r.tcp
        then = None
        if (distance < WAYPOINT_TOLERANCE or state.phase_steps > limit or self._stalled(distance)
                or pushed):
            then = "press" if self.inside_grip else "close"
        return Move(target, self._travel_grip(r), then)

    def _press(self, r: Reading) -> Move:
        """Inside grip: press towards the notch's inner wall before the fingers open against its sides."""
        return Move(r.grasp + r.press, self._travel_grip(r), "close" if self.state.phase_steps >= PRESS_STEPS else None)

    def _close(self, r: Reading) -> Move:
        """Close the fingers on the grasp (or where the hand met a door); gradually for an aligned approach."""
        state = self.state
        target, grip = (r.grasp + r.press if state.hold is None else state.hold), r.hold
        if self.aligned:  # close gradually: thin pads slamming shut from beside a thin lip can pass through it
            grip = grip + (self.approach_grip - grip) * (1.0 - state.phase_steps / CLOSE_STEPS)
        return Move(target, grip, "open" if state.phase_steps >= CLOSE_STEPS else None)

    def _around(self, r: Reading) -> Move:
        """Round a door's free edge to behind its inside face, waypoint by waypoint (fingers open while
        backing out, then closed)."""
        state = self.state
        angle = self._angle(r.grasp)
        target = rotate_about(state.around[0], self.pivot, self.axis, angle)
        grip = -1.0 if len(state.around) == 4 else 1.0  # open while backing out, then closed
        distance = float(np.linalg.norm(target - r.tcp))
        behind = len(state.around) == 1 and _met(r.touch, r.closing, r.closing_before)
        then = None
        if (distance < AROUND_TOLERANCE or state.phase_steps > AROUND_STEPS or self._stalled(distance)
                or behind):  # behind the door, touching it: push from here (chasing the waypoint shuts it)
            state.around.pop(0)
            then = "around" if state.around else "push"
            state.radius = None
        return Move(target, grip, then)

    def _push(self, r: Reading) -> Move:
        """Along the opening arc, pressing on the door's inside face."""
        return Move(self._open_target(r.tcp, np.zeros(3)), 1.0)

    def _open(self, r: Reading) -> Move:
        """Pull along the planned line or swing along the planned arc, holding the part; when the handle has
        slipped out of the fingers, re-grasp it (:meth:`_slipped`)."""
        if np.linalg.norm(r.grasp - r.tcp) > REGRASP_DISTANCE and self.state.regrasps < MAX_REGRASPS:
            return self._slipped(r)
        return Move(self._open_target(r.tcp, r.press), r.hold)

    def _slipped(self, r: Reading) -> Move:
        """The handle slipped out of the fingers: a door open far enough is pushed open from inside (round its
        free edge); otherwise open the fingers and go back in front of the handle (a door's hand backing
        straight out of its face first)."""
        state = self.state
        state.regrasps += 1
        path = self._push_path(r.tcp, r.grasp) if self.swinging else None
        if path is not None:  # a door open far enough: push it open from inside
            state.around = path
            return Move(rotate_about(path[0], self.pivot, self.axis, self._angle(r.grasp)), -1.0, "around")
        state.radius, state.cleared, state.hold = None, not self.swinging, None
        outward = self._turned(self.outward, r.grasp)
        target = r.grasp + PREGRASP_OFFSET * outward
        if not state.cleared:
            target = r.tcp + max(PREGRASP_OFFSET - float((r.tcp - r.grasp) @ outward), 0.0) * outward
        return Move(target, self._travel_grip(r), "pregrasp")

    #: The method of each phase.
    PHASES = {"pregrasp": _pregrasp, "approach": _approach, "press": _press, "close": _close, "open": _open,
              "around": _around, "push": _push}
