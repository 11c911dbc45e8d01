"""Asset -> MuJoCo model, built with ``mujoco.MjSpec``.

Layout of the spec (names are those of the asset, so code on top of it can find things):

- one body per link, named as the link; the root link's body hangs from the world body with no joint
  (welded, at ``options.base_pos`` / ``base_quat``); fixed joints weld a body to its parent; revolute
  and continuous joints become hinges, prismatic ones slides, named as the URDF joints, with
  ``ref`` = the rest value so that ``qpos0`` is the rest configuration and ``qpos`` reads URDF values;
- per body, one visual mesh geom ``<link>_visual`` in default class ``visual`` (no contacts, group 2)
  and convex collision geoms ``<link>_collision_<k>`` in class ``collision`` (group 3);
- explicit inertials from the hulls and a density (:mod:`spark_bench.sim.physical`);
- every pair of bodies collides: ``<exclude>`` only for a parent-child pair whose hulls block the child's joint
  where the surfaces do not (:mod:`spark_bench.sim.phantom`) or whose overlap at rest no cut resolves (by
  construction: a cap over a bottle neck); the hulls of the other parent-child pairs that overlap at rest are cut
  apart (:mod:`spark_bench.sim.rest_trim`).
  MuJoCo's ``filterparent`` never applies between a body welded to the world and its children, so a
  drawer collides with its carcass; between two moving bodies it does, so non-overlapping moving
  parent-child pairs get explicit ``<pair>`` elements.

Angles in the spec are radians (``compiler.degree = False``); nothing else global is set, so a
gripper or a scene can be added to the same spec.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.contacts import add_contact_filters, geometric_parents
from spark_bench.sim.hulls import object_collision_shapes, object_size
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.physical import (
    GRAVITY,
    JointDynamics,
    MassProperties,
    axis_inertia,
    joint_dynamics,
    link_mass_properties,
    principal_inertia,
)
from spark_bench.sim.prepared import PreparedObject
from spark_bench.sim.shapes import CollisionReport, CollisionShape

FRICTION_SOLIMP = (0.999, 0.999, 0.001, 0.5, 2.0)
VISUAL_CLASS = "visual"
COLLISION_CLASS = "collision"
VISUAL_GROUP = 2
COLLISION_GROUP = 3
#: Display colours of the collision hulls, one per link (cycled).
HULL_COLOURS = [(0.90, 0.35, 0.25), (0.25, 0.60, 0.90), (0.35, 0.80, 0.35), (0.95, 0.75, 0.20),
                (0.70, 0.40, 0.85), (0.20, 0.80, 0.80), (0.95, 0.50, 0.70), (0.55, 0.55, 0.55)]


def prepare(asset: ArticulatedAsset, options: ConvertOptions | None = None,
            shapes: dict[str, list[CollisionShape]] | None = None, progress: bool = False) -> PreparedObject:
    """Collision shapes (CoACD through the cache), mass properties and joint dynamics of ``asset``.

    :param asset: the object
    :param options: conversion options
    :param shapes: collision shapes per link, when already computed
    :param progress: show CoACD progress
    """
    from spark_bench.paths import cache_dir

    options = options or ConvertOptions()
    for name in list(asset.links) + list(asset.joints):
        if name in ("world", "") or not name.isprintable():
            raise InputError(asset.source or asset.name, f"name {name!r} cannot be a MuJoCo body or joint name")
    report = CollisionReport()
    start = time.perf_counter()
    size = object_size(asset)
    if shapes is None:
        cache = cache_dir("coacd") if options.use_cache else None
        shapes = object_collision_shapes(asset, options, cache=cache, report=report, progress=progress, size=size)
    else:
        report.hulls = {name: len(s) for name, s in shapes.items()}
    report.seconds["shapes"] = time.perf_counter() - start
    prepared = PreparedObject(asset, options, shapes, {}, {}, size, report)
    _update_physics(prepared)
    _resolve_contacts(prepared)
    report.seconds["contacts"] = time.perf_counter() - start - report.seconds["shapes"]
    return prepared


def _resolve_contacts(prepared: PreparedObject) -> None:
    """Decide which parent-child pairs collide and make their hulls fit: exclude a pair whose hulls meet (at rest,
    or on the child's path) while the child's own path is free of the parent's surface (:mod:`.phantom`, judged
    on hulls cut apart at rest); cut apart the hulls of the other pairs that overlap at rest, from the hulls as
    made (:mod:`.rest_trim`; a pair no cut resolves, or with no single joint to judge it by, is excluded); bevel
    hinge edges (:mod:`.relief`); then recompute masses and joint dynamics from the final hulls."""
    from spark_bench.paths import cache_dir
    from spark_bench.sim.phantom import find_phantom_blocks, phantom_candidates
    from spark_bench.sim.relief import relieve
    from spark_bench.sim.rest_trim import rest_overlaps, trim_rest_overlaps
    from spark_bench.sim.shape_cache import contacts_as_cached, load_contacts, object_key, store_contacts

    mujoco = mujoco_module()
    cache = cache_dir("coacd") if prepared.options.use_cache else None
    key = object_key(prepared) if cache is not None else None
    cached = load_contacts(cache, key, prepared.size) if cache is not None else None
    if cached is not None:
        prepared.shapes, prepared.excluded, prepared.trim, prepared.relief, prepared.phantom = cached
        _update_physics(prepared)
        return

    def probe_model():
        spec = assemble_spec(prepared, visuals=False)
        # every parent-child contact on, as the final model has them (explicit pairs or unfiltered)
        spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
        for parent, child in sorted(prepared.excluded):
            spec.add_exclude(bodyname1=parent, bodyname2=child)
        return spec.compile()

    gap = 0.5 * prepared.options.clearance * prepared.size
    limit = prepared.options.trim_overlap * prepared.size
    prepared.excluded = {}  # none yet: the probe collides every pair
    model = probe_model()
    pairs = {(parent, child) for child, parent in geometric_parents(prepared).items()}
    at_rest: dict[tuple[str, str], float] = {}
    for o in rest_overlaps(model, mujoco.MjData(model), pairs):
        at_rest[(o.parent, o.child)] = max(at_rest.get((o.parent, o.child), 0.0), o.depth)
    judged = {(parent, child) for parent, child, _ in phantom_candidates(prepared)}
    by_construction = {pair: depth for pair, depth in at_rest.items() if pair not in judged and depth > limit}
    made = {link: list(shapes) for link, shapes in prepared.shapes.items()}  # the hulls as CoACD made them
    # the paths judged on hulls cut apart at rest (nearer the surfaces they wrap), as if every pair collided, with
    # what overlapped before the cuts
    prepared.excluded = dict(by_construction)
    _, unresolved = trim_rest_overlaps(prepared, probe_model, limit, gap)
    prepared.excluded.update(unresolved)
    decided: set[tuple[str, str]] = set()
    prepared.phantom = find_phantom_blocks(prepared, probe_model(), gap, at_rest, decided=decided)
    prepared.excluded.update({(b.parent, b.child): at_rest.get((b.parent, b.child), 0.0) for b in prepared.phantom})
    # then cut again from the hulls as made, only where a pair collides (probe_model excludes the others): an
    # excluded pair keeps its hulls whole, since what a cut takes off is gone for every other contact too (conv-10;
    # toaster 103555: its lever's tab, cut to nothing against the body it is excluded from, no longer met the
    # carriages it is modelled 20 mm into, a reviewed defect)
    prepared.shapes = made
    prepared.trim, unresolved = trim_rest_overlaps(prepared, probe_model, limit, gap)
    prepared.excluded.update(unresolved)
    # a hull left whole can meet, on a part's path, a hull it did not meet cut (a body's hull not cut for a door
    # that is excluded, in the way of a turntable): the pairs not judged yet are judged on the final hulls (a pair
    # judged blocked stays blocked: larger hulls only meet more, and deeper)
    more = find_phantom_blocks(prepared, probe_model(), gap, at_rest, skip=decided)
    prepared.phantom += more
    prepared.excluded.update({(b.parent, b.child): at_rest.get((b.parent, b.child), 0.0) for b in more})
    prepared.relief = relieve(prepared, probe_model, gap)
    if cache is not None and not prepared.report.coacd.failed:
        store_contacts(cache, key, prepared)
    # the model is built from what the cache gives back, stored or not (see as_cached), and its masses from
    # those shapes, as on a cache hit above
    contacts_as_cached(prepared)
    _update_physics(prepared)


def _update_physics(prepared: PreparedObject) -> None:
    """Masses and joint dynamics from the current shapes."""
    asset, options = prepared.asset, prepared.options
    moving = {name for joint in asset.movable_joints() for name in asset.moving_links(joint.name)}
    materials = {name: options.material_of(asset.category, name, name in moving) for name in asset.links}
    prepared.mass = {name: link_mass_properties(prepared.shapes.get(name, []), materials[name].density,
                                                materials[name].wall)
                     for name in asset.links}
    prepared.dynamics = {j.name: _dynamics_of(prepared, j.name) for j in asset.movable_joints()}


def _transform_props(props: MassProperties, transform: np.ndarray) -> MassProperties:
    rotation = transform[:3, :3]
    com = rotation @ props.com + transform[:3, 3]
    return MassProperties(props.mass, com, rotation @ props.inertia @ rotation.T, props.volume)


def subtree_mass(prepared: PreparedObject, joint_name: str) -> MassProperties:
    """Mass properties of everything ``joint_name`` moves, in that joint's frame at rest."""
    asset = prepared.asset
    joint = asset.joints[joint_name]
    poses = asset.link_poses()
    frame = np.linalg.inv(poses[joint.parent] @ joint.origin)
    parts = [_transform_props(prepared.mass[name], frame @ poses[name]) for name in asset.moving_links(joint_name)]
    total = sum(p.mass for p in parts)
    com = sum(p.mass * p.com for p in parts) / total
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.com - com
        inertia += p.inertia + p.mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return MassProperties(total, com, inertia, sum(p.volume for p in parts))


def base_rotation(options: ConvertOptions) -> np.ndarray:
    """3x3 rotation of the root link in the world (from ``options.base_quat``, w x y z)."""
    w, x, y, z = np.asarray(options.base_quat, float) / np.linalg.norm(options.base_quat)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def gravity_pull(prepared: PreparedObject, joint_name: str, props: MassProperties) -> float:
    """Generalized gravity force on ``joint_name`` at rest, positive when it pulls the joint away
    from its rest value into its range (a drop-down door falling open); 0 otherwise."""
    asset = prepared.asset
    joint = asset.joints[joint_name]
    rotation = base_rotation(prepared.options) @ (asset.link_poses()[joint.parent] @ joint.origin)[:3, :3]
    weight = rotation.T @ np.array([0.0, 0.0, -GRAVITY * props.mass])  # in the joint frame
    axis = np.asarray(joint.axis, float) / np.linalg.norm(joint.axis)
    pull = float(axis @ np.cross(props.com, weight)) if joint.is_rotational else float(axis @ weight)
    if joint.type == JointType.CONTINUOUS:
        return abs(pull)
    rest = joint.rest_value
    if rest <= joint.lower + 1e-9:
        return max(pull, 0.0)
    if rest >= joint.upper - 1e-9:
        return max(-pull, 0.0)
    return abs(pull)


def _dynamics_of(prepared: PreparedObject, joint_name: str) -> JointDynamics:
    joint = prepared.asset.joints[joint_name]
    props = subtree_mass(prepared, joint_name)
    axis = np.asarray(joint.axis, float) / np.linalg.norm(joint.axis)
    offset = props.com - np.dot(props.com, axis) * axis
    size = _links_size(prepared, prepared.asset.moving_links(joint_name))
    options = prepared.options
    return joint_dynamics("hinge" if joint.is_rotational else "slide", props.mass,
                          axis_inertia(props, np.zeros(3), axis), float(np.linalg.norm(offset)), size,
                          options.joint_damping, options.joint_armature, options.joint_frictionloss,
                          joint.damping, joint.friction, gravity_pull(prepared, joint_name, props))


def _links_size(prepared: PreparedObject, links: list[str]) -> float:
    poses = prepared.asset.link_poses()
    points = [s.to_trimesh().vertices @ poses[n][:3, :3].T + poses[n][:3, 3]
              for n in links for s in prepared.shapes.get(n, [])]
    if not points:
        return 0.1 * prepared.size
    return float(np.linalg.norm(np.ptp(np.concatenate(points), axis=0)))


# ----- spec assembly ------------------------------------------------------------------------------
def _quat(rotation: np.ndarray) -> list[float]:
    mujoco = mujoco_module()
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).reshape(9))
    return quat.tolist()


def write_obj_file(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """A bare OBJ (``v`` and ``f`` lines), the format MuJoCo and PyBullet both read."""
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64) + 1
    text = ("v %.9g %.9g %.9g\n" * len(vertices)) % tuple(vertices.ravel())
    text += ("f %d %d %d\n" * len(faces)) % tuple(faces.ravel())
    Path(path).write_text(text)


class _MeshSink:
    """Puts mesh data into the spec: inline (``uservert``) or as OBJ files under ``mesh_dir``."""

    def __init__(self, spec, mesh_dir: Path | None):
        self.spec, self.mesh_dir = spec, mesh_dir
        if mesh_dir is not None:
            Path(mesh_dir).mkdir(parents=True, exist_ok=True)

    def add(self, name: str, vertices: np.ndarray, faces: np.ndarray, shell: bool):
        mujoco = mujoco_module()
        mesh = self.spec.add_mesh(name=name)
        if self.mesh_dir is None:
            mesh.uservert = np.asarray(vertices, np.float32).reshape(-1).tolist()
            mesh.userface = np.asarray(faces, np.int32).reshape(-1).tolist()
        else:
            write_obj_file(Path(self.mesh_dir) / f"{name}.obj", vertices, faces)
            mesh.file = f"{name}.obj"
        if shell:  # visual meshes may be open or flat: their volume is meaningless, their area is not
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        return mesh


def _add_defaults(spec, options: ConvertOptions):
    visual = spec.add_default(VISUAL_CLASS, spec.default)
    visual.geom.contype = 0
    visual.geom.conaffinity = 0
    visual.geom.group = VISUAL_GROUP
    visual.geom.density = 0.0
    visual.geom.mass = 0.0
    collision = spec.add_default(COLLISION_CLASS, spec.default)
    collision.geom.contype = 1
    collision.geom.conaffinity = 1
    collision.geom.group = COLLISION_GROUP
    collision.geom.condim = 3
    collision.geom.friction = [options.friction, 0.005, 0.0001]
    collision.geom.density = 0.0
    collision.geom.mass = 0.0
    return visual, collision


def _add_collision_geoms(body, sink: _MeshSink, link: str, shapes: list[CollisionShape], default,
                         colour) -> None:
    mujoco = mujoco_module()
    rgba = list(colour) + [1.0]
    for k, shape in enumerate(shapes):
        name = f"{link}_collision_{k}"
        pos, quat = shape.origin[:3, 3].tolist(), _quat(shape.origin[:3, :3])
        if shape.kind == "box":
            body.add_geom(default=default, name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=pos, quat=quat,
                          size=(0.5 * np.asarray(shape.size)).tolist(), rgba=rgba)
        elif shape.kind == "cylinder":
            body.add_geom(default=default, name=name, type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=pos, quat=quat,
                          size=[float(shape.size[0]), 0.5 * float(shape.size[1]), 0.0], rgba=rgba)
        elif shape.kind == "sphere":
            body.add_geom(default=default, name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=pos,
                          size=[float(shape.size[0]), 0.0, 0.0], rgba=rgba)
        else:
            sink.add(name, shape.vertices, shape.faces, shell=False)
            body.add_geom(default=default, name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, rgba=rgba)


def _set_inertial(body, props: MassProperties) -> None:
    moments, axes = principal_inertia(props.inertia)
    body.explicitinertial = True
    body.mass = float(props.mass)
    body.ipos = props.com.tolist()
    body.iquat = _quat(axes)
    body.inertia = moments.tolist()


def assemble_spec(prepared: PreparedObject, mesh_dir: Path | None = None, visuals: bool = True):
    """The ``MjSpec`` of a prepared object (see the module docstring for its layout).

    :param prepared: output of :func:`prepare`
    :param mesh_dir: write meshes as OBJ files here and reference them (None: meshes inline)
    :param visuals: add the visual geoms; without them the model simulates the same (they have no
        contacts and no mass) and compiles much faster (a watertight remesh has ~10^5 faces per link)
    """
    mujoco = mujoco_module()
    asset, options = prepared.asset, prepared.options
    spec = mujoco.MjSpec()
    spec.modelname = asset.name or "object"
    spec.compiler.degree = False
    if mesh_dir is not None:
        spec.meshdir = str(mesh_dir)
    visual_default, collision_default = _add_defaults(spec, options)
    sink = _MeshSink(spec, mesh_dir)
    bodies = {}
    root = asset.root
    bodies[root] = spec.worldbody.add_body(name=root, pos=list(map(float, options.base_pos)),
                                           quat=list(map(float, options.base_quat)))
    order = [root] + [j.child for j in asset.topological_joints()]
    for joint in asset.topological_joints():
        transform = joint.origin @ joint.motion(joint.rest_value)
        body = bodies[joint.parent].add_body(name=joint.child, pos=transform[:3, 3].tolist(),
                                             quat=_quat(transform[:3, :3]))
        bodies[joint.child] = body
        if joint.is_movable:
            dyn = prepared.dynamics[joint.name]
            kind = mujoco.mjtJoint.mjJNT_HINGE if joint.is_rotational else mujoco.mjtJoint.mjJNT_SLIDE
            mj_joint = body.add_joint(name=joint.name, type=kind, axis=np.asarray(joint.axis, float).tolist(),
                                      pos=[0.0, 0.0, 0.0], ref=float(joint.rest_value))
            mj_joint.damping = [dyn.damping, 0.0, 0.0]  # MuJoCo 4: polynomial damping coefficients
            mj_joint.armature = dyn.armature
            mj_joint.frictionloss = dyn.frictionloss
            # MuJoCo's default friction impedance (0.9) lets 10% of the load through, so a latched part
            # creeps; 0.999 makes dry friction hold, which is what it is for
            mj_joint.solimp_friction = list(FRICTION_SOLIMP)
            if joint.type == JointType.CONTINUOUS:
                mj_joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
            else:
                mj_joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
                # MuJoCo needs lower < upper; a URDF joint locked by equal limits keeps a 1 um range
                mj_joint.range = [float(joint.lower), max(float(joint.upper), float(joint.lower) + 1e-6)]
    for index, name in enumerate(order):
        body = bodies[name]
        _set_inertial(body, prepared.mass[name])
        visual = prepared.visual(name) if visuals else None
        if visual is not None:
            vertices, faces, rgba = visual
            spec.add_material(name=f"{name}_material", rgba=rgba, specular=0.2, shininess=0.3)
            sink.add(f"{name}_visual", vertices, faces, shell=True)
            body.add_geom(default=visual_default, name=f"{name}_visual", type=mujoco.mjtGeom.mjGEOM_MESH,
                          meshname=f"{name}_visual", material=f"{name}_material")
        _add_collision_geoms(body, sink, name, prepared.shapes.get(name, []), collision_default,
                             HULL_COLOURS[index % len(HULL_COLOURS)])
    return spec


def build_spec(asset: ArticulatedAsset, options: ConvertOptions | None = None, *,
               prepared: PreparedObject | None = None, mesh_dir: Path | None = None, visuals: bool = True):
    """The object as a ``mujoco.MjSpec``, ready to compile or to extend (see the module docstring).

    :param asset: the object
    :param options: conversion options (default :class:`ConvertOptions`)
    :param prepared: reuse an earlier :func:`prepare` result (collision hulls, masses)
    :param mesh_dir: write meshes as OBJ files there (None: meshes inline in the spec)
    :param visuals: add the visual geoms (False: the same physics, no visual meshes to compile)
    """
    prepared = prepared if prepared is not None else prepare(asset, options)
    spec = assemble_spec(prepared, mesh_dir=mesh_dir, visuals=visuals)
    add_contact_filters(spec, prepared)
    return spec
