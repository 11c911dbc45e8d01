"""Which collision pairs are on: parent-child overlaps at rest, MuJoCo's ``filterparent``.

Every pair of links collides, as real parts do, except a parent and its child whose hulls overlap at
rest by more than ``ConvertOptions.exclude_overlap`` of the object's size: that overlap is by
construction (a cap around a bottle neck, a button sunk into its panel), and a contact there would push
the parts apart from the first step. "Parent" skips links without geometry (``*_helper`` links). A parent-child pair whose hulls block the
child's joint where the parent's surface does not (a button pressed into the hull that covers its
hole) is excluded too (:mod:`spark_bench.sim.phantom`).

MuJoCo drops contacts between a body and its parent when both move (``filterparent``); such pairs that
should collide get explicit ``<pair>`` elements instead of a global flag, so a spec extended with a
gripper keeps MuJoCo's usual filtering for the gripper's own bodies.
"""

from __future__ import annotations

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.prepared import PreparedObject


def geometric_parents(prepared: PreparedObject) -> dict[str, str]:
    """For each link with collision shapes, its nearest ancestor that has some (a ``*_helper`` link
    without geometry is skipped: the cap of a bottle and the bottle are parent and child)."""
    asset = prepared.asset
    parent_of = {j.child: j.parent for j in asset.joints.values()}
    out = {}
    for link in asset.links:
        if not prepared.shapes.get(link):
            continue
        ancestor = parent_of.get(link)
        while ancestor is not None and not prepared.shapes.get(ancestor):
            ancestor = parent_of.get(ancestor)
        if ancestor is not None:
            out[link] = ancestor
    return out


def rest_overlaps(model, data, pairs: set[tuple[str, str]]) -> dict[tuple[str, str], float]:
    """Deepest penetration (positive, m) per ``(parent, child)`` body pair at the model's rest pose."""
    mujoco = mujoco_module()

    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    out: dict[tuple[str, str], float] = {}
    for contact in data.contact[: data.ncon]:
        a = model.body(model.geom_bodyid[contact.geom1]).name
        b = model.body(model.geom_bodyid[contact.geom2]).name
        pair = (a, b) if (a, b) in pairs else (b, a) if (b, a) in pairs else None
        if pair is not None and contact.dist < 0:
            out[pair] = max(out.get(pair, 0.0), -float(contact.dist))
    return out


def _weld_of(asset: ArticulatedAsset, link: str) -> str | None:
    """The link whose body ``link`` is welded to (itself when its joint moves); None for the world."""
    while True:
        joint = asset.joint_of_child(link)
        if joint is None:
            return None
        if joint.is_movable:
            return link
        link = joint.parent


def filtered_by_mujoco(asset: ArticulatedAsset, a: str, b: str) -> bool:
    """Whether MuJoCo's ``filterparent`` drops contacts between the bodies of links ``a`` and ``b``:
    both move, and one's weld body is the weld parent of the other's."""
    wa, wb = _weld_of(asset, a), _weld_of(asset, b)
    if wa is None or wb is None:
        return False
    parent_a = _weld_of(asset, asset.joint_of_child(wa).parent)
    parent_b = _weld_of(asset, asset.joint_of_child(wb).parent)
    return wa == parent_b or wb == parent_a


def add_contact_filters(spec, prepared: PreparedObject) -> None:
    """Add ``<exclude>`` for the parent-child pairs that overlap at rest (``prepared.excluded``) and
    explicit ``<pair>`` elements between the collision geoms of the other parent-child pairs that
    MuJoCo's ``filterparent`` would drop."""
    for parent, child in sorted(prepared.excluded):
        spec.add_exclude(bodyname1=parent, bodyname2=child)
    friction = [prepared.options.friction] * 2 + [0.005, 0.0001, 0.0001]
    pairs = {(parent, child) for child, parent in geometric_parents(prepared).items()}
    for parent, child in sorted(pairs - set(prepared.excluded)):
        if not filtered_by_mujoco(prepared.asset, parent, child):
            continue
        for a in range(len(prepared.shapes[parent])):
            for b in range(len(prepared.shapes[child])):
                spec.add_pair(geomname1=f"{parent}_collision_{a}", geomname2=f"{child}_collision_{b}",
                              condim=3, friction=friction)
