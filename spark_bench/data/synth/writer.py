"""Write an :class:`~spark_bench.data.synth.spec.ObjectSpec` as a PartNet-Mobility object folder.

Byte-for-byte reproducible: fixed float formatting, canonical vertex and face order, sorted JSON keys,
no timestamps. Each link's visual is one watertight manifold per colour (the union of its solids, by
manifold3d) with an MTL giving its ``Kd``; its collision elements are the solids themselves (boxes and
cylinders, convex OBJ meshes for frustums), so they are convex by construction.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import manifold3d
import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.transforms import matrix_to_rpy
from spark_bench.data.synth.primitives import Solid
from spark_bench.data.synth.spec import ObjectSpec, Part
from spark_bench.errors import InputError

ROOT_RPY = "1.570796 0 -1.570796"
MESH_DIR = "textured_objs"
GENERATOR_NAME = "spark_bench.data.synth"


def fmt(value: float, digits: int = 6) -> str:
    """Fixed-point text of a float without trailing zeros (``-0`` written as ``0``)."""
    text = f"{float(value):.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def fmt_vec(values, digits: int = 6) -> str:
    return " ".join(fmt(v, digits) for v in values)


def fmt_sci(value: float) -> str:
    """Six significant digits, for masses and inertias of very different magnitudes."""
    return f"{float(value):.6g}"


def clean_json(obj):
    """JSON-ready copy with floats rounded to 6 decimals and NumPy types converted."""
    if isinstance(obj, dict):
        return {str(k): clean_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | np.ndarray):
        return [clean_json(v) for v in obj]
    if isinstance(obj, bool | np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        return round(float(obj), 6) + 0.0
    return obj


#: Visual solids are grown by this much (m) before their union, so that touching solids fuse.
VISUAL_GROW = 1e-4


def union_mesh(solids: list[Solid]) -> tuple[np.ndarray, np.ndarray]:
    """The union of ``solids`` as one manifold triangle mesh, in canonical vertex and face order."""
    shapes = [s.manifold(VISUAL_GROW) for s in solids]
    merged = shapes[0] if len(shapes) == 1 else manifold3d.Manifold.batch_boolean(shapes, manifold3d.OpType.Add)
    mesh = merged.to_mesh()
    return canonical_mesh(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts))


def canonical_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices rounded to micrometres and sorted (never merged); faces re-indexed, rotated and sorted."""
    rounded = np.round(np.asarray(vertices, dtype=float), 6) + 0.0
    order = np.lexsort(rounded.T[::-1])  # stable: coincident vertices keep their order
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    unique = rounded[order]
    tri = rank[np.asarray(faces, dtype=np.int64)]
    first = np.argmin(tri, axis=1)
    rows = np.arange(len(tri))
    tri = np.stack([tri[rows, (first + k) % 3] for k in range(3)], axis=1)  # same orientation
    tri = tri[np.lexsort(tri.T[::-1])]
    return unique, tri


def obj_text(vertices: np.ndarray, faces: np.ndarray, material: str | None) -> str:
    lines = ["# spark-bench synth"]
    if material:
        lines += [f"mtllib {material}.mtl", f"o {material}"]
    lines += [f"v {fmt_vec(v)}" for v in vertices]
    if material:
        lines.append(f"usemtl {material}")
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    return "\n".join(lines) + "\n"


def mtl_text(name: str, rgba) -> str:
    r, g, b, a = rgba
    return (f"newmtl {name}\nKa 0 0 0\nKd {fmt(r, 4)} {fmt(g, 4)} {fmt(b, 4)}\nKs 0.1 0.1 0.1\nNs 20\n"
            f"d {fmt(a, 4)}\nillum 2\n")


def mass_properties(solids: list[Solid]) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, 3x3 inertia about it) of a set of solids, overlaps counted twice."""
    masses = np.array([s.density * s.volume() for s in solids])
    mass = float(masses.sum())
    com = sum(m * s.center for m, s in zip(masses, solids)) / mass
    inertia = np.zeros((3, 3))
    for m, s in zip(masses, solids):
        d = s.center - com
        inertia += s.rotation @ s.local_inertia(m) @ s.rotation.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


def link_names(spec: ObjectSpec) -> dict[str, str]:
    """URDF link name of every part: moving parts first (``link_0``...), the body last."""
    others = [p.name for p in spec.parts if p.joint is not None]
    roots = [p.name for p in spec.parts if p.joint is None]
    return {name: f"link_{i}" for i, name in enumerate(others + roots)}


def _color_groups(part: Part) -> list[list[Solid]]:
    groups: dict[tuple, list[Solid]] = {}
    for solid in part.solids:
        groups.setdefault(tuple(solid.color), []).append(solid)
    return list(groups.values())


def _link_xml(part: Part, link: str, folder: Path) -> list[str]:
    frame = part.frame
    out = [f'\t<link name="{link}">']
    mass, com, inertia = mass_properties(part.solids)
    out += ["\t\t<inertial>", f'\t\t\t<origin xyz="{fmt_vec(com - frame)}" rpy="0 0 0"/>',
            f'\t\t\t<mass value="{fmt_sci(mass)}"/>',
            '\t\t\t<inertia ixx="{}" ixy="{}" ixz="{}" iyy="{}" iyz="{}" izz="{}"/>'.format(
                *(fmt_sci(inertia[i, j]) for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)))),
            "\t\t</inertial>"]
    for k, group in enumerate(_color_groups(part)):
        name = f"{link}_{k}"
        vertices, faces = union_mesh(group)
        (folder / MESH_DIR / f"{name}.obj").write_text(obj_text(vertices, faces, name))
        (folder / MESH_DIR / f"{name}.mtl").write_text(mtl_text(name, group[0].color))
        out += [f'\t\t<visual name="{name}">', f'\t\t\t<origin xyz="{fmt_vec(-frame)}"/>',
                f'\t\t\t<geometry>\n\t\t\t\t<mesh filename="{MESH_DIR}/{name}.obj"/>\n\t\t\t</geometry>',
                f'\t\t\t<material name="{name}">\n\t\t\t\t<color rgba="{fmt_vec(group[0].color, 4)}"/>'
                "\n\t\t\t</material>", "\t\t</visual>"]
    for k, solid in enumerate(part.solids):
        name = f"{link}_collision_{k}"
        if solid.kind == "frustum":
            vertices, faces = union_mesh([solid])
            (folder / MESH_DIR / f"{name}.obj").write_text(obj_text(vertices, faces, None))
            origin = f'xyz="{fmt_vec(-frame)}"'
            geometry = f'<mesh filename="{MESH_DIR}/{name}.obj"/>'
        else:
            origin = f'xyz="{fmt_vec(solid.center - frame)}" rpy="{fmt_vec(matrix_to_rpy(solid.rotation))}"'
            if solid.kind == "box":
                geometry = f'<box size="{fmt_vec(solid.size)}"/>'
            else:
                geometry = f'<cylinder radius="{fmt(solid.size[0])}" length="{fmt(solid.size[1])}"/>'
        out += [f'\t\t<collision name="{name}">', f"\t\t\t<origin {origin}/>",
                f"\t\t\t<geometry>\n\t\t\t\t{geometry}\n\t\t\t</geometry>", "\t\t</collision>"]
    out.append("\t</link>")
    return out


def _joint_xml(part: Part, spec: ObjectSpec, names: dict[str, str]) -> list[str]:
    joint, link = part.joint, names[part.name]
    parent = spec.part(part.parent)
    out = [f'\t<joint name="joint_{link.split("_", 1)[1]}" type="{joint.type}">',
           f'\t\t<origin xyz="{fmt_vec(part.frame - parent.frame)}"/>']
    if joint.type != JointType.FIXED:
        out.append(f'\t\t<axis xyz="{fmt_vec(joint.axis)}"/>')
    out += [f'\t\t<child link="{link}"/>', f'\t\t<parent link="{names[part.parent]}"/>']
    if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC):
        out.append(f'\t\t<limit lower="{fmt(joint.lower)}" upper="{fmt(joint.upper)}" effort="100" velocity="1"/>')
    out.append("\t</joint>")
    return out


def urdf_text(spec: ObjectSpec, object_id: str, folder: Path) -> str:
    """The ``mobility.urdf`` text; writes the meshes into ``folder / textured_objs`` on the way."""
    names = link_names(spec)
    out = ['<?xml version="1.0" ?>', f'<robot name="{object_id}">', '\t<link name="base"/>']
    order = sorted(spec.parts, key=lambda p: int(names[p.name].split("_")[1]))
    for part in order:
        out += _link_xml(part, names[part.name], folder)
        if part.joint is not None:
            out += _joint_xml(part, spec, names)
        else:
            index = names[part.name].split("_")[1]
            out += [f'\t<joint name="joint_{index}" type="fixed">', f'\t\t<origin rpy="{ROOT_RPY}" xyz="0 0 0"/>',
                    f'\t\t<child link="{names[part.name]}"/>', '\t\t<parent link="base"/>', "\t</joint>"]
    out.append("</robot>")
    return "\n".join(out) + "\n"


def prepare_folder(folder: Path) -> None:
    """Empty ``folder`` for writing: only an empty folder or a previous synth object may be replaced."""
    if folder.exists():
        if not folder.is_dir():
            raise InputError(folder, "exists and is not a folder")
        meta = folder / "meta.json"
        ours = meta.is_file() and GENERATOR_NAME in meta.read_text(errors="replace")
        if any(folder.iterdir()) and not ours:
            raise InputError(folder, "exists and is not a spark-bench synth object; refusing to overwrite it")
        shutil.rmtree(folder)
    (folder / MESH_DIR).mkdir(parents=True)


def write_object(spec: ObjectSpec, folder: Path, object_id: str, generator: dict) -> Path:
    """Write ``spec`` as a PartNet-Mobility object folder; returns the folder.

    :param generator: provenance for ``meta.json`` (seed, version...)
    """
    folder = Path(folder)
    prepare_folder(folder)
    (folder / "mobility.urdf").write_text(urdf_text(spec, object_id, folder))
    names = link_names(spec)
    order = sorted(spec.parts, key=lambda p: int(names[p.name].split("_")[1]))
    (folder / "semantics.txt").write_text("".join(f"{names[p.name]} {p.semantic_word} {p.label}\n" for p in order))
    meta = {"model_cat": spec.category, "model_id": object_id, "anno_id": object_id,
            "generator": dict(generator, name=GENERATOR_NAME), "params": spec.params}
    (folder / "meta.json").write_text(json.dumps(clean_json(meta), sort_keys=True, indent=2) + "\n")
    return folder
