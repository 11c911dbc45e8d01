"""The joint sweep in PhysX: every moving joint driven through its range, out and back, by PhysX's own joint drive.

The schedule, the servo's force limit and the pass rule are the MuJoCo sweep's (:mod:`spark_bench.sim.sweep`): one
joint at a time from its lower to its upper limit in 1.5 s, held 0.5 s, back in 1.5 s, held 0.5 s, the others held
at rest by their drives; the servo's force capped at :data:`~spark_bench.sim.sweep.FORCE_MARGIN` times what
friction, damping and inertia need and never below the part's weight at its far edge
(:func:`~spark_bench.sim.sweep.servo_limits`); gravity on the swept joint fed forward (PhysX's passive force); a
joint passes when it reaches :data:`~spark_bench.sim.sweep.SWEEP_REACH` of its range out and back (or stops short
by at most :data:`~spark_bench.sim.sweep.SWEEP_FLOOR` of the object's size). The servo is a PhysX articulation
drive (implicit, force-limited); the joint's viscous damping and dry friction act as generalized forces (the
friction smoothed over a small speed, so that an explicit force stays stable).

How a verdict was made (``verdict_by`` in each joint's details): ``contact`` where PhysX collides the part with
everything it can meet (the articulation's carrier links, :mod:`.build`), so a part running into its parent is
stopped by PhysX's contacts; ``query`` where the articulation filters the part and its parent
(:attr:`PhysxObject.filtered`): the part then swings through, and the sweep asks PhysX's contact generation on
copies of the two (:mod:`.query`) where they are every few steps; the first pose at which they interpenetrate by
more than they did at rest plus :data:`~spark_bench.sim.checks.PENETRATION_TOLERANCE` of the size is where the
part ran into its parent, and counts as where it stopped.
"""

from __future__ import annotations

import math

import numpy as np

from spark_bench.sim.checks import PENETRATION_TOLERANCE
from spark_bench.sim.mjcf import subtree_mass
from spark_bench.sim.physical import GRAVITY
from spark_bench.sim.physx.build import PhysxObject
from spark_bench.sim.physx.checks import damping_force, hull_name, joint_inertia, part_radius
from spark_bench.sim.physx.query import PairQuery
from spark_bench.sim.results import CheckResult
from spark_bench.sim.sweep import (
    HOLD_SECONDS,
    RAMP_SECONDS,
    SWEEP_FLOOR,
    SWEEP_REACH,
    SweptJoint,
    servo_limits,
)

#: Steps between two contact queries of a filtered pair.
QUERY_EVERY = 5
#: The friction force is ``frictionloss * tanh(v / v0)``, ``v0`` this fraction of the sweep's speed (or more, where
#: a stiffer one would not be stable).
FRICTION_SPEED = 0.05


class _Sweeper:
    """The servos and the schedule of one object's sweep."""

    def __init__(self, obj: PhysxObject, joints: list[SweptJoint]):
        self.obj, self.joints = obj, {j.name: j for j in joints if j.name in obj.dof}
        dt = obj.timestep
        self.servo, self.radius, self.friction, self.smooth = {}, {}, {}, {}
        for name, joint in self.joints.items():
            inertia = joint_inertia(obj, name)
            span = max(joint.upper - joint.lower, 1e-6)
            speed = span / RAMP_SECONDS
            dynamics = obj.prepared.dynamics[name]
            need = dynamics.frictionloss + dynamics.damping * speed + inertia * speed / 0.25
            self.radius[name] = part_radius(obj, name)
            weight = subtree_mass(obj.prepared, name).mass * GRAVITY * self.radius[name]
            force, kp = servo_limits(need, weight, inertia, span, dt)
            self.servo[name] = (force, kp, 2.0 * math.sqrt(kp * inertia))
            self.friction[name] = dynamics.frictionloss
            self.smooth[name] = max(FRICTION_SPEED * speed, dynamics.frictionloss * dt / inertia)
        self.query = PairQuery(obj) if obj.filtered else None

    def start(self) -> None:
        """Every joint at rest, its servo on and holding it there."""
        self.obj.set_rest()
        for name, joint in self.obj.joints.items():
            force, kp, kv = self.servo[name]
            joint.set_armature([self.obj.prepared.dynamics[name].armature])
            joint.set_drive_property(kp, kv, force, "force")
            joint.set_drive_target(self.joints[name].rest)
            joint.set_drive_velocity_target(0.0)

    def forces(self, swept: str) -> np.ndarray:
        """Damping and friction on every joint, gravity fed forward on the swept one."""
        qvel = np.asarray(self.obj.articulation.qvel, float)
        out = damping_force(self.obj)
        for name, index in self.obj.dof.items():
            out[index] -= self.friction[name] * math.tanh(qvel[index] / self.smooth[name])
        index = self.obj.dof[swept]
        out[index] += float(self.obj.articulation.compute_passive_force(True, True)[index])
        return out

    def run(self, targets: dict[str, list[float]], swept: str, watch: dict | None = None) -> tuple[float, float]:
        """Step through per-joint target lists; returns the highest and lowest value of the swept joint. ``watch``
        (filtered pairs to query, their rest depths, a tolerance) gets ``first``: ``(value, contact)`` at the first
        query over its depth."""
        steps = len(next(iter(targets.values())))
        index = self.obj.dof[swept]
        high, low = -np.inf, np.inf
        for k in range(steps):
            for name, values in targets.items():
                self.obj.joints[name].set_drive_target(values[k])
            self.obj.articulation.set_qf(self.forces(swept))
            self.obj.scene.step()
            value = float(self.obj.articulation.qpos[index])
            high, low = max(high, value), min(low, value)
            if watch is not None and watch.get("first") is None and k % QUERY_EVERY == 0:
                for contact in self.query.contacts(watch["pairs"]):
                    if contact.depth > watch["rest"].get((contact.parent, contact.child), 0.0) + watch["tolerance"]:
                        watch["first"] = (value, contact)
                        break
        return high, low


def _ramp(start: float, end: float, steps: int, hold: int) -> list[float]:
    return [start + (end - start) * min(1.0, (k + 1) / steps) for k in range(steps)] + [end] * hold


def _blocking_contacts(obj: PhysxObject, moving: set[str], top: int = 3) -> list[dict]:
    """The strongest contacts between the moving groups and the rest (what blocked the part)."""
    found: dict[tuple, list[float]] = {}
    for contact in obj.scene.physx_system.get_contacts():
        groups = [b.name for b in contact.bodies]
        inside = [g in moving for g in groups]
        if inside[0] == inside[1] or not contact.points:
            continue
        owners = [obj.shape_owner(b, s) for b, s in zip(contact.bodies, contact.shapes)]
        mine, other = (owners[0], owners[1]) if inside[0] else (owners[1], owners[0])
        if mine is None or other is None:
            continue
        force = sum(float(np.linalg.norm(p.impulse)) for p in contact.points) / obj.timestep
        depth = -min(float(p.separation) for p in contact.points)
        entry = found.setdefault((mine, other), [0.0, 0.0])
        entry[0], entry[1] = max(entry[0], force), max(entry[1], depth)
    ranked = sorted(found.items(), key=lambda kv: -kv[1][0])[:top]
    return [{"geom": hull_name(a), "blocked_by": hull_name(b), "force": round(f, 3), "depth": round(max(d, 0.0), 6),
             "body": a[0], "blocked_by_body": b[0]} for (a, b), (f, d) in ranked]


def _watch(sweeper: _Sweeper, name: str, moving: set[str]) -> dict | None:
    """What to query while ``name`` is swept: the filtered pairs with one side moving, their depths at rest."""
    obj = sweeper.obj
    pairs = [p for p in obj.filtered if (p[0] in moving) != (p[1] in moving)]
    if not pairs:
        return None
    obj.set_rest()
    rest = {(c.parent, c.child): max(c.depth, 0.0) for c in sweeper.query.contacts(pairs)}
    return {"pairs": pairs, "rest": rest, "tolerance": PENETRATION_TOLERANCE * obj.prepared.size, "first": None}


def sweep_joint(sweeper: _Sweeper, name: str, open_first: tuple[str, ...] = ()) -> dict:
    """Drive joint ``name`` out and back (after opening the joints in ``open_first``): the fraction of its range
    reached and returned, what blocked it, and how that was found (``verdict_by``)."""
    obj, joints = sweeper.obj, sweeper.joints
    joint = joints[name]
    moving = {obj.group_of[link] for link in obj.prepared.asset.moving_links(name)}
    watch = _watch(sweeper, name, moving)
    ramp, hold = int(RAMP_SECONDS / obj.timestep), int(HOLD_SECONDS / obj.timestep)
    sweeper.start()
    held = {n: [j.rest] * (ramp + hold) for n, j in joints.items()}
    if open_first:
        sweeper.run({**held, **{n: _ramp(joints[n].rest, joints[n].upper, ramp, hold) for n in open_first}}, name)
        held.update({n: [joints[n].upper] * (ramp + hold) for n in open_first})
    span = joint.upper - joint.lower
    reached, _ = sweeper.run({**held, name: _ramp(joint.lower, joint.upper, ramp, hold)}, name, watch)
    blocked = _blocking_contacts(obj, moving) if (reached - joint.lower) / span < 0.98 else []
    verdict_by, travelled = "contact", reached
    if watch is not None and watch["first"] is not None:  # it swung through its parent: it stopped where it met it
        value, contact = watch["first"]
        reached, verdict_by = min(reached, value), "query"
        blocked = [{"geom": hull_name(contact.shapes[0]), "blocked_by": hull_name(contact.shapes[1]),
                    "depth": round(contact.depth, 6), "body": contact.shapes[0][0],
                    "blocked_by_body": contact.shapes[1][0]}]
    _, lowest = sweeper.run({**held, name: _ramp(joint.upper, joint.lower, ramp, hold)}, name)
    reach = (reached - joint.lower) / span
    returned = (travelled - lowest) / (travelled - joint.lower) if travelled > joint.lower + 1e-12 else 1.0
    out = {"reached": round(float(np.clip(reach, 0, 1)), 4), "returned": round(float(np.clip(returned, 0, 1)), 4),
           "finite": bool(np.all(np.isfinite(obj.articulation.qpos))), "blocked_by": blocked,
           "opened_first": list(open_first), "verdict_by": verdict_by}
    if returned < 0.98:
        out["blocked_back_by"] = _blocking_contacts(obj, moving)
    return out


def _owner_joint(obj: PhysxObject, link: str, names: set[str]) -> str | None:
    """The swept joint that moves ``link`` (None for the fixed base)."""
    asset = obj.prepared.asset
    joint = asset.joint_of_child(link)
    while joint is not None:
        if joint.name in names:
            return joint.name
        joint = asset.joint_of_child(joint.parent)
    return None


def _passed(result: dict, floor: float) -> bool:
    reach = min(result["reached"], result["returned"])
    return result["finite"] and (reach >= SWEEP_REACH or result["shortfall"] <= floor)


def _with_shortfall(result: dict, full: float) -> dict:
    result["shortfall"] = round((1.0 - min(result["reached"], result["returned"])) * full, 6)
    return result


def check_joint_sweep(obj: PhysxObject, joints: list[SweptJoint]) -> CheckResult:
    """Sweep every moving joint, the others held at rest; a joint blocked by another moving part is swept again with
    those parts opened first, as the MuJoCo sweep does. Value: the smallest fraction of a range reached or
    returned (1 with no moving joint)."""
    sweeper = _Sweeper(obj, joints)
    floor = SWEEP_FLOOR * obj.prepared.size
    names = set(sweeper.joints)
    results = {}
    for joint in joints:
        name = joint.name
        if joint.upper - joint.lower < 1e-9 or name not in names:  # nothing to sweep (built as a fixed joint)
            results[name] = {"reached": 1.0, "returned": 1.0, "finite": True, "blocked_by": [], "opened_first": [],
                             "zero_range": True, "verdict_by": "contact", "shortfall": 0.0}
            continue
        full = (joint.upper - joint.lower) * sweeper.radius[name]
        result = _with_shortfall(sweep_joint(sweeper, name), full)
        blockers = tuple(sorted({o for b in result["blocked_by"]
                                 if (o := _owner_joint(obj, b["blocked_by_body"], names)) not in (None, name)}))
        if not _passed(result, floor) and blockers:
            retry = _with_shortfall(sweep_joint(sweeper, name, open_first=blockers), full)
            if _passed(retry, floor) or retry["reached"] > result["reached"]:
                retry["blocked_at_rest_by"] = result["blocked_by"]
                result = retry
        results[name] = result
    worst = min((min(r["reached"], r["returned"]) for r in results.values()), default=1.0)
    failed = [k for k, r in results.items() if not _passed(r, floor)]
    details = {"joints": results, "failed": failed, "floor": round(floor, 6),
               "verdict_by": sorted({r["verdict_by"] for r in results.values()})}
    if failed:
        details["reason"] = failure_reason(failed[0], results[failed[0]], sweeper.joints[failed[0]])
    return CheckResult(not failed, worst, details)


def failure_reason(name: str, result: dict, joint: SweptJoint) -> str:
    """One line for a joint that failed the sweep: how far it went, what it ran into, and how that was found."""
    head = f"joint {name} reached {result['reached']:.0%} and returned {result['returned']:.0%} of its range"
    out = result["reached"] < SWEEP_REACH or not result.get("blocked_back_by")
    blocked = result["blocked_by"] if out else result["blocked_back_by"]
    if not blocked:
        return f"{head} (no contact held it)"
    first = blocked[0]
    fraction = result["reached"] if out else result["reached"] * (1.0 - result["returned"])
    at = joint.lower + fraction * (joint.upper - joint.lower)
    where = f"{np.degrees(at):.0f} deg" if joint.rotational else f"{1000 * at:.0f} mm"
    deep = 1000 * first.get("depth", 0.0)
    pairs = ", ".join(f"{b['geom']} by {b['blocked_by']}" for b in blocked)
    how = "found by PhysX contact queries: the articulation does not collide the two" \
        if result["verdict_by"] == "query" else "PhysX contacts"
    way = "" if out else " on the way back"
    return (f"{head} (blocked{way}: {first['body']} runs into {first['blocked_by_body']} at {where}"
            + (f", {deep:.1f} mm deep" if deep >= 0.1 else "") + f": {pairs}; {how})")
