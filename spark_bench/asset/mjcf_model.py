"""An MJCF model compiled by MuJoCo and turned into an :class:`~spark_bench.asset.model.ArticulatedAsset`:
world-frame body poses, joint anchors and axes after forward kinematics at ``qpos0``, visual geoms in the
world frame at rest, one link per body.

MuJoCo does what the format leaves to its compiler: ``compiler angle`` (degrees, MJCF's default, turned
into radians), ``eulerseq``, ``meshdir``, default classes, mesh ``scale`` and ``refquat``. The model is
compiled for kinematics only: textures are dropped (their images are not needed; PhysX-Anything's are
PNGs beside the meshes), every geom stops colliding and every mesh takes a shell inertia, every body a unit
mass, so a part MuJoCo would refuse for its physics (a flat patch has no convex hull nor volume;
Particulate's parts are open surfaces cut from one mesh) is still read. None of these moves a vertex.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mjcf_names import ElementNames, element_names
from spark_bench.asset.model import ArticulatedAsset, Collision, Joint, Link, Visual
from spark_bench.asset.opening_direction import orient_joints
from spark_bench.errors import InputError

#: MuJoCo's viewer shows geom groups 0, 1 and 2 and hides 3 to 5 (``mjvOption.geomgroup``); robot
#: descriptions put collision-only geoms in group 3. The geoms of groups 0-2 are the visuals.
VISUAL_GROUPS = (0, 1, 2)
#: A limited hinge whose declared bounds all lie within a full turn and one of which spans at least
#: this many (declared) units reads as radians: with ``angle="degree"`` it is taken as radians written
#: where degrees are declared (a hinge of an object moving 1 to 6 degrees is not an articulation).
RADIAN_LOOKING_SPAN = 1.0


@dataclass
class Compiled:
    """A compiled model at rest.

    :param model: MuJoCo's ``MjModel``
    :param data: its ``MjData`` after ``mj_forward`` at ``qpos0``
    :param degree: whether the model declares its angles in degrees (``compiler angle``)
    :param eulerseq: ``compiler eulerseq``
    :param collides: per geom, whether the file lets it collide (``contype`` or ``conaffinity`` non-zero:
        MuJoCo simulates it), as written, before :func:`for_kinematics` turned every geom off
    :param names: the name of every body, joint and geom (:mod:`spark_bench.asset.mjcf_names`: the author's, or
        one saying where it is)
    """

    model: object
    data: object
    degree: bool
    eulerseq: str
    collides: np.ndarray | None = None
    names: ElementNames | None = None

    def name(self, kind: str, index: int) -> str:
        """The name of element ``index`` of ``kind`` (``body``, ``joint`` or ``geom``)."""
        names = self.names or element_names(self.model)
        return {"body": names.bodies, "joint": names.joints, "geom": names.geoms}[kind][index]


@dataclass
class BodyGeometry:
    """The visual geoms of every body, in the world frame at rest, and what was left out.

    :param meshes: body id -> ``(mesh, rgba, source)`` per visual geom
    :param skipped: ``"geom <name> (body <name>): why"`` per geom left out
    """

    meshes: dict[int, list[tuple[trimesh.Trimesh, tuple, str | None]]] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


def mujoco_error(exc: Exception) -> str:
    """MuJoCo's message on one line."""
    return " ".join(str(exc).split())[:300]


def for_kinematics(spec, mujoco) -> None:
    """Drop what only dynamics and rendering need (see the module docstring): textures, collisions,
    mesh volumes, body masses."""
    for texture in list(spec.textures):
        spec.delete(texture)
    for material in spec.materials:
        material.textures = [""] * len(material.textures)
    for mesh in spec.meshes:
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = 0, 0
    for body in spec.bodies:
        if body.name != "world":
            body.explicitinertial, body.mass, body.inertia = True, 1.0, [1.0, 1.0, 1.0]


def check_angle_unit(spec, path: Path, mujoco) -> None:
    """Refuse hinge ranges written in the other unit than the declared one (``compiler angle``).

    With radians declared, a bound beyond a full turn (``90`` for a quarter turn) is degrees. With
    degrees declared (MJCF's default), hinges whose bounds all lie within a full turn, one spanning at
    least :data:`RADIAN_LOOKING_SPAN`, are radians (``1.5708`` for a quarter turn).

    :raises InputError: naming the joint and its range
    """
    hinges = [(j.name or "(unnamed)", [float(v) for v in j.range]) for j in spec.joints
              if j.type == mujoco.mjtJoint.mjJNT_HINGE and j.limited != mujoco.mjtLimited.mjLIMITED_FALSE
              and any(v != 0.0 for v in j.range)]
    full_turn = 2.0 * math.pi + 1e-6
    if not spec.compiler.degree:
        for name, bounds in hinges:
            if max(abs(v) for v in bounds) > full_turn:
                raise InputError(path, f'hinge {name!r}: range {bounds} is beyond a full turn in radians '
                                       '(compiler angle="radian"): degrees written where radians are declared')
        return
    if hinges and all(max(abs(v) for v in b) <= full_turn for _, b in hinges) and \
            max(b[1] - b[0] for _, b in hinges) >= RADIAN_LOOKING_SPAN:
        name, bounds = hinges[0]
        raise InputError(path, f"hinge {name!r}: range {bounds} reads as radians, but the model's angles are "
                               'degrees (compiler angle="degree", MJCF\'s default): radians written where '
                               'degrees are declared (a radian model says <compiler angle="radian"/>)')


def mesh_files(spec) -> dict[str, str]:
    """Mesh name -> its file as the MJCF names it (MuJoCo's messages name the element, not the file)."""
    return {mesh.name: mesh.file for mesh in spec.meshes if mesh.file}


def compile_error(exc: Exception, files: dict[str, str]) -> str:
    """MuJoCo's compile message, with the file of the mesh it names."""
    message = mujoco_error(exc)
    named = re.search(r"Element name '([^']+)'", message)
    if named and named.group(1) in files:
        message += f" (mesh file {files[named.group(1)]})"
    return message


def check_finite(compiled: Compiled, path: Path) -> None:
    """Every body pose, joint anchor and axis and mesh vertex a finite number (MuJoCo reads ``nan`` in an
    attribute with a warning and carries it through).

    :raises InputError: naming the first joint or body that is not
    """
    model, data = compiled.model, compiled.data
    for j in range(model.njnt):
        if not (np.all(np.isfinite(data.xanchor[j])) and np.all(np.isfinite(data.xaxis[j]))):
            raise InputError(path, f"joint {compiled.name('joint', j)!r}: its axis or position is not finite "
                                   f"(axis {data.xaxis[j].tolist()}, anchor {data.xanchor[j].tolist()})")
    for b in range(model.nbody):
        if not (np.all(np.isfinite(data.xpos[b])) and np.all(np.isfinite(data.xmat[b]))):
            raise InputError(path, f"body {compiled.name('body', b)!r}: its pose is not finite")
    for g in range(model.ngeom):
        if not (np.all(np.isfinite(data.geom_xpos[g])) and np.all(np.isfinite(model.geom_size[g]))):
            raise InputError(path, f"geom {compiled.name('geom', g)!r}: its pose or size is not finite")
    if not np.all(np.isfinite(model.mesh_vert)):
        raise InputError(path, "a mesh has a vertex that is not finite")


def compile_model(path: Path) -> Compiled:
    """The model of ``path`` compiled for kinematics, at rest (``mj_forward`` at ``qpos0``).

    :raises InputError: when MuJoCo cannot read or compile it (its message: a truncated mesh, an unknown
        class...), a hinge's range is in the wrong unit, or a pose or axis is not finite
    """
    from spark_bench.mujoco_gl import mujoco_module

    mujoco = mujoco_module()
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise InputError(path, f"MuJoCo cannot read it: {mujoco_error(exc)}") from None
    check_angle_unit(spec, path, mujoco)
    degree, eulerseq = bool(spec.compiler.degree), "".join(spec.compiler.eulerseq)
    files = mesh_files(spec)
    written = [(geom, bool(geom.contype or geom.conaffinity)) for geom in spec.geoms]
    for_kinematics(spec, mujoco)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise InputError(path, f"MuJoCo cannot compile it: {compile_error(exc, files)}") from None
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    collides = np.zeros(model.ngeom, dtype=bool)
    for geom, flag in written:
        collides[geom.id] = flag
    compiled = Compiled(model, data, degree, eulerseq, collides, element_names(model))
    check_finite(compiled, path)
    return compiled


def primitive(kind: int, size: np.ndarray, mujoco) -> trimesh.Trimesh | None:
    """A primitive geom as a mesh in its own frame (MuJoCo sizes are half lengths), None for a kind that
    is not a solid (plane, height field, SDF)."""
    geom = mujoco.mjtGeom
    if kind == geom.mjGEOM_BOX:
        return trimesh.creation.box(extents=2.0 * size)
    if kind == geom.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if kind == geom.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[16, 16])
    if kind == geom.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=32)
    if kind == geom.mjGEOM_ELLIPSOID:
        sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        return trimesh.Trimesh(sphere.vertices * size, sphere.faces, process=False)
    return None


def mesh_source(model, mesh_id: int, run_dir: Path) -> str | None:
    """The file MuJoCo read a mesh from, relative to the run folder (None for a mesh given inline)."""
    start = int(model.mesh_pathadr[mesh_id])
    if start < 0:
        return None
    raw = bytes(model.paths[start:]).split(b"\0", 1)[0].decode()
    try:
        return str(Path(raw).resolve().relative_to(run_dir))
    except ValueError:
        return raw


def geom_mesh(compiled: Compiled, g: int, run_dir: Path, mujoco) -> tuple[trimesh.Trimesh | None, str | None]:
    """Geom ``g`` as a mesh in the world frame at rest, and its file (None, None for no solid)."""
    model, data = compiled.model, compiled.data
    source = None
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        m = int(model.geom_dataid[g])
        v0, nv = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        f0, nf = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        local = trimesh.Trimesh(np.asarray(model.mesh_vert[v0:v0 + nv], dtype=float),
                                np.asarray(model.mesh_face[f0:f0 + nf]), process=False)
        source = mesh_source(model, m, run_dir)
    else:
        local = primitive(int(model.geom_type[g]), np.asarray(model.geom_size[g], dtype=float), mujoco)
        if local is None:
            return None, None
    rotation = np.asarray(data.geom_xmat[g], dtype=float).reshape(3, 3)
    world = local.vertices @ rotation.T + np.asarray(data.geom_xpos[g], dtype=float)
    return trimesh.Trimesh(world, local.faces, process=False), source


def visual_geometry(compiled: Compiled, run_dir: Path) -> BodyGeometry:
    """Every body's visual geoms (groups :data:`VISUAL_GROUPS`, solids only) in the world frame at rest.

    :param run_dir: the run folder (mesh sources are relative to it)
    """
    from spark_bench.mujoco_gl import mujoco_module

    mujoco = mujoco_module()
    model = compiled.model
    out = BodyGeometry()
    for g in range(model.ngeom):
        body = int(model.geom_bodyid[g])
        where = f"geom {compiled.name('geom', g)!r} (body {compiled.name('body', body)!r})"
        if int(model.geom_group[g]) not in VISUAL_GROUPS:
            out.skipped.append(f"{where}: group {int(model.geom_group[g])}, not shown (collision)")
            continue
        mesh, source = geom_mesh(compiled, g, run_dir, mujoco)
        if mesh is None:
            kind = mujoco.mjtGeom(int(model.geom_type[g])).name.removeprefix("mjGEOM_").lower()
            out.skipped.append(f"{where}: a {kind}, not a part's surface (a floor, a terrain)")
            continue
        material = int(model.geom_matid[g])
        rgba = model.mat_rgba[material] if material >= 0 else model.geom_rgba[g]
        out.meshes.setdefault(body, []).append((mesh, tuple(float(c) for c in rgba), source))
    return out


def collision_shapes(compiled: Compiled) -> dict[int, list[Collision]]:
    """Every body's colliding geoms (:attr:`Compiled.collides`) in the world frame at rest, as MuJoCo simulates
    them: a box, sphere or cylinder as that primitive, a mesh as its convex hull (MuJoCo collides with a
    mesh's hull), a capsule or ellipsoid as a convex mesh; planes and height fields (a floor) left out. Each
    shape's ``source`` is its geom's name (:mod:`spark_bench.asset.mjcf_names`)."""
    from spark_bench.mujoco_gl import mujoco_module

    mujoco = mujoco_module()
    model, data, out = compiled.model, compiled.data, {}
    kinds = {int(mujoco.mjtGeom.mjGEOM_BOX): "box", int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
             int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder"}
    for g in np.flatnonzero(compiled.collides if compiled.collides is not None else []):
        size = np.asarray(model.geom_size[g], dtype=float)
        world = pose(np.asarray(data.geom_xmat[g], dtype=float).reshape(3, 3), np.asarray(data.geom_xpos[g]))
        kind = kinds.get(int(model.geom_type[g]))
        if kind is not None:
            full = {"box": 2.0 * size, "sphere": size[:1], "cylinder": np.array([size[0], 2.0 * size[1]])}[kind]
            shape = Collision(kind, origin=world, size=full, source=compiled.name("geom", int(g)))
        else:
            mesh, _ = geom_mesh(compiled, int(g), Path("."), mujoco)
            if mesh is None or len(mesh.vertices) < 4:
                continue
            shape = Collision("mesh", mesh=mesh.convex_hull, source=compiled.name("geom", int(g)))
        out.setdefault(int(model.geom_bodyid[g]), []).append(shape)
    return out


def kept_bodies(model, geometry: BodyGeometry) -> list[int]:
    """The bodies with a visual geom in their subtree (MuJoCo orders parents before children), the world
    first: a body without one (a site holder, a flex's nodes) would be an empty part."""
    keep = {0}
    for body in range(model.nbody - 1, 0, -1):
        if body in geometry.meshes or body in keep:
            keep.add(body)
            keep.add(int(model.body_parentid[body]))
    return sorted(keep)


def pose(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """4x4 from a 3x3 rotation and a position."""
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rotation, position
    return out


def joint_limits(compiled: Compiled, j: int, kind: str) -> tuple[float, float, bool]:
    """``(lower, upper, has_limits)`` of joint ``j`` about its rest value ``qpos0`` (its ``ref``): radians
    for a hinge (MuJoCo converted degrees), metres for a slide; an unlimited hinge is continuous."""
    model = compiled.model
    if kind == JointType.CONTINUOUS:
        return 0.0, 2.0 * math.pi, False
    if not model.jnt_limited[j]:
        return 0.0, 0.0, False
    rest = float(model.qpos0[model.jnt_qposadr[j]])
    lower, upper = (float(v) - rest for v in model.jnt_range[j])
    return lower, upper, True


def joint_kind(model, j: int) -> str:
    """Our type of MuJoCo joint ``j`` (a hinge or a slide): revolute, continuous (unlimited) or prismatic."""
    from spark_bench.mujoco_gl import mujoco_module

    if int(model.jnt_type[j]) == int(mujoco_module().mjtJoint.mjJNT_SLIDE):
        return "prismatic"
    return "revolute" if model.jnt_limited[j] else "continuous"


def chain(compiled: Compiled, body: int, movable: list[int], parent: tuple[str, np.ndarray], link: str
          ) -> tuple[list[Joint], list[Link], np.ndarray]:
    """The joints hanging ``link`` (MuJoCo body ``body``) from its parent's link: one per hinge or slide of
    the body, in MuJoCo's order, through links without geometry when there are several; each joint's
    frame at its anchor, turned like the body, its axis the body-frame axis; each joint named as the file
    names it (:mod:`spark_bench.asset.mjcf_names`).

    :param movable: the body's hinge and slide joints
    :param parent: the parent link's name and its 4x4 frame at rest
    :param link: the body's link
    :returns: the joints, the helper links (``<link>_helper_<i>``), and ``link``'s frame at rest
    """
    model, data = compiled.model, compiled.data
    rotation = np.asarray(data.xmat[body], dtype=float).reshape(3, 3)
    (parent_link, parent_frame), joints, helpers = parent, [], []
    frame = parent_frame
    for i, j in enumerate(movable):
        frame = pose(rotation, np.asarray(data.xanchor[j], dtype=float))
        child = link if i == len(movable) - 1 else f"{link}_helper_{i}"
        kind = joint_kind(model, j)
        lower, upper, has_limits = joint_limits(compiled, j, kind)
        axis = rotation.T @ np.asarray(data.xaxis[j], dtype=float)
        joints.append(Joint(compiled.name("joint", j), kind, parent_link, child, np.linalg.inv(parent_frame) @ frame,
                            axis / np.linalg.norm(axis), lower, upper, has_limits=has_limits))
        if child != link:
            helpers.append(Link(child, label=f"{compiled.name('body', body)} (joint {i})"))
        parent_link, parent_frame = child, frame
    return joints, helpers, frame


def fixed_joint_name(compiled: Compiled, held: list[int], link: str, taken: dict) -> str:
    """The name of the fixed joint that holds ``link`` at rest: the name the file gives the first of its free or
    ball joints ``held`` that it names, else ``<link>:fixed`` (numbered where ``taken`` already holds it)."""
    written = [j for j in held if compiled.model.jnt(j).name]
    base = compiled.name("joint", written[0]) if written else f"{link}:fixed"
    name, k = base, 2
    while name in taken:
        name, k = f"{base}_{k}", k + 1
    return name


def build_asset(compiled: Compiled, geometry: BodyGeometry, name: str,
                collisions: dict[int, list[Collision]] | None = None) -> tuple[ArticulatedAsset, list[dict]]:
    """The object: one link per kept body (in MuJoCo's order), named as the file names the body (``worldbody``
    for MuJoCo's world body; :mod:`spark_bench.asset.mjcf_names`), its frame the body's at rest; a body with one hinge
    or slide hangs from its parent's link by a revolute (continuous when unlimited) or prismatic joint at the
    joint's anchor, named as the file names it, one with several by a chain of them (:func:`chain`, MuJoCo
    applying a body's joints in order from its parent); a body with no joint, a free or a ball joint is fixed at
    its rest pose. Each joint then opens toward its upper limit (:func:`~spark_bench.asset.opening_direction.
    orient_joints`: a range written about ``qpos0`` that rests at its upper limit, or whose geometry opens toward
    the lower one, is read about the opposite axis), what was read kept in ``meta["opening_direction"]``.

    :param collisions: the bodies' collision shapes in the world frame (:func:`collision_shapes`), kept in
        their links, and the joints' damping and friction loss where the file sets them (the model as
        written, for the sim checks); None reads the visuals and the kinematics only (an import)
    :returns: the asset and one record per body (its MuJoCo name, link, joints, what was not kept)
    """
    from spark_bench.mujoco_gl import mujoco_module

    jnt = mujoco_module().mjtJoint
    model, data = compiled.model, compiled.data
    bodies = kept_bodies(model, geometry)
    link_of = {b: compiled.name("body", b) for b in bodies}
    frame_of = {0: np.eye(4)}
    links: dict[str, Link] = {}
    joints: dict[str, Joint] = {}
    hung_of: dict[int, list[tuple[int, Joint]]] = {}
    held_of: dict[int, list[str]] = {}
    for body in bodies:
        ids = range(int(model.body_jntadr[body]), int(model.body_jntadr[body] + model.body_jntnum[body]))
        movable = [j for j in ids if int(model.jnt_type[j]) in (int(jnt.mjJNT_HINGE), int(jnt.mjJNT_SLIDE))]
        held = [j for j in ids if j not in movable]
        held_of[body] = [jnt(int(model.jnt_type[j])).name.removeprefix("mjJNT_").lower() for j in held]
        link, hung = link_of[body], []
        if body:
            up = int(model.body_parentid[body])
            rest = pose(np.asarray(data.xmat[body], dtype=float).reshape(3, 3), np.asarray(data.xpos[body]))
            hung, helpers, frame = chain(compiled, body, movable, (link_of[up], frame_of[up]), link)
            if not movable:
                weld = fixed_joint_name(compiled, held, link, joints)
                hung, frame = [Joint(weld, "fixed", link_of[up], link, np.linalg.inv(frame_of[up]) @ rest)], rest
            joints.update({j.name: j for j in hung})
            links.update({h.name: h for h in helpers})
            frame_of[body] = frame
        hung_of[body] = list(zip(movable, hung))
        to_link = np.linalg.inv(frame_of[body])
        visuals = [Visual(trimesh.Trimesh(mesh.vertices @ to_link[:3, :3].T + to_link[:3, 3], mesh.faces,
                                          process=False), rgba=rgba, source=source)
                   for mesh, rgba, source in geometry.meshes.get(body, [])]
        links[link] = Link(link, visuals, label=link)
        if collisions is not None:
            links[link].collisions = [_moved(shape, to_link) for shape in collisions.get(body, [])]
            for j, ours in hung_of[body]:
                dof = int(model.jnt_dofadr[j])
                ours.damping = float(model.dof_damping[dof]) or None
                ours.friction = float(model.dof_frictionloss[dof]) or None
    asset = ArticulatedAsset(name=name, links=links, joints=joints)
    asset.meta["opening_direction"] = [o.to_dict() for o in orient_joints(asset)]
    records = [{"body": link_of[body], "link": link_of[body], "fixed": held_of[body], "joints": [
        {"name": ours.name, "type": ours.type, "lower": ours.lower, "upper": ours.upper}
        for _, ours in hung_of[body] if ours.type != JointType.FIXED]} for body in bodies]
    dropped = [compiled.name("body", b) for b in range(1, model.nbody) if b not in set(bodies)]
    if dropped:
        records.append({"dropped_bodies": dropped, "why": "no visual geom in their subtree"})
    return asset, records


def _moved(shape: Collision, transform: np.ndarray) -> Collision:
    """A world-frame collision shape in the frame ``transform`` maps the world to."""
    if shape.kind == "mesh":
        mesh = shape.mesh.copy()
        mesh.apply_transform(transform)
        return Collision("mesh", mesh=mesh, source=shape.source)
    return Collision(shape.kind, origin=transform @ shape.origin, size=shape.size, source=shape.source)
