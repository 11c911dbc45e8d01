"""The names an MJCF model's bodies, joints and geoms go by in spark-bench: the author's, or where there is none,
one that says where the element is.

Every report (``check``, ``rollout``, ``metrics`` per joint, results rows, exports) names parts and joints by the
links and joints of the :class:`~spark_bench.asset.model.ArticulatedAsset`, so the reader gives those the names
the file gives: a hinge named ``microwave`` stays ``microwave``, a body ``drawer_link`` stays ``drawer_link``.
The world body is ``worldbody``, as the file writes it (MuJoCo's own name for it, ``world``, cannot name a
body of the models spark-bench builds; ``worldbody_2`` where a body of the file is named ``worldbody``). An element the file leaves unnamed is named after its place, stably
(the same file always reads the same): ``<body>:body<k>`` for the k-th child body of a body, ``<body>:hinge<k>``
(``slide``, ``ball``, ``free``) for the k-th joint of a body, ``<body>:geom<k>`` for its k-th geom (k counts
every element of that kind in the body, from 0, in file order). Names hold no white space and no ``/``: link
names become file names (``meshes/<link>_visual.obj``) and the first word of a ``semantics.txt`` line.

MuJoCo keeps each kind's names unique (bodies among bodies, joints among joints); a made-up name that an
author's name already holds is numbered (``_2``, ``_3``...).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from spark_bench.asset.naming import unique_name

#: The world body's name: its element in the file (``world``, MuJoCo's name, is reserved in a model).
WORLD = "worldbody"
#: MuJoCo's joint types, in ``mjtJoint`` order, as the made-up names spell them.
JOINT_WORDS = ("free", "ball", "slide", "hinge")
#: What a name may not hold (white space: ``semantics.txt`` splits on it; ``/``: link names are file names).
UNSAFE = re.compile(r"[\s/]+")


@dataclass
class ElementNames:
    """The name of every body, joint and geom of a compiled model, by MuJoCo index.

    :param bodies: body id -> name (``worldbody`` for body 0)
    :param joints: joint id -> name
    :param geoms: geom id -> name
    """

    bodies: list[str]
    joints: list[str]
    geoms: list[str]


def safe(name: str) -> str:
    """``name`` with each run of white space or ``/`` turned into ``_`` (an author's name kept readable)."""
    return UNSAFE.sub("_", name.strip()) or "_"


def _named(model, kind: str, count: int) -> list[str]:
    """Each element's author name made safe (numbered where two become one), "" where the file gives none."""
    used: set[str] = set()
    out = []
    for i in range(count):
        name = getattr(model, kind)(i).name
        out.append(unique_name(safe(name), used) if name else "")
    return out


def _place(written: list[str], owners: list[int], bodies: list[str], words: list[str]) -> list[str]:
    """The names of one kind of element: the written one, else ``<owner body>:<word><k>`` with k the element's
    index among its owner's elements; every name unique among the kind."""
    used = {w for w in written if w}
    seen: dict[int, int] = {}
    out = []
    for written_name, owner, word in zip(written, owners, words):
        k = seen.get(owner, 0)
        seen[owner] = k + 1
        out.append(written_name if written_name else unique_name(f"{bodies[owner]}:{word}{k}", used))
    return out


def element_names(model) -> ElementNames:
    """The names of every body, joint and geom of ``model`` (a compiled ``MjModel``; see the module docstring)."""
    written = _named(model, "body", model.nbody)
    used = {w for w in written[1:] if w}
    bodies = [unique_name(WORLD, used)]  # numbered where an author's body is so named (spark-bench's own model.xml)
    children: dict[int, int] = {}
    for b in range(1, model.nbody):  # MuJoCo orders parents before children
        parent = int(model.body_parentid[b])
        k = children.get(parent, 0)
        children[parent] = k + 1
        bodies.append(written[b] or unique_name(f"{bodies[parent]}:body{k}", used))
    joints = _place(_named(model, "jnt", model.njnt), [int(b) for b in model.jnt_bodyid], bodies,
                    [JOINT_WORDS[int(t)] for t in model.jnt_type])
    geoms = _place(_named(model, "geom", model.ngeom), [int(b) for b in model.geom_bodyid], bodies,
                   ["geom"] * model.ngeom)
    return ElementNames(bodies, joints, geoms)
