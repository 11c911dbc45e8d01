"""Which collision pairs are on: every pair but the excluded parent-child pairs, MuJoCo's ``filterparent``.

Every pair of links collides, as real parts do, a part with its own parent included. A parent and its child are
excluded only where their hulls meet (at rest, or along the child's joint) while the child's own path is free of
the parent's surface (:mod:`spark_bench.sim.phantom`: a button in the hull that covers its hole, a door whose hulls
overlap its frame's at rest), or where their hulls overlap at rest by construction and no cut parts them (a knob's
shaft through its panel: :mod:`spark_bench.sim.rest_trim`, which cuts apart the hulls of every other pair that
overlaps at rest). A part that moves into its parent (a door turned the wrong way) keeps colliding with it. "Parent"
skips links without geometry (``*_helper`` links).

MuJoCo drops contacts between a body and its parent when both move (``filterparent``); such pairs that
should collide get explicit ``<pair>`` elements instead of a global flag, so a spec extended with a
gripper keeps MuJoCo's usual filtering for the gripper's own bodies.
"""

from __future__ import annotations

from spark_bench.asset.model import ArticulatedAsset
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
    """Add ``<exclude>`` for the parent-child pairs excluded (``prepared.excluded``: no cut parts their hulls at rest,
    or only their hulls block the child's joint) and explicit ``<pair>`` elements between the collision geoms of the
    other parent-child pairs that MuJoCo's ``filterparent`` would drop."""
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
