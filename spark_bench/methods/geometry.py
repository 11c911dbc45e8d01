"""A geometry-only articulation estimator in the spirit of Articulate AnyMesh (Qiu et al. 2025).

Input: the ground truth's part meshes at rest and its kinematic tree, with every joint parameter
removed (type, axis, pivot, limits; the semantic labels too). Output: an articulated object whose
joints are inferred from each moving part's shape and from its contact region with its parent, with
no open-state image. As in Articulate AnyMesh, the inference is a set of geometric heuristics on the
connecting area and the part's extent, so it is right on clear cases and wrong where they mislead.

For each moving part (the links a movable joint moves, down to the next movable joint):

1. **Contact region**: the part's surface samples within ``contact_eps`` of its parent's surface (the
   parent's rigid group: links joined to it by fixed joints).
2. **Free side**: rays from the part along the six axis directions of the (canonical) benchmark frame;
   the direction least blocked by the parent is the side the part opens towards.
3. **Shape class** from the part's axis-aligned extents:
   - small part: a protruding round knob turns (``continuous``) about the surface normal, a flat
     button slides (``prismatic``) into the surface;
   - thin slab facing the free side: a door or lid, ``revolute`` about one of its four edges: the edge
     scored highest on contact (a line of contact along an edge), on the handle cue (the handle
     protrudes near the edge opposite the hinge), and on a weak prior (doors on vertical faces hinge
     on a vertical edge; lids on their back edge, the front being -X);
   - a box nested in a cavity (blocked on at least three lateral sides): a drawer, ``prismatic``
     along the free direction, sliding out by 0.7 of its depth;
   - anything else: ``prismatic`` along the free direction.
4. Door axes are signed so that the door swings towards the free side.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.joint_type import JointType, is_rotational
from spark_bench.asset.mesh import merge_meshes, sample_triangles
from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.methods.base import CaseInput, Generation, PartMeshes
from spark_bench.methods.registry import register_method
from spark_bench.metrics.shape import KDTree, build_tree, nearest_distances

AXES = np.eye(3)
#: The six ray directions: +x, -x, +y, -y, +z, -z.
DIRECTIONS = np.concatenate([AXES, -AXES])[[0, 3, 1, 4, 2, 5]]
FRONT = np.array([-1.0, 0.0, 0.0])
UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class GeometryOptions:
    """Thresholds of the estimator, in benchmark-frame units (the object fits [-1, 1]^3).

    :param contact_eps: distance below which a part point touches its parent
    :param n_part_samples: surface samples per moving part
    :param n_parent_samples: surface samples of the parent
    :param n_rays: rays per direction for the free-side test
    :param slab_ratio: a part is a slab when its thickness is below this fraction of its other sides
    :param small_size: parts whose largest extent is below this are knobs or buttons
    :param small_area: so are parts whose face towards the free side is below this area (and
        whose largest extent is below twice ``small_size``)
    :param edge_band: width of an edge's band, as a fraction of the slab's extent across the edge
    :param seed: sampling seed
    """

    contact_eps: float = 0.03
    n_part_samples: int = 3000
    n_parent_samples: int = 20000
    n_rays: int = 96
    slab_ratio: float = 0.3
    small_size: float = 0.15
    small_area: float = 0.02
    edge_band: float = 0.15
    seed: int = 0


@dataclass
class JointEstimate:
    """One inferred joint, world frame (benchmark frame).

    :param link: the child link of the joint
    :param type: ``revolute``, ``continuous``, ``prismatic`` or ``fixed`` (no geometry to judge from)
    :param axis: unit axis direction
    :param pivot: a point on the axis
    :param upper: upper limit (rad or benchmark units)
    :param kind: what the part was taken for (``door``, ``lid``, ``drawer``, ``knob``, ``button``, ``slider``)
    :param evidence: the numbers the decision was made on
    """

    link: str
    type: str
    axis: np.ndarray
    pivot: np.ndarray
    upper: float
    kind: str
    evidence: dict = field(default_factory=dict)

    def summary(self) -> dict:
        return {"link": self.link, "type": self.type, "kind": self.kind, "axis": self.axis.round(4).tolist(),
                "pivot": self.pivot.round(4).tolist(), "upper": round(float(self.upper), 4), **self.evidence}


# ----- part bookkeeping -----------------------------------------------------------------------------
def moving_part(parts: PartMeshes, link: str) -> list[str]:
    """Links moved by the joint above ``link`` and by no other movable joint below it."""
    out, stack = [], [link]
    while stack:
        current = stack.pop()
        out.append(current)
        stack.extend(c for c, p in parts.parents.items() if p == current and not parts.movable[c])
    return out


def rigid_group(parts: PartMeshes, link: str) -> list[str]:
    """Links joined to ``link`` by fixed joints only (up and down the tree)."""
    top = link
    while top in parts.parents and not parts.movable[top]:
        top = parts.parents[top]
    return moving_part(parts, top)


def _mesh_of(parts: PartMeshes, links) -> trimesh.Trimesh:
    return merge_meshes([parts.meshes[n] for n in links if n in parts.meshes])


def _samples(mesh: trimesh.Trimesh, n: int, seed: int) -> np.ndarray | None:
    if len(mesh.faces) == 0:
        return None
    try:
        return sample_triangles(np.asarray(mesh.vertices)[np.asarray(mesh.faces)], n, seed)
    except ValueError:  # zero area
        return None


# ----- the cues ----------------------------------------------------------------------------------------
def contact_points(part_points: np.ndarray, parent_points: np.ndarray, eps: float) -> np.ndarray:
    """Part points within ``eps`` of the parent; if none, the 2% closest (a part may float a little)."""
    distances = nearest_distances(part_points, parent_points)
    close = distances < eps
    if close.sum() < 5:
        close = distances <= np.quantile(distances, 0.02)
    return part_points[close]


def blocked_fractions(part_points: np.ndarray, parent: trimesh.Trimesh, n_rays: int, seed: int) -> np.ndarray:
    """For each of :data:`DIRECTIONS`, the fraction of rays from part points that hit the parent."""
    rng = np.random.default_rng(seed)
    origins = part_points[rng.choice(len(part_points), min(n_rays, len(part_points)), replace=False)]
    intersector = trimesh.ray.ray_triangle.RayMeshIntersector(parent)
    out = np.zeros(len(DIRECTIONS))
    for k, direction in enumerate(DIRECTIONS):
        starts = origins + 1e-4 * direction  # do not hit the surface the point lies on
        hits = intersector.intersects_any(starts, np.tile(direction, (len(starts), 1)))
        out[k] = float(np.mean(hits))
    return out


def free_direction(blocked: np.ndarray) -> np.ndarray:
    """The direction most open compared with its opposite (``blocked(d) - blocked(-d)`` smallest):
    a drawer is blocked at the back and open at the front, a cap blocked below and open above, even
    when the sides are blocked too. Ties go to the front (-X), then up."""
    opposite = blocked[[1, 0, 3, 2, 5, 4]]
    preference = np.array([np.dot(d, FRONT) * 1e-3 + np.dot(d, UP) * 5e-4 for d in DIRECTIONS])
    return DIRECTIONS[int(np.argmin(blocked - opposite - preference))].copy()


def handle_centroid(points: np.ndarray, normal: np.ndarray) -> np.ndarray | None:
    """Centroid of the most protruding compact cluster on a slab's ``normal`` side (a handle), if any.

    The slab's outer face is the 80th percentile of the points along ``normal``; the handle is what
    sticks out well beyond it (a raised panel sticks out a little, over a large area: not a handle).
    """
    s = points @ normal
    face, top = np.percentile(s, 80), s.max()
    if top - face < 0.01:
        return None
    protruding = points[s > top - 0.35 * (top - face)]
    if len(protruding) < 5:
        return None
    spread = protruding.max(axis=0) - protruding.min(axis=0)
    extent = points.max(axis=0) - points.min(axis=0)
    in_plane = np.abs(normal) < 0.5
    if np.all(spread[in_plane] > 0.6 * extent[in_plane]):  # everywhere: a relief, not a handle
        return None
    return protruding.mean(axis=0)


def is_round(points: np.ndarray, axis: np.ndarray) -> bool:
    """Whether the part is round about ``axis`` through its center: its farthest point from the axis is
    about half its width (a square's corner would be 0.71 of its diagonal width, i.e. 1.41 x half)."""
    k = int(np.argmax(np.abs(axis)))
    others = [i for i in range(3) if i != k]
    lo, hi = points.min(axis=0), points.max(axis=0)
    width = hi[others] - lo[others]
    if width.min() < 0.8 * width.max():
        return False
    radial = np.linalg.norm(points[:, others] - (lo[others] + hi[others]) / 2.0, axis=1)
    return bool(radial.max() < 1.15 * width.max() / 2.0)


# ----- the decisions -------------------------------------------------------------------------------------
def hinge_edge(points: np.ndarray, contact: np.ndarray, normal: np.ndarray, band: float,
               neighbours: KDTree | None = None, eps: float = 0.03) -> tuple[np.ndarray, np.ndarray, dict]:
    """The hinge of a slab facing ``normal``: ``(axis, pivot, evidence)``.

    :param points: the slab's surface samples
    :param contact: its contact points with the parent
    :param normal: unit outward normal (the free side)
    :param band: edge band width as a fraction of the slab's extent across the edge
    :param neighbours: a tree (:func:`~spark_bench.metrics.shape.build_tree`) on samples of the other
        moving parts: an edge that meets another moving part (the middle of a double door) is not a hinge
    :param eps: contact distance
    """
    k = int(np.argmax(np.abs(normal)))
    in_plane = [i for i in range(3) if i != k]
    lo, hi = points.min(axis=0), points.max(axis=0)
    handle = handle_centroid(points, normal)
    vertical_face = abs(normal[2]) < 0.5
    best = None
    scores = {}
    for across in in_plane:
        along = in_plane[0] if across == in_plane[1] else in_plane[1]
        width = max(hi[across] - lo[across], 1e-9)
        for side, edge in (("min", lo[across]), ("max", hi[across])):
            near = np.abs(contact[:, across] - edge) < band * width
            score = float(near.mean()) if len(contact) else 0.0
            if handle is not None:
                score += abs(handle[across] - edge) / width
            if neighbours is not None:
                edge_points = points[np.abs(points[:, across] - edge) < band * width]
                if len(edge_points) and np.mean(nearest_distances(edge_points, neighbours) < eps) > 0.2:
                    score -= 0.5
            if vertical_face and along == 2:
                score += 0.3  # doors on vertical faces mostly hinge on a vertical edge
            if not vertical_face and across == 0 and side == "max":
                score += 0.3  # a lid hinges at the back (+X: the front faces -X)
            name = f"{'xyz'[along]}-edge@{'xyz'[across]}{side}"
            scores[name] = round(score, 4)
            if best is None or score > best[0]:
                best = (score, along, across, edge)
    _, along, across, edge = best
    axis = AXES[along].copy()
    pivot = (lo + hi) / 2.0
    pivot[across] = edge
    pivot[k] = np.percentile(points @ AXES[k], 50)  # mid-thickness of the slab
    center = points.mean(axis=0)
    if np.dot(np.cross(axis, center - pivot), normal) < 0:
        axis = -axis  # open towards the free side
    return axis, pivot, {"edge_scores": scores, "handle_found": handle is not None}


def estimate_joint(parts: PartMeshes, link: str, options: GeometryOptions) -> JointEstimate:
    """Infer the joint above ``link`` from geometry alone."""
    part_links = moving_part(parts, link)
    part_mesh = _mesh_of(parts, part_links)
    if len(part_mesh.faces) == 0:  # a helper link: judge from everything it carries
        part_mesh = _mesh_of(parts, parts.subtree(link))
    subtree = set(parts.subtree(link))
    parent_links = [n for n in rigid_group(parts, parts.parents[link]) if n not in subtree]
    parent_mesh = _mesh_of(parts, parent_links)
    if len(parent_mesh.faces) == 0:
        parent_mesh = _mesh_of(parts, [n for n in parts.meshes if n not in subtree])
    points = _samples(part_mesh, options.n_part_samples, options.seed)
    parent_points = _samples(parent_mesh, options.n_parent_samples, options.seed + 1)
    if points is None or parent_points is None:
        return JointEstimate(link, "fixed", AXES[0].copy(), np.zeros(3), 0.0, "unknown",
                             {"why": "no geometry to judge from"})
    contact = contact_points(points, parent_points, options.contact_eps)
    blocked = blocked_fractions(points, parent_mesh, options.n_rays, options.seed)
    free = free_direction(blocked)
    free_axis = int(np.argmax(np.abs(free)))
    lateral = [k for k, d in enumerate(DIRECTIONS) if abs(np.dot(d, free)) < 0.5]
    n_lateral_blocked = int(sum(blocked[k] > 0.5 for k in lateral))
    lo, hi = points.min(axis=0), points.max(axis=0)
    extents = hi - lo
    others = [i for i in range(3) if i != free_axis]
    center = (lo + hi) / 2.0
    evidence = {"free": free.tolist(), "blocked": blocked.round(3).tolist(), "extents": extents.round(4).tolist(),
                "n_contact": int(len(contact)), "lateral_blocked": n_lateral_blocked}

    diameter = float(max(extents[others]))
    face_area = float(np.prod(extents[others]))
    round_part = is_round(points, free)
    evidence["round"] = round_part
    if extents.max() < options.small_size or (face_area < options.small_area and diameter < 2 * options.small_size):
        if round_part and extents[free_axis] >= 0.35 * diameter:
            return JointEstimate(link, "continuous", free, center, 2 * np.pi, "knob", evidence)
        return JointEstimate(link, "prismatic", -free, center, 0.5 * float(extents[free_axis]), "button", evidence)
    if round_part and extents[free_axis] >= options.slab_ratio * diameter:
        return JointEstimate(link, "continuous", free, center, 2 * np.pi, "cap", evidence)
    others_mesh = _mesh_of(parts, [n for n in parts.meshes if n not in subtree and n not in parent_links])
    other_points = _samples(others_mesh, options.n_parent_samples, options.seed + 2)
    neighbours = build_tree(other_points) if other_points is not None else None
    if extents[free_axis] < options.slab_ratio * min(extents[others]):
        axis, pivot, more = hinge_edge(points, contact, free, options.edge_band, neighbours, options.contact_eps)
        kind = "door" if abs(free[2]) < 0.5 else "lid"
        return JointEstimate(link, "revolute", axis, pivot, np.pi / 2, kind, {**evidence, **more})
    if n_lateral_blocked >= 3:
        return JointEstimate(link, "prismatic", free, center, 0.7 * float(extents[free_axis]), "drawer", evidence)
    thin = int(np.argmin(extents))
    if extents[thin] < options.slab_ratio * np.median(extents):
        normal = AXES[thin] * (1.0 if blocked[2 * thin] <= blocked[2 * thin + 1] else -1.0)
        axis, pivot, more = hinge_edge(points, contact, normal, options.edge_band, neighbours, options.contact_eps)
        return JointEstimate(link, "revolute", axis, pivot, np.pi / 2, "flap", {**evidence, **more})
    return JointEstimate(link, "prismatic", free, center, 0.5 * float(extents[free_axis]), "slider", evidence)


def estimate_joints(parts: PartMeshes, options: GeometryOptions | None = None) -> dict[str, JointEstimate]:
    """An estimate for the joint above every link whose joint moves, by child link.

    A link without geometry between two movable joints (PartNet-Mobility's ``link_0_helper``) makes a
    two-degree-of-freedom joint, a screw: when the part it carries turns, the helper slides along the
    same axis.
    """
    options = options or GeometryOptions()
    out = {link: estimate_joint(parts, link, options) for link, movable in parts.movable.items() if movable}
    for link, estimate in out.items():
        own = _mesh_of(parts, moving_part(parts, link))
        below = [c for c, p in parts.parents.items() if p == link and parts.movable[c]]
        if len(own.faces) == 0 and below and is_rotational(estimate.type):
            extent = float(np.ptp(_mesh_of(parts, parts.subtree(link)).vertices @ estimate.axis))
            out[link] = JointEstimate(link, "prismatic", estimate.axis.copy(), estimate.pivot.copy(),
                                      0.2 * extent, "screw", {**estimate.evidence, "helper": True})
    return out


# ----- the output object -----------------------------------------------------------------------------
def build_asset(parts: PartMeshes, estimates: dict[str, JointEstimate], name: str = "geometry") -> ArticulatedAsset:
    """The predicted object: the given part meshes and tree, with the estimated joints.

    Every link frame below the root is oriented like the object frame (``parts.object_rotation``,
    the PartNet-Mobility convention) and placed on its joint's pivot.
    """
    rotation = np.asarray(parts.object_rotation, dtype=float)
    order = [parts.root]
    while len(order) < len(parts.parents) + 1:
        order += [c for c, p in parts.parents.items() if p in order and c not in order]
    poses = {parts.root: np.eye(4)}
    links, joints = {}, {}
    for link in order:
        if link != parts.root:
            parent_pose = poses[parts.parents[link]]
            estimate = estimates.get(link)
            pose = np.eye(4)
            pose[:3, :3] = rotation
            pose[:3, 3] = estimate.pivot if estimate is not None and estimate.type != JointType.FIXED else parent_pose[:3, 3]
            poses[link] = pose
            joint_type = estimate.type if estimate is not None else "fixed"
            axis = rotation.T @ estimate.axis if estimate is not None else np.array([1.0, 0.0, 0.0])
            upper = float(estimate.upper) if estimate is not None else 0.0
            joints[parts.joint_names[link]] = Joint(
                parts.joint_names[link], joint_type, parts.parents[link], link,
                origin=np.linalg.inv(parent_pose) @ pose, axis=axis / np.linalg.norm(axis), lower=0.0,
                upper=2 * np.pi if joint_type == JointType.CONTINUOUS else upper, has_limits=joint_type != JointType.CONTINUOUS)
        visuals = []
        if link in parts.meshes and len(parts.meshes[link].faces):
            world = parts.meshes[link]
            local = (np.asarray(world.vertices) - poses[link][:3, 3]) @ poses[link][:3, :3]
            visuals.append(Visual(trimesh.Trimesh(local, np.asarray(world.faces), process=False),
                                  rgba=tuple(parts.colors.get(link, (0.7, 0.7, 0.7, 1.0)))))
        links[link] = Link(link, visuals=visuals)
    return ArticulatedAsset(name, links, joints, category=parts.category)


@register_method("geometry")
class GeometryBaseline:
    """The ``geometry`` method: :func:`estimate_joints` on the case's part meshes.

    Its geometry is the ground truth's, so its shape metrics are not meaningful (shown as n/a); its
    articulation metrics are the point.
    """

    name = "geometry"
    version = "1"
    inputs = ("part_meshes",)
    regime = "part meshes"
    #: It takes no options (its thresholds are :class:`GeometryOptions`' defaults).
    accepts: dict = {}

    def __init__(self, options: GeometryOptions | None = None):
        self.options = options or GeometryOptions()

    @classmethod
    def from_options(cls, options: dict) -> GeometryBaseline:
        """The registry's factory (no options)."""
        return cls()

    def label(self) -> str:
        return "geometry (AnyMesh-style)"

    def prepare(self) -> None:
        """Nothing to prepare."""

    def config(self) -> dict:
        return asdict(self.options)

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        from spark_bench.asset.urdf import write_object_folder

        parts = case.part_meshes()
        estimates = estimate_joints(parts, self.options)
        write_object_folder(build_asset(parts, estimates, name=case.case_id), out_dir)
        return Generation(Path(out_dir), {"joints": [e.summary() for e in estimates.values()]},
                          shape_metrics_valid=False)
