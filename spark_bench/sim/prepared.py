"""The object as prepared for the simulators (:class:`PreparedObject`): collision shapes, masses, joint
dynamics and the contact decisions, computed once by :func:`spark_bench.sim.mjcf.prepare` and read by the
contact filters, the hinge relief, the MJCF and PyBullet writers and the checks.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.physical import JointDynamics, MassProperties
from spark_bench.sim.shapes import CollisionReport, CollisionShape


@dataclass
class PreparedObject:
    """Everything computed before the spec is assembled (reused by the checks and the PyBullet writer).

    :param asset: the object
    :param options: the options used
    :param shapes: collision shapes per link (link frame)
    :param mass: mass properties per link (link frame)
    :param dynamics: joint parameters per movable joint
    :param size: the object's bounding-box diagonal at rest (every relative tolerance refers to it)
    :param report: how the collision shapes were made
    :param excluded: parent-child body pairs that do not collide, with their overlap depth at rest
    :param relief: hinge-relief cuts made (:class:`~spark_bench.sim.relief.ReliefCut`)
    """

    asset: ArticulatedAsset
    options: ConvertOptions
    shapes: dict[str, list[CollisionShape]]
    mass: dict[str, MassProperties]
    dynamics: dict[str, JointDynamics]
    size: float
    report: CollisionReport
    excluded: dict[tuple[str, str], float] = field(default_factory=dict)
    relief: list = field(default_factory=list)
