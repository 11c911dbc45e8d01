"""The sim-readiness checks in PhysX: each a number and a pass/fail, as :mod:`spark_bench.sim.checks` has them. Their
names and report order are :data:`spark_bench.sim.check_registry.PHYSX_CHECKS` (after ``mesh_files``).

=====================  =========================================================  ==============================
check                  value                                                      passes when
=====================  =========================================================  ==============================
``physx_loads``        convex hulls given to PhysX (after splitting)              PhysX builds the articulation
                                                                                  (hulls over 255 vertices or
                                                                                  255 polygons split first; a
                                                                                  hull whose cooking moved its
                                                                                  surface > 0.5 % of the size
                                                                                  is noted)
``mass_inertia``       smallest mass of a moving link (kg), as PhysX reads it     all > 0 and finite, principal
                                                                                  moments > 0 with a + b >= c
``joint_limits``       moving joints PhysX built                                  finite limits with lower <
                                                                                  upper (equal: built fixed), as
                                                                                  PhysX reads them back
``rest_stability``     largest joint drift after 2 s, fraction of its range       finite, drift <= 2 % (or the
                                                                                  part moved < 0.1 % of the size)
``rest_penetration``   deepest contact between two links at rest / object size    <= 0.5 %
``joint_sweep``        smallest fraction of a range reached or returned           :mod:`.sweep`
=====================  =========================================================  ==============================

Joint dynamics are the prepared ones (:attr:`PreparedObject.dynamics`): armature as PhysX's joint armature;
viscous damping as a generalized force each step; MuJoCo's dry friction (``frictionloss``) at rest as a PhysX
velocity drive to zero whose force is capped at it (it holds a part up to that force and slides beyond, as a
friction constraint does). The tolerances are the MuJoCo checks' (:mod:`spark_bench.sim.check_rest`). MuJoCo's
``settled`` exemption (a part that only came out of an overlap it started in) is not made: the hulls of a part
and its parent no longer overlap at rest (:mod:`spark_bench.sim.rest_trim`).
"""

from __future__ import annotations

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.sim.check_rest import (
    PENETRATION_TOLERANCE,
    REST_DRIFT_FLOOR,
    REST_DRIFT_TOLERANCE,
    REST_SECONDS,
)
from spark_bench.sim.mjcf import subtree_mass
from spark_bench.sim.physical import axis_inertia
from spark_bench.sim.physx.build import PhysxObject
from spark_bench.sim.physx.hulls import MAX_POLYGONS, MAX_VERTICES
from spark_bench.sim.physx.query import PairQuery
from spark_bench.sim.results import CheckResult
from spark_bench.sim.sweep import SweptJoint

#: The damping of the drive that holds a joint by friction at rest, in inertias per time step.
HOLD_DAMPING = 1000.0


def hull_name(owner: tuple[str, int] | None) -> str:
    """A hull as the MuJoCo checks name it (``link_collision_k``)."""
    return "carrier" if owner is None else f"{owner[0]}_collision_{owner[1]}"


def joint_inertia(obj: PhysxObject, name: str) -> float:
    """The joint-space inertia of joint ``name`` with the others held: what it moves about its axis (kg m^2) or its
    mass (kg), plus its armature."""
    prepared = obj.prepared
    joint = prepared.asset.joints[name]
    props = subtree_mass(prepared, name)
    axis = np.asarray(joint.axis, float) / np.linalg.norm(joint.axis)
    own = axis_inertia(props, np.zeros(3), axis) if joint.is_rotational else props.mass
    return float(own + prepared.dynamics[name].armature)


def part_radius(obj: PhysxObject, name: str) -> float:
    """How far joint ``name``'s part reaches from its axis (m; 1 for a slide): the farthest vertex of its collision
    shapes from the axis line, at rest."""
    asset = obj.prepared.asset
    joint = asset.joints[name]
    if not joint.is_rotational:
        return 1.0
    point, axis = asset.joint_frames()[name]
    poses = asset.link_poses()
    best = 0.0
    for link in asset.moving_links(name):
        for shape in obj.prepared.shapes.get(link, []):
            world = np.asarray(shape.to_trimesh().vertices, float) @ poses[link][:3, :3].T + poses[link][:3, 3]
            d = world - point
            best = max(best, float(np.max(np.linalg.norm(d - np.outer(d @ axis, axis), axis=1), initial=0.0)))
    return best


def damping_force(obj: PhysxObject) -> np.ndarray:
    """The viscous damping of every joint as a generalized force at the current velocities."""
    qvel = np.asarray(obj.articulation.qvel, float)
    out = np.zeros_like(qvel)
    for name, index in obj.dof.items():
        out[index] = -obj.prepared.dynamics[name].damping * qvel[index]
    return out


def check_physx_loads(obj: PhysxObject) -> CheckResult:
    """PhysX built the object: every hull within its limits (those over them split), the hulls its cooking moved
    noted (the checks that follow judge what PhysX simulates)."""
    details = {**obj.hulls.to_dict(), "vertex_limit": MAX_VERTICES, "polygon_limit": MAX_POLYGONS,
               "cooked_moved": round(obj.cooked_moved, 6), "cooked_changed": obj.cooked_changed,
               "links": len(obj.articulation.links), "carriers": obj.carriers,
               "filtered_pairs": [f"{a}|{b}" for a, b in obj.filtered], "ignore_bits": obj.ignore_bits,
               "pcm": obj.pcm, "timestep": obj.timestep}
    notes = []
    if obj.hulls.split:
        notes.append(f"{sum(len(v) for v in obj.hulls.split.values())} hull(s) over PhysX's limits split into "
                     f"pieces within them")
    if obj.cooked_changed:  # what PhysX simulates, and what the checks below judge: said, not failed
        notes.append(f"PhysX's cooking moved the surface of {len(obj.cooked_changed)} hull(s) by more than "
                     f"{PENETRATION_TOLERANCE:.1%} of the object's size (up to {1000 * obj.cooked_moved:.2f} mm: it "
                     f"merges near-coplanar faces): {', '.join(obj.cooked_changed[:3])}")
    if notes:
        details["note"] = "; ".join(notes)
    return CheckResult(True, float(obj.hulls.hulls), details)


def check_mass_inertia(obj: PhysxObject) -> CheckResult:
    """Every PhysX link that moves has a positive, finite mass and valid principal moments, as PhysX reads them."""
    bad, masses = [], []
    for name, link in obj.links.items():
        if name == obj.prepared.asset.root:
            continue
        mass = float(link.component.mass)
        a, b, c = np.sort(np.asarray(link.component.inertia, float))
        masses.append(mass)
        if not (np.isfinite([mass, a, b, c]).all() and mass > 0 and a > 0 and a + b >= c * (1 - 1e-6)):
            bad.append(name)
    details = {"moving_links": len(masses)}
    if bad:
        details["reason"] = f"invalid mass or inertia in PhysX: {bad}"
    return CheckResult(not bad, float(min(masses, default=float("nan"))), details)


def check_joint_limits(obj: PhysxObject) -> CheckResult:
    """Every moving joint's limits are finite with lower < upper (a continuous joint has none; equal limits make a
    fixed joint) and PhysX reads back the limits it was given."""
    bad = []
    for name, joint in obj.joints.items():
        urdf = obj.prepared.asset.joints[name]
        (low, high), = np.asarray(joint.limit, float)
        if urdf.type == JointType.CONTINUOUS:
            continue
        wanted = np.array([urdf.lower, urdf.upper], float)
        if not (np.isfinite(wanted).all() and wanted[0] < wanted[1]):
            bad.append(f"{name}: limits {wanted.tolist()}")
        elif not np.allclose([low, high], wanted, rtol=1e-6, atol=1e-6):
            bad.append(f"{name}: PhysX holds [{low:.6g}, {high:.6g}] for {wanted.tolist()}")
    details = {"locked_as_fixed": obj.locked}
    if bad:
        details["reason"] = "joint limits PhysX does not take: " + "; ".join(bad)
    return CheckResult(not bad, float(len(obj.joints)), details)


def _hold_at_rest(obj: PhysxObject) -> None:
    """Armature, and dry friction as a velocity drive to zero capped at ``frictionloss``, on every joint."""
    dt = obj.timestep
    for name, joint in obj.joints.items():
        dynamics = obj.prepared.dynamics[name]
        joint.set_armature([dynamics.armature])
        # a damper that would stop the joint within a thousandth of a step, capped: below the cap a load moves the
        # part at most g dt / 1000 per second (a drive is a damper, not a constraint), beyond it the part slides
        joint.set_drive_property(0.0, HOLD_DAMPING * joint_inertia(obj, name) / dt, dynamics.frictionloss, "force")
        joint.set_drive_velocity_target(0.0)


def check_rest_stability(obj: PhysxObject, joints: list[SweptJoint], seconds: float = REST_SECONDS) -> CheckResult:
    """Gravity on, every joint free but for its friction and damping, from rest: a finite state and small drift
    (the MuJoCo check's tolerances: :data:`REST_DRIFT_TOLERANCE` of the range, or the part moved less than
    :data:`REST_DRIFT_FLOOR` of the object's size)."""
    obj.set_rest()
    _hold_at_rest(obj)
    size = obj.prepared.size
    finite = True
    for _ in range(int(round(seconds / obj.timestep))):
        obj.articulation.set_qf(damping_force(obj))
        obj.scene.step()
        if not np.all(np.isfinite(obj.articulation.qpos)):
            finite = False
            break
    qpos = np.asarray(obj.articulation.qpos, float)
    drift, moved, bad = {}, {}, {}
    for joint in joints:
        if joint.name not in obj.dof:
            continue
        span = (joint.upper - joint.lower) if joint.upper > joint.lower else 1.0
        signed = float(qpos[obj.dof[joint.name]]) - joint.rest
        drift[joint.name] = abs(signed) / span
        moved[joint.name] = abs(signed) * part_radius(obj, joint.name)
        if drift[joint.name] > REST_DRIFT_TOLERANCE and moved[joint.name] > REST_DRIFT_FLOOR * size:
            bad[joint.name] = drift[joint.name]
    worst = max(drift.values(), default=0.0) if finite else float("inf")
    details = {"seconds": seconds, "drift": {k: round(v, 5) for k, v in drift.items()},
               "displacement": {k: round(v, 6) for k, v in moved.items()}}
    if not finite:
        details["reason"] = "NaN or infinite state in PhysX"
    elif bad:
        name = max(bad, key=bad.get)
        details["reason"] = f"joint {name} drifted {drift[name]:.1%} of its range ({moved[name]:.4g} m) at rest"
    return CheckResult(finite and not bad, worst, details)


def rest_contacts(obj: PhysxObject) -> list[tuple[float, str, str]]:
    """``(depth, hull, hull)`` of every penetrating contact between two links at rest, the articulation's and the
    queried pairs' (:class:`~spark_bench.sim.physx.query.PairQuery`), deepest first."""
    obj.set_rest()
    obj.scene.step()  # a step's contacts are those at the poses it starts from
    found = []
    for contact in obj.scene.physx_system.get_contacts():
        if not contact.points:
            continue
        depth = -min(float(p.separation) for p in contact.points)
        if depth > 0:
            owners = [obj.shape_owner(b, s) for b, s in zip(contact.bodies, contact.shapes)]
            found.append((depth, hull_name(owners[0]), hull_name(owners[1])))
    obj.set_rest()
    if obj.filtered:
        found += [(c.depth, hull_name(c.shapes[0]), hull_name(c.shapes[1])) for c in PairQuery(obj).contacts()
                  if c.depth > 0]
    return sorted(found, reverse=True)


def check_rest_penetration(obj: PhysxObject) -> CheckResult:
    """Deepest contact between two links at rest, as a fraction of the object's size (at most
    :data:`PENETRATION_TOLERANCE`); excluded pairs are listed, not counted (PhysX does not collide them)."""
    size = obj.prepared.size
    found = rest_contacts(obj)
    depth, pair = (found[0][0], found[0][1:]) if found else (0.0, None)
    value = depth / size
    details = {"depth": depth, "size": size, "deepest_pair": list(pair) if pair else None,
               "queried_pairs": [f"{a}|{b}" for a, b in obj.filtered],
               "excluded_pairs": sorted(f"{a}|{b}" for a, b in obj.prepared.excluded)}
    if value > PENETRATION_TOLERANCE:
        details["reason"] = f"{pair[0]} and {pair[1]} interpenetrate by {value:.2%} of the object's size at rest"
    return CheckResult(value <= PENETRATION_TOLERANCE, value, details)
