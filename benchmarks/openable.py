"""Which joints of a real object are drawers, doors and lids: by their moving part's label
(PartNet-Mobility ``semantics.txt``). What the scripts measuring the opening score on real objects share."""

from __future__ import annotations

#: Part labels (PartNet-Mobility ``semantics.txt``) that make a joint a drawer, door or lid.
OPENABLE = {"drawer": "drawer", "door": "door", "rotation_door": "door", "translation_door": "door",
            "lid": "lid", "rotation_lid": "lid", "translation_lid": "lid", "rotation_window": "window",
            "translation_window": "window", "board": "board"}


def openable_joints(asset) -> list[dict]:
    """``[{"joint", "type", "label", "category", "env"}]``: the drawers, doors and lids of an object.

    :param asset: the object (:func:`spark_bench.envs.assets.load_asset`)
    """
    from spark_bench.envs import ENV_OF_JOINT_TYPE

    out = []
    for joint in asset.movable_joints():
        kind = OPENABLE.get(asset.links[joint.child].label)
        if kind is None or joint.type not in ENV_OF_JOINT_TYPE:
            continue
        out.append({"joint": joint.name, "type": joint.type, "label": kind, "category": asset.category,
                    "env": ENV_OF_JOINT_TYPE[joint.type]})
    return out


def openable(gt_bench) -> dict[str, str]:
    """``{joint: label}``: the drawers, doors and lids of a case's ground truth (by its links' labels).

    :param gt_bench: a case's ground truth (an articulated asset)
    """
    out = {}
    for joint in gt_bench.movable_joints():
        label = OPENABLE.get(gt_bench.links[joint.child].label)
        if label is not None and joint.type in ("prismatic", "revolute"):
            out[joint.name] = label
    return out
