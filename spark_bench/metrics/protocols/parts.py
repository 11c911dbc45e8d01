"""An asset's parts as the papers' evaluation code sees them: part boxes, part surfaces, states, samples.

The papers of the field describe an articulated object as a tree of *parts*, each moved by one joint
(SINGAPO's and CAGE's ``object.json`` "diffuse_tree", PartCrafter's part meshes). Here a part is
spark-bench's joint-centric part (:meth:`~spark_bench.asset.model.ArticulatedAsset.part_of_joint`):
the base (every link the root reaches through fixed joints) and, for each movable joint, the links it
moves that no movable joint below it moves. A part without geometry (a helper link between two chained
joints) is left out and its children hang from the nearest part above it that has geometry.

:func:`object_dict` writes an asset in SINGAPO's / CAGE's ``object.json`` layout (the parity benchmark
feeds the same dictionary to the papers' own functions): each part's world axis-aligned box at rest, its
joint's world axis line at rest and its range *from rest* (``[0, open - rest]``, degrees for rotations,
because their ``transform_all_parts`` opens a part by ``range[1] * state`` from the box it is given).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spark_bench.asset.model import ArticulatedAsset, Configuration, Joint
from spark_bench.metrics.geometry import has_area, posed_triangles


@dataclass
class Part:
    """One part of an asset.

    :param index: the part's index (0: the base)
    :param links: the links of the part
    :param joint: the movable joint that moves it (None: the base)
    :param parent: index of the part it hangs from (-1: the base)
    :param children: indices of the parts hanging from it
    """

    index: int
    links: list[str]
    joint: Joint | None
    parent: int = -1
    children: list[int] = field(default_factory=list)


def _base_links(asset: ArticulatedAsset) -> list[str]:
    """Links the root reaches through non-movable joints."""
    out, stack = [], [asset.root]
    while stack:
        link = stack.pop()
        out.append(link)
        stack.extend(j.child for j in asset.joints.values() if j.parent == link and not j.is_movable)
    return out


def _has_geometry(asset: ArticulatedAsset, links: list[str]) -> bool:
    return any(asset.links[name].has_geometry for name in links)


def asset_parts(asset: ArticulatedAsset) -> list[Part]:
    """The base (index 0) and the movable joints' parts that have geometry, parents before children.

    :param asset: the asset
    """
    parts = [Part(0, _base_links(asset), None)]
    part_of_link = {name: 0 for name in parts[0].links}
    for joint in asset.topological_joints():
        if not joint.is_movable:
            continue
        links = asset.part_of_joint(joint.name)
        parent = part_of_link[joint.parent]
        if not _has_geometry(asset, links):  # a helper link: its children hang from its parent part
            part_of_link.update({name: parent for name in links})
            continue
        index = len(parts)
        parts.append(Part(index, links, joint, parent))
        parts[parent].children.append(index)
        part_of_link.update({name: index for name in links})
    return parts


def part_triangles(asset: ArticulatedAsset, part: Part, q: Configuration | None = None) -> np.ndarray:
    """The part's visual surface at ``q`` (world frame), (F, 3, 3).

    :param asset: the asset
    :param part: one of :func:`asset_parts`
    :param q: joint values (missing joints at rest)
    """
    return posed_triangles(asset, q, part.links)


def box_of(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(center, size)`` of the axis-aligned box of (F, 3, 3) triangles; None without triangles."""
    if len(triangles) == 0:
        return None
    points = triangles.reshape(-1, 3)
    low, high = points.min(0), points.max(0)
    return (low + high) / 2.0, high - low


def joint_range_from_rest(joint: Joint) -> list[float]:
    """``[0, open - rest]`` of a movable joint, degrees for rotations and asset units for slides."""
    span = joint.open_value - joint.rest_value
    return [0.0, float(np.degrees(span)) if joint.is_rotational else float(span)]


def object_dict(asset: ArticulatedAsset) -> dict:
    """The asset in SINGAPO's / CAGE's ``object.json`` layout (``{"diffuse_tree": [part, ...]}``).

    Each part: ``id``, ``name`` (its first link), ``parent``, ``children``, ``aabb`` (``center``,
    ``size``: world box at rest), ``joint`` (``type``; ``axis`` ``origin`` / ``direction``: world axis
    line at rest; ``range``: :func:`joint_range_from_rest`). A base without geometry gets a box of size 0
    at the centre of the object's box.

    :param asset: the asset
    """
    rest = asset.rest_configuration()
    frames = asset.joint_frames(rest)
    tree = []
    whole = box_of(posed_triangles(asset, rest))
    for part in asset_parts(asset):
        box = box_of(part_triangles(asset, part, rest))
        if box is None:
            box = (whole[0], np.zeros(3)) if whole is not None else (np.zeros(3), np.zeros(3))
        if part.joint is None:
            joint = {"type": "fixed", "axis": {"origin": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 0.0]},
                     "range": [0.0, 0.0]}
        else:
            point, direction = frames[part.joint.name]
            joint = {"type": part.joint.type,
                     "axis": {"origin": point.tolist(), "direction": direction.tolist()},
                     "range": joint_range_from_rest(part.joint)}
        tree.append({"id": part.index, "name": part.links[0], "parent": part.parent,
                     "children": list(part.children),
                     "aabb": {"center": box[0].tolist(), "size": box[1].tolist()}, "joint": joint})
    return {"diffuse_tree": tree}


def sample_trimesh_way(triangles: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` area-weighted samples drawn as ``trimesh.sample.sample_surface`` draws them (the sampler of
    FreeArt3D's and PartCrafter's code: faces by inverse CDF of the cumulative areas, then two uniforms
    folded into the triangle), from the generator ``rng``: the same generator state gives the same points
    as trimesh's ``mesh.sample(n)`` on the same triangles (without building a mesh each time).

    :param triangles: (F, 3, 3) surface, positive area
    :param n: number of points
    :param rng: the generator the draws come from
    :raises ValueError: for a surface without area
    """
    triangles = np.asarray(triangles, dtype=np.float64)
    if not has_area(triangles):
        raise ValueError("cannot sample a surface without area")
    edges = triangles[:, 1:, :] - triangles[:, :2, :]  # trimesh.triangles.cross, then .area
    crosses = np.cross(edges[:, 0], edges[:, 1])
    weight_cum = np.cumsum(np.sqrt((crosses ** 2).sum(axis=1)) / 2.0)
    face = np.searchsorted(weight_cum, rng.random(int(n)) * weight_cum[-1])
    origins = triangles[:, 0]
    vectors = triangles[:, 1:] - np.tile(origins, (1, 2)).reshape((-1, 2, 3))
    lengths = rng.random((len(face), 2, 1))
    lengths[lengths.sum(axis=1).reshape(-1) > 1.0] -= 1.0
    return (vectors[face] * np.abs(lengths)).sum(axis=1) + origins[face]


def surface_centroid(triangles: np.ndarray) -> np.ndarray:
    """Area-weighted mean of the triangle centroids (trimesh's ``Trimesh.centroid``)."""
    import trimesh

    mesh = trimesh.Trimesh(triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3),
                           process=False)
    return np.asarray(mesh.centroid, dtype=np.float64)


def triangles_extent(triangles: np.ndarray) -> float:
    """The longest side of the axis-aligned box of (F, 3, 3) triangles."""
    points = triangles.reshape(-1, 3)
    return float((points.max(0) - points.min(0)).max())


def require_geometry(asset: ArticulatedAsset, what: str = "ground truth") -> np.ndarray:
    """The asset's surface at rest, (F, 3, 3).

    :param asset: the asset
    :param what: what the asset is, for the message
    :raises InputError: when it has no surface to measure
    """
    from spark_bench.errors import InputError

    triangles = posed_triangles(asset, asset.rest_configuration())
    if not has_area(triangles):
        raise InputError(asset.source or asset.name or what, f"the {what} has no surface to measure")
    return triangles
