"""The coarse URDF of SPARK's structure prior (paper section 3.1): its data model, JSON form and checks.

Every prior backend (``vlm``, ``annotation``, ``file``) produces a :class:`PriorStructure`:

- links with semantic labels;
- joints with a type from ``{fixed, revolute, prismatic}``, an axis from the six canonical directions of
  :data:`CANONICAL_AXES`, a coarse origin (a point on the axis) and limits with ``lower = 0`` and an upper
  bound taken from the predefined ``large`` / ``small`` ranges of :data:`DEFAULT_UPPER`.

Axes and origins are in the **object frame** of PartNet-Mobility meshes: Y up, the object's front towards
+Z, x to the object's right, in benchmark units (the object fits [-1, 1]^3, centered at 0). The world
(benchmark) frame is this frame turned by the root joint of every PartNet-Mobility URDF
(:data:`OBJECT_TO_WORLD`: Z up, front towards -X).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.asset.transforms import rpy_to_matrix
from spark_bench.errors import InputError

#: The paper's canonical dictionary of unit directions, object frame.
CANONICAL_AXES: dict[str, tuple[float, float, float]] = {
    "front": (0.0, 0.0, 1.0),
    "back": (0.0, 0.0, -1.0),
    "up": (0.0, 1.0, 0.0),
    "down": (0.0, -1.0, 0.0),
    "right": (1.0, 0.0, 0.0),
    "left": (-1.0, 0.0, 0.0),
}
PRIOR_JOINT_TYPES = (JointType.FIXED, JointType.REVOLUTE, JointType.PRISMATIC)
RANGES = ("large", "small")
#: Predefined upper limits (rad for revolute, benchmark units for prismatic) by motion range.
DEFAULT_UPPER: dict[str, dict[str, float]] = {
    "revolute": {"large": math.pi / 2, "small": math.pi / 12},
    "prismatic": {"large": 0.5, "small": 0.05},
    "fixed": {"large": 0.0, "small": 0.0},
}
#: The PartNet-Mobility root joint, ``rpy="1.570796 0 -1.570796"``: object frame -> world frame.
ROOT_RPY = (1.570796, 0.0, -1.570796)
OBJECT_TO_WORLD = rpy_to_matrix(ROOT_RPY)


def axis_vector(name: str) -> np.ndarray:
    """The unit vector of a canonical direction name."""
    return np.asarray(CANONICAL_AXES[name], dtype=float)


def object_axis(name: str, axis_frame=None) -> np.ndarray:
    """The object-frame direction of a prior joint's axis name.

    :param name: a key of :data:`CANONICAL_AXES`
    :param axis_frame: 3x3 rotation whose columns are the object-frame vectors of the named frame's x, y
        and z, when the prior names its axes in another frame (the case camera's, see
        :func:`spark_bench.methods.ours.prior.camera_axis_frame`); None: the names are the object frame's
    """
    vector = axis_vector(name)
    return vector if axis_frame is None else np.asarray(axis_frame, dtype=float) @ vector


def nearest_axis_name(vector) -> str:
    """The canonical direction closest in angle to ``vector`` (object frame), sign included."""
    v = np.asarray(vector, dtype=float)
    v = v / np.linalg.norm(v)
    return max(CANONICAL_AXES, key=lambda name: float(np.dot(axis_vector(name), v)))


@dataclass
class PriorLink:
    """A link of the coarse URDF.

    :param name: link name, unique (used to associate the link with its part mesh)
    :param label: semantic label (``door``, ``drawer``, ``body``...)
    """

    name: str
    label: str = ""


@dataclass
class PriorJoint:
    """A joint of the coarse URDF, object frame.

    :param name: joint name, unique
    :param type: one of :data:`PRIOR_JOINT_TYPES`
    :param parent: parent link name
    :param child: child link name
    :param axis: canonical direction name, a key of :data:`CANONICAL_AXES`
    :param origin: a point on the joint axis, object frame, benchmark units
    :param range: ``large`` or ``small`` motion range
    :param lower: lower limit, always 0
    :param upper: upper limit (rad or benchmark units)
    """

    name: str
    type: str
    parent: str
    child: str
    axis: str = "up"
    origin: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    range: str = "large"
    lower: float = 0.0
    upper: float = 0.0

    @property
    def axis_vector(self) -> np.ndarray:
        return axis_vector(self.axis)


@dataclass
class PriorStructure:
    """The coarse URDF: links and joints (a tree whose root is the object's static body).

    :param links: links in order, the root first
    :param joints: joints in order
    :param source: which backend made it (``vlm``, ``annotation``, ``file``)
    """

    links: list[PriorLink]
    joints: list[PriorJoint]
    source: str = ""

    def to_dict(self) -> dict:
        """The JSON form (the same as the VLM's answer schema, plus ``source``)."""
        return {"links": [asdict(link) for link in self.links],
                "joints": [asdict(joint) for joint in self.joints], "source": self.source}

    @property
    def root(self) -> str:
        children = {j.child for j in self.joints}
        return next(link.name for link in self.links if link.name not in children)

    def joint(self, name: str) -> PriorJoint:
        return next(j for j in self.joints if j.name == name)


def _fail(source, problem: str):
    raise InputError(source, problem)


def parse_structure(data, source=None, known_links: list[str] | None = None,
                    upper_table: dict | None = None, origin_bound: float = 2.0) -> PriorStructure:
    """Check a coarse-URDF answer (decoded JSON) and build a :class:`PriorStructure`.

    :param data: the decoded JSON object ``{"links": [...], "joints": [...]}``
    :param source: file or endpoint it came from, for one-line errors
    :param known_links: when the part meshes are known in advance, the link names: each exactly once
    :param upper_table: predefined upper limits by type and range (default :data:`DEFAULT_UPPER`);
        an explicit ``upper`` in a joint wins
    :param origin_bound: largest accepted absolute origin coordinate (benchmark units)
    :raises InputError: on any violation, naming the first one
    """
    table = upper_table or DEFAULT_UPPER
    if not isinstance(data, dict) or not isinstance(data.get("links"), list) or not isinstance(
            data.get("joints"), list):
        _fail(source, 'expected an object with "links" and "joints" lists')
    links = []
    for k, item in enumerate(data["links"]):
        if not isinstance(item, dict) or not isinstance(item.get("name"), str) or not item["name"]:
            _fail(source, f"links[{k}] needs a non-empty string name")
        links.append(PriorLink(name=item["name"], label=str(item.get("label", ""))))
    names = [link.name for link in links]
    if len(set(names)) != len(names):
        _fail(source, f"duplicate link names in {names}")
    if known_links is not None and set(names) - set(known_links):
        _fail(source, f"unknown link names {sorted(set(names) - set(known_links))}; expected from {known_links}")
    if known_links is not None and set(known_links) - set(names):  # each part mesh needs its link
        _fail(source, f"missing link names {sorted(set(known_links) - set(names))}; every part needs a link")
    joints = [_parse_joint(k, item, source, set(names), table, origin_bound)
              for k, item in enumerate(data["joints"])]
    _check_tree(names, joints, source)
    return PriorStructure(links=links, joints=joints, source=str(data.get("source", "")))


def _parse_joint(k, item, source, names: set, table, origin_bound) -> PriorJoint:
    where = f"joints[{k}]"
    if not isinstance(item, dict):
        _fail(source, f"{where} is not an object")
    name = item.get("name") or f"joint_{k}"
    jtype = item.get("type")
    if jtype == JointType.CONTINUOUS:
        jtype = "revolute"
    if jtype not in PRIOR_JOINT_TYPES:
        _fail(source, f"{where}: type {jtype!r} is not one of {list(PRIOR_JOINT_TYPES)}")
    for key in ("parent", "child"):
        if item.get(key) not in names:
            _fail(source, f"{where}: {key} {item.get(key)!r} is not a declared link")
    axis = item.get("axis", "up")
    if isinstance(axis, list | tuple):
        vec = np.asarray(axis, dtype=float) if len(axis) == 3 else None
        matches = [n for n in CANONICAL_AXES if vec is not None and np.allclose(axis_vector(n), vec, atol=1e-6)]
        if not matches:
            _fail(source, f"{where}: axis {axis} is not a canonical direction")
        axis = matches[0]
    if axis not in CANONICAL_AXES:
        _fail(source, f"{where}: axis {axis!r} is not one of {list(CANONICAL_AXES)}")
    origin = item.get("origin", [0.0, 0.0, 0.0])
    try:
        origin = [float(v) for v in origin]
    except (TypeError, ValueError):
        origin = []
    if len(origin) != 3 or not all(math.isfinite(v) and abs(v) <= origin_bound for v in origin):
        _fail(source, f"{where}: origin must be 3 finite numbers within +-{origin_bound}")
    motion_range = item.get("range", "large")
    if motion_range not in RANGES:
        _fail(source, f"{where}: range {motion_range!r} is not one of {list(RANGES)}")
    lower = float(item.get("lower", 0.0) or 0.0)
    if lower != 0.0:
        _fail(source, f"{where}: lower limit must be 0, got {lower}")
    upper = item.get("upper")
    upper = float(table[jtype][motion_range]) if upper is None else float(upper)
    if not math.isfinite(upper) or upper < 0:
        _fail(source, f"{where}: upper limit must be finite and >= 0, got {upper}")
    return PriorJoint(name=str(name), type=jtype, parent=item["parent"], child=item["child"], axis=axis,
                      origin=origin, range=motion_range, lower=0.0, upper=upper)


def _check_tree(names: list[str], joints: list[PriorJoint], source) -> None:
    children = [j.child for j in joints]
    if len(set(children)) != len(children):
        _fail(source, "a link is the child of two joints")
    if len({j.name for j in joints}) != len(joints):
        _fail(source, "duplicate joint names")
    roots = [n for n in names if n not in children]
    if len(roots) != 1:
        _fail(source, f"expected exactly one root link, found {roots}")
    parent_of = {j.child: j.parent for j in joints}
    for name in names:  # walk up: a cycle never reaches the root
        seen, link = set(), name
        while link in parent_of:
            if link in seen:
                _fail(source, f"joint cycle through link {link!r}")
            seen.add(link)
            link = parent_of[link]


def answer_schema(known_links: list[str] | None = None) -> dict:
    """JSON schema of the coarse-URDF answer, for ``response_format: json_schema`` requests."""
    name_schema: dict = {"type": "string"}
    if known_links:
        name_schema = {"type": "string", "enum": list(known_links)}
    joint = {
        "type": "object",
        "properties": {
            "name": {"type": "string"},
            "type": {"type": "string", "enum": list(PRIOR_JOINT_TYPES)},
            "parent": name_schema,
            "child": name_schema,
            "axis": {"type": "string", "enum": list(CANONICAL_AXES)},
            "origin": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
            "range": {"type": "string", "enum": list(RANGES)},
        },
        "required": ["name", "type", "parent", "child", "axis", "origin", "range"],
        "additionalProperties": False,
    }
    link = {"type": "object", "properties": {"name": name_schema, "label": {"type": "string"}},
            "required": ["name", "label"], "additionalProperties": False}
    return {
        "type": "object",
        "properties": {"links": {"type": "array", "items": link}, "joints": {"type": "array", "items": joint}},
        "required": ["links", "joints"],
        "additionalProperties": False,
    }
