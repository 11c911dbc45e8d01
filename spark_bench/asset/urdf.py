"""URDF read and write through yourdfpy, keeping PartNet-Mobility conventions.

Reading validates what yourdfpy does not: no DTD or XML entities (no expansion, no external fetch),
unique link and joint names, a single tree (no cycles, one parent per link), finite non-zero axes,
mesh paths that stay inside the object folder (or, for a URDF the user names directly, resolve as ROS
resolves them: :mod:`spark_bench.asset.mesh_paths`), and meshes with a surface. Every problem raises
:class:`~spark_bench.errors.InputError` naming the file.

A mesh file with no surface (missing, empty, no vertices, vertices but no faces) is an
:class:`EmptyMeshError`. As in PartNet-Mobility, whose URDFs keep listing part files that had no faces
(SAPIEN skips them), such a file is skipped, with a warning and a note in :attr:`Link.skipped_meshes`,
when another visual (collision) of the same link has a surface; a link whose every visual (every
collision) mesh has none is an input error naming the link and each file.
"""

from __future__ import annotations

import io
import json
import logging
import math
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh
import yourdfpy
from lxml import etree

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.mesh_paths import MeshPathResolver, resolver_for
from spark_bench.asset.model import (
    DEFAULT_REVOLUTE_UPPER,
    JOINT_TYPES,
    ArticulatedAsset,
    Collision,
    Joint,
    Link,
    Visual,
)
from spark_bench.asset.obj_text import face_lines, vertex_lines
from spark_bench.asset.transforms import transform_points
from spark_bench.errors import InputError

MAX_URDF_BYTES = 50_000_000
logger = logging.getLogger(__name__)


class EmptyMeshError(InputError):
    """A mesh file with no surface: missing, empty (0 bytes), no vertices, or vertices but no faces."""


# ----- reading --------------------------------------------------------------------------------
def read_urdf_xml(path: Path) -> bytes:
    """The URDF's bytes, after checking that it is well-formed XML with no DTD or entities."""
    return _read_urdf_tree(path)[0]


def _read_urdf_tree(path: Path):
    """``(bytes, root element)`` of the URDF, checked as :func:`read_urdf_xml` says."""
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "URDF file not found")
    data = path.read_bytes()
    if len(data) > MAX_URDF_BYTES:
        raise InputError(path, f"URDF is larger than {MAX_URDF_BYTES} bytes")
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise InputError(path, "XML DTDs and entities are not allowed in a URDF (no entity expansion)")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    try:
        root = etree.fromstring(data, parser=parser)
    except etree.XMLSyntaxError as exc:
        raise InputError(path, f"malformed XML: {exc}") from None
    if root.tag != "robot":
        raise InputError(path, f"root element is <{root.tag}>, expected <robot>")
    return data, root


def _check_structure(path: Path, robot: yourdfpy.Robot) -> None:
    link_names = [link.name for link in robot.links]
    dup = sorted({n for n in link_names if link_names.count(n) > 1})
    if dup:
        raise InputError(path, f"duplicate link name {dup[0]!r}")
    joint_names = [joint.name for joint in robot.joints]
    dup = sorted({n for n in joint_names if joint_names.count(n) > 1})
    if dup:
        raise InputError(path, f"duplicate joint name {dup[0]!r}")
    known = set(link_names)
    parent_of: dict[str, str] = {}
    for joint in robot.joints:
        for end in (joint.parent, joint.child):
            if end not in known:
                raise InputError(path, f"joint {joint.name!r} refers to unknown link {end!r}")
        if joint.child in parent_of:
            raise InputError(path, f"link {joint.child!r} has two parent joints")
        parent_of[joint.child] = joint.parent
        if joint.type not in JOINT_TYPES:
            raise InputError(path, f"joint {joint.name!r} has unsupported type {joint.type!r}")
    for start in parent_of:
        seen, link = {start}, start
        while link in parent_of:
            link = parent_of[link]
            if link in seen:
                raise InputError(path, f"kinematic cycle through link {link!r}")
            seen.add(link)
    roots = [n for n in link_names if n not in parent_of]
    if len(roots) != 1:
        raise InputError(path, f"expected one root link, found {len(roots)}: {roots[:5]}")


def _resolve_mesh_path(resolver: MeshPathResolver, filename: str) -> Path:
    """The existing mesh file ``filename`` names (:mod:`spark_bench.asset.mesh_paths`)."""
    resolved = resolver.resolve(filename)
    if resolved.is_dir():
        raise EmptyMeshError(resolver.urdf, f"mesh file {filename!r} is a directory, not a file")
    if not resolved.is_file():
        raise EmptyMeshError(resolver.urdf, f"mesh file {filename!r} not found")
    return resolved


def _material_rgba(geometry) -> tuple[float, float, float, float] | None:
    material = getattr(getattr(geometry, "visual", None), "material", None)
    if material is None:
        return None
    image = getattr(material, "image", None)
    if image is None and hasattr(material, "baseColorTexture"):
        image = material.baseColorTexture
    if image is not None:
        small = np.asarray(image.convert("RGB").resize((16, 16)), dtype=float) / 255.0
        return (*small.reshape(-1, 3).mean(0), 1.0)
    color = getattr(material, "main_color", None)
    if color is None:
        return None
    color = np.asarray(color, dtype=float) / 255.0
    return (*color[:3], 1.0)


def load_mesh_file(path: Path) -> tuple[trimesh.Trimesh, tuple[float, float, float, float] | None]:
    """One mesh file (OBJ, GLB, STL, ...) as a single unprocessed mesh and its mean material colour.

    Scenes (several objects, GLB node trees) are flattened with their node transforms and merged.

    :raises EmptyMeshError: the file is empty, or holds no vertices, or vertices but no faces
    :raises InputError: the file cannot be parsed, or has NaN or infinite coordinates
    """
    from spark_bench.asset.mesh import merge_meshes

    if path.stat().st_size == 0:
        raise EmptyMeshError(path, "mesh file is empty (0 bytes)")
    try:
        with warnings.catch_warnings():  # trimesh warns about texture UVs it cannot use: not our concern
            warnings.simplefilter("ignore")
            loaded = trimesh.load(str(path), process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many kinds on broken files
        raise InputError(path, f"cannot read mesh: {type(exc).__name__}: {exc}") from None
    colors, parts, n_vertices = [], [], 0
    if isinstance(loaded, trimesh.Scene):
        for node in loaded.graph.nodes_geometry:
            transform, geom_name = loaded.graph[node]
            geom = loaded.geometry[geom_name]
            n_vertices += len(getattr(geom, "vertices", ()))
            if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
                continue
            parts.append(trimesh.Trimesh(transform_points(transform, geom.vertices), geom.faces, process=False))
            colors.append((_material_rgba(geom), geom.area))
    elif isinstance(loaded, trimesh.Trimesh):
        n_vertices = len(loaded.vertices)
        if len(loaded.faces):
            parts.append(trimesh.Trimesh(loaded.vertices, loaded.faces, process=False))
            colors.append((_material_rgba(loaded), loaded.area))
    else:  # point clouds and paths have no surface
        n_vertices = len(getattr(loaded, "vertices", ()))
    if not parts:
        raise EmptyMeshError(path, f"mesh file has {n_vertices} vertices but no faces" if n_vertices
                             else "mesh file has no vertices")
    mesh = merge_meshes(parts)
    if not np.all(np.isfinite(mesh.vertices)):
        raise InputError(path, "mesh has NaN or infinite vertex coordinates")
    weighted = [(c, a) for c, a in colors if c is not None]
    rgba = None
    if weighted:
        w = np.array([a for _, a in weighted]) + 1e-12
        rgba = tuple(float(x) for x in np.average([c for c, _ in weighted], axis=0, weights=w))
    return mesh, rgba


def _geometry_mesh(resolver: MeshPathResolver, mesh_geom, cache) -> tuple[trimesh.Trimesh, tuple | None, str]:
    resolved = _resolve_mesh_path(resolver, mesh_geom.filename)
    if resolved not in cache:
        cache[resolved] = load_mesh_file(resolved)
    mesh, rgba = cache[resolved]
    mesh = mesh.copy()
    if mesh_geom.scale is not None:
        mesh.vertices = mesh.vertices * np.broadcast_to(np.asarray(mesh_geom.scale, dtype=float), (3,))
    return mesh, rgba, resolver.source_name(resolved)


def _origin(element) -> np.ndarray:
    origin = getattr(element, "origin", None)
    return np.eye(4) if origin is None else np.asarray(origin, dtype=float)


def _read_link(resolver: MeshPathResolver, ylink, materials: dict, cache: dict, load_meshes: bool) -> Link:
    urdf_path = resolver.urdf
    link = Link(name=ylink.name)
    empty: dict[str, list[str]] = {"visual": [], "collision": []}  # mesh files with no surface, by role
    for visual in ylink.visuals:
        geom = visual.geometry
        rgba = None
        if visual.material is not None:
            mat = materials.get(visual.material.name, visual.material)
            if mat.color is not None:
                rgba = tuple(float(c) for c in mat.color.rgba)
        if geom.mesh is not None:
            if not load_meshes:
                continue
            try:
                mesh, file_rgba, source = _geometry_mesh(resolver, geom.mesh, cache)
            except EmptyMeshError as exc:
                empty["visual"].append(_empty_problem(exc, geom.mesh.filename))
                continue
            mesh.apply_transform(_origin(visual))
            link.visuals.append(Visual(mesh=mesh, rgba=rgba or file_rgba or (0.7, 0.7, 0.7, 1.0), source=source))
        else:
            prim = _primitive(urdf_path, ylink.name, geom, _origin(visual))
            if prim is not None:
                link.visuals.append(Visual(mesh=prim.to_trimesh(), rgba=rgba or (0.7, 0.7, 0.7, 1.0)))
    for collision in ylink.collisions:
        geom = collision.geometry
        if geom.mesh is not None:
            if not load_meshes:
                continue
            try:
                mesh, _, source = _geometry_mesh(resolver, geom.mesh, cache)
            except EmptyMeshError as exc:
                empty["collision"].append(_empty_problem(exc, geom.mesh.filename))
                continue
            link.collisions.append(Collision("mesh", origin=_origin(collision), mesh=mesh, source=source))
        else:
            prim = _primitive(urdf_path, ylink.name, geom, _origin(collision))
            if prim is not None:
                link.collisions.append(prim)
    for role, shapes in (("visual", link.visuals), ("collision", link.collisions)):
        if empty[role] and not shapes:
            raise InputError(urdf_path, f"link {ylink.name!r} has no {role} mesh with a surface: "
                                        + "; ".join(empty[role]))
        for problem in empty[role]:
            logger.warning("%s: link %r: skipped a %s mesh with no surface (the link has others): %s",
                           urdf_path, ylink.name, role, problem)
            link.skipped_meshes.append(f"{role}: {problem}")
    return link


def _empty_problem(exc: EmptyMeshError, filename: str) -> str:
    """The problem of an :class:`EmptyMeshError`, naming the mesh file as the URDF writes it."""
    if repr(filename) in exc.problem:
        return exc.problem
    return exc.problem.replace("mesh file", f"mesh file {filename!r}", 1)


def _primitive(urdf_path, link_name, geom, origin) -> Collision | None:
    if geom.box is not None:
        kind, size = "box", np.asarray(geom.box.size, dtype=float)
    elif geom.cylinder is not None:
        kind, size = "cylinder", np.array([geom.cylinder.radius, geom.cylinder.length], dtype=float)
    elif geom.sphere is not None:
        kind, size = "sphere", np.array([geom.sphere.radius], dtype=float)
    else:
        return None
    if not np.all(np.isfinite(size)) or np.any(size <= 0):
        raise InputError(urdf_path, f"link {link_name!r} has a {kind} with invalid size {size.tolist()}")
    return Collision(kind, origin=origin, size=size)


def _read_joint(urdf_path: Path, yjoint, has_axis: bool = True) -> Joint:
    origin = _origin(yjoint)
    if not np.all(np.isfinite(origin)):
        raise InputError(urdf_path, f"joint {yjoint.name!r} has a NaN or infinite origin")
    axis = np.asarray(yjoint.axis if yjoint.axis is not None else [1.0, 0.0, 0.0], dtype=float)
    norm = float(np.linalg.norm(axis)) if np.all(np.isfinite(axis)) else math.nan
    if yjoint.type != JointType.FIXED and (not math.isfinite(norm) or norm < 1e-9):
        raise InputError(urdf_path, f"joint {yjoint.name!r} has a zero or NaN axis {axis.tolist()}")
    axis = axis / norm if yjoint.type != JointType.FIXED else (axis / norm if norm > 1e-9 else np.array([1.0, 0, 0]))
    limit = yjoint.limit
    lower = upper = None
    if limit is not None:
        lower, upper = limit.lower, limit.upper
    has_limits = lower is not None and upper is not None
    if yjoint.type == JointType.CONTINUOUS:
        lower, upper = 0.0, 2.0 * math.pi
    elif yjoint.type == JointType.REVOLUTE and not has_limits:
        lower, upper = (lower or 0.0), (upper if upper is not None else DEFAULT_REVOLUTE_UPPER)
    elif yjoint.type == JointType.PRISMATIC and not has_limits:
        lower, upper = (lower or 0.0), (upper or 0.0)
    elif yjoint.type == JointType.FIXED:
        lower, upper = 0.0, 0.0
    lower = _number(lower, urdf_path, f"joint {yjoint.name!r} limit lower")
    upper = _number(upper, urdf_path, f"joint {yjoint.name!r} limit upper")
    if not (math.isfinite(lower) and math.isfinite(upper)):
        raise InputError(urdf_path, f"joint {yjoint.name!r} has non-finite limits")
    if upper < lower:
        raise InputError(urdf_path, f"joint {yjoint.name!r} has upper limit {upper} below lower {lower}")
    dyn = yjoint.dynamics
    return Joint(
        name=yjoint.name, type=yjoint.type, parent=yjoint.parent, child=yjoint.child, origin=origin,
        axis=axis, lower=lower, upper=upper, has_limits=has_limits or yjoint.type == JointType.FIXED, has_axis=has_axis,
        # yourdfpy leaves <dynamics> and <limit effort/velocity> as the attribute strings
        damping=_optional_number(getattr(dyn, "damping", None), urdf_path, f"joint {yjoint.name!r} damping"),
        friction=_optional_number(getattr(dyn, "friction", None), urdf_path, f"joint {yjoint.name!r} friction"),
        effort=_optional_number(getattr(limit, "effort", None), urdf_path, f"joint {yjoint.name!r} effort"),
        velocity=_optional_number(getattr(limit, "velocity", None), urdf_path, f"joint {yjoint.name!r} velocity"),
    )


def _number(value, urdf_path, what: str) -> float:
    """``value`` as a float, or an :class:`InputError` naming the file and the attribute."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(urdf_path, f"{what} is not a number: {value!r}") from None


def _optional_number(value, urdf_path, what: str) -> float | None:
    """A finite float, or None when the attribute is absent."""
    if value is None:
        return None
    number = _number(value, urdf_path, what)
    if not math.isfinite(number):
        raise InputError(urdf_path, f"{what} is not finite: {value!r}")
    return number


def load_urdf(path: str | Path, folder: str | Path | None = None, load_meshes: bool = True, *,
              as_it_lies: bool = False, package_paths: Sequence[str | Path] | None = None) -> ArticulatedAsset:
    """Read a URDF into an :class:`ArticulatedAsset`, meshes in link frames.

    :param path: the URDF file
    :param folder: the object folder that mesh paths must stay inside (default: the URDF's folder)
    :param load_meshes: read mesh files (False: structure only, much faster)
    :param as_it_lies: resolve mesh paths as ROS does, ``..``, ``package://`` and absolute paths included
        (a URDF the user named directly; :mod:`spark_bench.asset.mesh_paths`); ``folder`` is then unused
    :param package_paths: folders searched for ``package://NAME/`` before ``ROS_PACKAGE_PATH``
    """
    path = Path(path).resolve()
    folder = None if as_it_lies else (Path(folder).resolve() if folder is not None else path.parent)
    resolver = resolver_for(path, folder, [Path(p) for p in package_paths or []])
    data, root = _read_urdf_tree(path)
    # yourdfpy fills a missing <axis> with its default: which joints wrote one is read here
    with_axis = {element.get("name") for element in root.iter("joint") if element.find("axis") is not None}
    try:
        urdf = yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False, load_meshes=False)
    except Exception as exc:
        raise InputError(path, f"invalid URDF: {type(exc).__name__}: {exc}") from None
    robot = urdf.robot
    _check_structure(path, robot)
    materials = {m.name: m for m in robot.materials}
    cache: dict = {}
    links = {yl.name: _read_link(resolver, yl, materials, cache, load_meshes) for yl in robot.links}
    joints = {yj.name: _read_joint(path, yj, yj.name in with_axis) for yj in robot.joints}
    return ArticulatedAsset(name=robot.name or path.parent.name, links=links, joints=joints, source=str(path))


# ----- writing --------------------------------------------------------------------------------
def _fmt(x: float) -> str:
    return f"{float(x):.9g}"


def write_obj(path: Path, mesh: trimesh.Trimesh, rgba=None, material_name: str = "material_0") -> None:
    """Write ``mesh`` as a plain OBJ (and an MTL with ``Kd`` when ``rgba`` is given), byte-stable."""
    path = Path(path)
    lines = [f"# spark-bench mesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces"]
    if rgba is not None:
        mtl = path.with_suffix(".mtl")
        r, g, b = (float(c) for c in rgba[:3])
        alpha = float(rgba[3]) if len(rgba) > 3 else 1.0
        mtl.write_text(f"newmtl {material_name}\nKd {_fmt(r)} {_fmt(g)} {_fmt(b)}\nKa 0 0 0\nKs 0.1 0.1 0.1\n"
                       f"d {_fmt(alpha)}\nillum 2\n")
        lines += [f"mtllib {mtl.name}", f"usemtl {material_name}"]
    with open(path, "wb") as handle:
        handle.write(("\n".join(lines) + "\n").encode())
        handle.write(vertex_lines(np.asarray(mesh.vertices)))
        handle.write(face_lines(np.asarray(mesh.faces)))


def _y_geometry_of(col: Collision, mesh_file: str | None):
    if col.kind == "box":
        return yourdfpy.Geometry(box=yourdfpy.Box(size=np.asarray(col.size, dtype=float)))
    if col.kind == "cylinder":
        return yourdfpy.Geometry(cylinder=yourdfpy.Cylinder(radius=float(col.size[0]), length=float(col.size[1])))
    if col.kind == "sphere":
        return yourdfpy.Geometry(sphere=yourdfpy.Sphere(radius=float(col.size[0])))
    return yourdfpy.Geometry(mesh=yourdfpy.Mesh(filename=mesh_file))


def asset_to_robot(asset: ArticulatedAsset, mesh_dir: str = "textured_objs", folder: Path | None = None
                   ) -> yourdfpy.Robot:
    """The asset as a yourdfpy ``Robot``; with ``folder``, mesh files are written under ``folder/mesh_dir``."""
    if folder is not None:
        (Path(folder) / mesh_dir).mkdir(parents=True, exist_ok=True)
    ylinks, materials = [], []
    for link in asset.links.values():
        visuals, collisions = [], []
        for k, visual in enumerate(link.visuals):
            stem = f"{link.name}_{k}" if len(link.visuals) > 1 else link.name
            rel = f"{mesh_dir}/{stem}.obj"
            if folder is not None:
                write_obj(Path(folder) / rel, visual.mesh, visual.rgba, material_name=f"{stem}_mat")
            mat = yourdfpy.Material(name=f"{stem}_mat", color=yourdfpy.Color(rgba=np.asarray(visual.rgba, float)))
            visuals.append(yourdfpy.Visual(name=stem, origin=np.eye(4),
                                           geometry=yourdfpy.Geometry(mesh=yourdfpy.Mesh(filename=rel)),
                                           material=mat))
        for k, col in enumerate(link.collisions):
            rel = None
            if col.kind == "mesh":
                rel = f"{mesh_dir}/{link.name}_collision_{k}.obj"
                if folder is not None:
                    write_obj(Path(folder) / rel, col.mesh)
            collisions.append(yourdfpy.Collision(name=f"{link.name}_collision_{k}", origin=col.origin,
                                                 geometry=_y_geometry_of(col, rel)))
        ylinks.append(yourdfpy.Link(name=link.name, visuals=visuals, collisions=collisions))
    yjoints = []
    for joint in asset.joints.values():
        limit = None
        if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            limit = yourdfpy.Limit(effort=joint.effort if joint.effort is not None else 100.0,
                                   velocity=joint.velocity if joint.velocity is not None else 1.0,
                                   lower=float(joint.lower), upper=float(joint.upper))
        dynamics = None
        if joint.damping is not None or joint.friction is not None:
            dynamics = yourdfpy.Dynamics(damping=joint.damping, friction=joint.friction)
        yjoints.append(yourdfpy.Joint(name=joint.name, type=joint.type, parent=joint.parent, child=joint.child,
                                      origin=joint.origin, axis=np.asarray(joint.axis, dtype=float),
                                      limit=limit, dynamics=dynamics))
    return yourdfpy.Robot(name=asset.name, links=ylinks, joints=yjoints, materials=materials)


def write_urdf(asset: ArticulatedAsset, folder: str | Path, filename: str = "mobility.urdf",
               mesh_dir: str = "textured_objs") -> Path:
    """Write the asset's URDF and its meshes (one OBJ + MTL per visual) into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    robot = asset_to_robot(asset, mesh_dir=mesh_dir, folder=folder)
    out = folder / filename
    # yourdfpy logs an error for every mesh it cannot resolve against the working directory while
    # validating; the paths are relative to ``folder`` and were just written, so silence it here.
    logger = logging.getLogger("yourdfpy")
    level, logger.level = logger.level, logging.CRITICAL
    try:
        urdf = yourdfpy.URDF(robot=robot, build_scene_graph=False, load_meshes=False, mesh_dir=str(folder),
                             filename_handler=yourdfpy.filename_handler_null)  # keep paths relative
        urdf.write_xml_file(str(out))
    finally:
        logger.setLevel(level)
    return out


def write_object_folder(asset: ArticulatedAsset, folder: str | Path) -> Path:
    """Write a PartNet-Mobility object folder: ``mobility.urdf``, ``textured_objs/``, ``semantics.txt``,
    ``meta.json``. Returns the URDF path."""
    folder = Path(folder)
    out = write_urdf(asset, folder)
    lines = []
    for link in asset.links.values():
        if link.name == asset.root:
            continue
        joint = asset.joint_of_child(link.name)
        word = link.semantic_joint or {"revolute": "hinge", "continuous": "hinge", "prismatic": "slider"}.get(
            joint.type if joint else "", "static")
        lines.append(f"{link.name} {word} {link.label or 'part'}")
    (folder / "semantics.txt").write_text("\n".join(lines) + "\n")
    meta = {k: v for k, v in asset.meta.items() if _jsonable(v)}
    meta["model_cat"] = asset.category or meta.get("model_cat", "")
    (folder / "meta.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
    return out


def _jsonable(value) -> bool:
    try:
        json.dumps(value)
    except (TypeError, ValueError):
        return False
    return True
