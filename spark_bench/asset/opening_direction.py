"""Which way a part opens, read from the asset: each joint turned so that it opens toward its upper limit.

spark-bench's joints rest at their lower limit and open toward their upper one (``Joint.rest_value``,
``Joint.open_value``). PartNet-Mobility's URDFs are written so; a format whose file draws every part at a pose of
its own, the *drawn* pose (MJCF's ``qpos0``, a USD stage's bodies as placed), need not be: much robot-learning
MJCF writes a drawer that rests closed at its **upper** limit and slides out toward the lower one (Meta-World's
drawer, ``range="-0.16 0"``), or rests inside its range (LIBERO's white cabinet, ``range="-0.16 0.01"``, 1 cm of
play behind the closed drawer). Read with the convention as it stands, such a drawer rests pulled out and
"opens" into its cabinet.

:func:`orient_joints` reads the direction once, where the readers build the asset (:mod:`.mjcf_model`,
:mod:`.usd_model`), so that everything downstream (the metrics, the sim checks, the environments, the opening
score and its drive check) sees a joint that opens toward its upper limit:

- the joint's drawn value at its lower limit: as written;
- at its upper limit (or beyond it): the part opens toward the lower limit; the joint is read about the opposite
  axis with the range negated, ``[-upper, -lower]`` (the same motion, its rest now the lower limit);
- strictly inside the range: the geometry says. The part is moved to each limit (every other joint as drawn) and
  the share of its surface inside the convex hull of the rest of the object is measured there: a part opens toward
  the limit where it leaves the object (a drawer pulled out, a door swung away from its carcass), so the joint is
  turned when the upper limit holds clearly more of it inside (:data:`INSIDE_MARGIN`); a part that neither limit
  moves into the object (a knob, a lid with nothing beneath it) keeps its range as written.

URDFs are not read so: their joints follow PartNet-Mobility's convention (``docs/conventions.md``, Joint types),
whatever pose their meshes are drawn in. Every joint looked at gets an :class:`Orientation` saying which rule
decided; the readers keep them in ``asset.meta["opening_direction"]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mesh import sample_surface
from spark_bench.asset.model import ArticulatedAsset, Joint

#: The geometry turns a joint only when its part at the upper limit has at least this much more of its surface
#: (a fraction) inside the hull of the rest of the object than at the lower limit: a clear difference, not noise.
INSIDE_MARGIN = 0.05
#: Surface samples of a part for the geometry rule (seeded: the same asset always reads the same way).
PART_SAMPLES = 2000
#: A limit within this fraction of the range (and 1e-9) of the drawn value is where the part is drawn.
AT_LIMIT = 1e-6


@dataclass
class Orientation:
    """How one joint's opening direction was read.

    :param joint: the joint's name
    :param toward: the limit it opens toward as the file writes it: ``upper`` (read as written) or ``lower``
        (read about the opposite axis, the range negated)
    :param rule: ``rest at lower``, ``rest at upper``, ``geometry`` or ``no geometry`` (drawn inside the range
        and nothing to tell the way by: read as written)
    :param written: the range as the file writes it (radians or metres)
    :param drawn: the joint's value in the pose the file draws
    :param inside: for the geometry rule, the share of the part's surface inside the rest of the object at the
        lower and at the upper limit
    """

    joint: str
    toward: str
    rule: str
    written: tuple[float, float]
    drawn: float = 0.0
    inside: tuple[float, float] | None = None

    def to_dict(self) -> dict:
        out = {"joint": self.joint, "opens_toward": self.toward, "rule": self.rule,
               "written": [float(v) for v in self.written], "drawn_at": float(self.drawn)}
        if self.inside is not None:
            out["inside_at_lower_upper"] = [round(float(v), 4) for v in self.inside]
        return out


def flip(joint: Joint) -> None:
    """Turn ``joint`` about the opposite axis with its range negated: the same motion, the limits swapped."""
    joint.axis = -np.asarray(joint.axis, dtype=float)
    joint.lower, joint.upper = 0.0 - float(joint.upper), 0.0 - float(joint.lower)  # 0.0 - x: no -0.0


def _hull_equations(points: np.ndarray) -> np.ndarray | None:
    """The facet planes ``n . p + d <= 0`` (inside) of the points' convex hull; None when they span no volume."""
    from scipy.spatial import ConvexHull, QhullError

    if len(points) < 4:
        return None
    try:
        return ConvexHull(points).equations
    except (QhullError, ValueError):
        return None


def _inside_share(points: np.ndarray, planes: np.ndarray, tolerance: float) -> float:
    """The share of ``points`` inside the convex hull given by ``planes`` (within ``tolerance``)."""
    signed = points @ planes[:, :3].T + planes[:, 3]
    return float(np.mean(np.all(signed <= tolerance, axis=1)))


def _part_motion(asset: ArticulatedAsset, joint: Joint, value: float, drawn: dict[str, float]) -> np.ndarray:
    """4x4 world motion of ``joint``'s part from the pose as drawn to ``joint`` at ``value``."""
    rest = asset.link_poses(drawn)[joint.child]
    moved = asset.link_poses({**drawn, joint.name: value})[joint.child]
    return moved @ np.linalg.inv(rest)


def inside_at_limits(asset: ArticulatedAsset, joint: Joint, drawn: dict[str, float]) -> tuple[float, float] | None:
    """The share of ``joint``'s part surface inside the convex hull of the rest of the object (every other joint
    as drawn), with the part at its lower and at its upper limit; None when the part or the rest has no volume
    to tell by.

    :param asset: the object
    :param joint: a limited movable joint of it
    :param drawn: every movable joint's value in the pose the file draws
    """
    moving = set(asset.moving_links(joint.name))
    part = asset.mesh(drawn, links=[n for n in asset.links if n in moving])
    others = asset.mesh(drawn, links=[n for n in asset.links if n not in moving])
    if len(part.faces) == 0 or len(others.vertices) < 4:
        return None
    planes = _hull_equations(np.asarray(others.vertices, dtype=float))
    if planes is None:
        return None
    size = float(np.linalg.norm(np.ptp(np.concatenate([part.vertices, others.vertices]), axis=0)))
    tolerance = 1e-4 * size
    samples = sample_surface(part, PART_SAMPLES, seed=0)
    shares = []
    for value in (joint.lower, joint.upper):
        motion = _part_motion(asset, joint, value, drawn)
        shares.append(_inside_share(samples @ motion[:3, :3].T + motion[:3, 3], planes, tolerance))
    return shares[0], shares[1]


def orient_joint(asset: ArticulatedAsset, joint: Joint, drawn: dict[str, float]) -> Orientation | None:
    """Read which way ``joint`` opens and turn it to open toward its upper limit (see the module docstring).

    :param asset: the object
    :param joint: one of its joints; None is returned for one without a range (fixed, continuous, unlimited)
    :param drawn: every movable joint's value in the pose the file draws (updated when ``joint`` is turned)
    """
    if joint.type not in (JointType.REVOLUTE, JointType.PRISMATIC) or not joint.has_limits:
        return None
    lower, upper, value = float(joint.lower), float(joint.upper), float(drawn.get(joint.name, 0.0))
    tolerance = 1e-9 + AT_LIMIT * max(upper - lower, 0.0)
    if value <= lower + tolerance:
        return Orientation(joint.name, "upper", "rest at lower", (lower, upper), value)
    if value >= upper - tolerance:
        flip(joint)
        drawn[joint.name] = 0.0 - value
        return Orientation(joint.name, "lower", "rest at upper", (lower, upper), value)
    inside = inside_at_limits(asset, joint, drawn)
    if inside is None:
        return Orientation(joint.name, "upper", "no geometry", (lower, upper), value)
    toward = "lower" if inside[1] - inside[0] >= INSIDE_MARGIN else "upper"
    if toward == "lower":
        flip(joint)
        drawn[joint.name] = 0.0 - value
    return Orientation(joint.name, toward, "geometry", (lower, upper), value, inside)


def orient_joints(asset: ArticulatedAsset, drawn: dict[str, float] | None = None) -> list[Orientation]:
    """:func:`orient_joint` on every joint of ``asset`` (in place), in file order; returns what was read.

    The geometry rule looks at each joint with every other as drawn, so the order of the joints does not
    matter: turning one leaves the pose it is drawn in where it was.

    :param asset: the object
    :param drawn: each movable joint's value in the pose the file draws (missing: 0, as for MJCF, whose ranges are
        read about ``qpos0``, and for a USD joint whose two frames meet as drawn)
    """
    values = {j.name: float((drawn or {}).get(j.name, 0.0)) for j in asset.movable_joints()}
    found = [orient_joint(asset, joint, values) for joint in list(asset.joints.values())]
    return [o for o in found if o is not None]
