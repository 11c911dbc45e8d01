"""Opening helpers shared by several test modules: a part opens with its true hinge and not with a wrong one;
the observation the scripted opener reads; the matching of an object's joints to themselves; the objects with
unusual grips that the grasp planner's and the scripted opener's tests share (a notched cabinet, a synth double
door)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from spark_bench.envs import observation as OBS
from spark_bench.envs.cabinet import procedural_cabinet

#: The finger-pull notches of :func:`notched_cabinet`: width across the front and depth into it, m.
NOTCH_WIDTH, NOTCH_DEPTH = 0.10, 0.028


def opens_with_its_hinge_only(env, max_steps: int, seed: int = 0) -> tuple[bool, bool]:
    """``(opened with the true joint, opened with the hinge turned 90 degrees in the grasped face's plane)``:
    one scripted episode each, planned from the environment's own joint and from that wrong one."""
    from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint

    true = open_with_ground_truth(env, seed=seed, max_steps=max_steps).success
    axis, pivot, joint_type = ground_truth_joint(env)
    outward = env.unwrapped.scene.grasp.outward
    wrong = np.cross(outward, axis) + outward * float(outward @ axis)
    return bool(true), bool(open_with_joint(env, wrong, pivot, joint_type, seed=seed, max_steps=max_steps).success)


def opener_observation(tcp: Sequence[float], grasp: Sequence[float],
                       touch: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """An observation of the environments' layout holding only what the scripted opener reads (zeros
    elsewhere).

    :param tcp: the gripper's tool centre point
    :param grasp: the grasp point
    :param touch: the pads' touch readings
    """
    obs = np.zeros(OBS.OBS_SIZE, dtype=np.float32)
    obs[OBS.TCP], obs[OBS.GRASP], obs[OBS.TOUCH] = tcp, grasp, touch
    return obs


def identity_matching(asset) -> dict:
    """The metrics' ``matching`` of ``asset``'s movable joints to themselves (a prediction that is the
    ground truth).

    :param asset: the object
    """
    return {"matching": [{"gt_joint": j.name, "pred_joint": j.name} for j in asset.movable_joints()]}


def notched_cabinet(seed: int = 0):
    """The procedural cabinet with its handles replaced by finger-pull notches cut through the fronts:
    one at the middle of the drawer front's top edge, one at the door's free edge."""
    from spark_bench.envs.cabinet import WOOD, box_part

    asset = procedural_cabinet(seed)

    def cut(link, panel, boxes):
        parts = [box_part(c, s, rgba) for c, s, rgba in boxes]
        link.visuals = [p[0] for p in parts] + link.visuals[1:panel]
        link.collisions = [p[1] for p in parts] + link.collisions[1:panel]

    drawer, door = asset.links["link_0"], asset.links["link_1"]
    (tx, w, h), (cx, _, _) = drawer.collisions[0].size, drawer.collisions[0].origin[:3, 3]
    side = (w - NOTCH_WIDTH) / 2
    cut(drawer, 5, [((cx, 0, -NOTCH_DEPTH / 2), (tx, w, h - NOTCH_DEPTH), WOOD),
                    ((cx, -(NOTCH_WIDTH + side) / 2, h / 2 - NOTCH_DEPTH / 2), (tx, side, NOTCH_DEPTH), WOOD),
                    ((cx, (NOTCH_WIDTH + side) / 2, h / 2 - NOTCH_DEPTH / 2), (tx, side, NOTCH_DEPTH), WOOD)])
    (tx, dw, dh), (cx, _, _) = door.collisions[0].size, door.collisions[0].origin[:3, 3]
    part = (dh - NOTCH_WIDTH) / 2
    cut(door, 1, [((cx, (dw - NOTCH_DEPTH) / 2, 0), (tx, dw - NOTCH_DEPTH, dh), WOOD),
                  ((cx, dw - NOTCH_DEPTH / 2, -(NOTCH_WIDTH + part) / 2), (tx, NOTCH_DEPTH, part), WOOD),
                  ((cx, dw - NOTCH_DEPTH / 2, (NOTCH_WIDTH + part) / 2), (tx, NOTCH_DEPTH, part), WOOD)])
    return asset


#: Synth StorageFurniture object 7 of ``generate_dataset(seed=0)`` (the benchmark's set): a double door
#: whose two edge lips (the handles) stand about 6 mm apart, half a default pad's thickness.
DOUBLE_DOOR_INDEX = 7


def double_door_cabinet(out):
    """Generate the synth double-door cabinet into ``out``; returns its folder."""
    from spark_bench.data.synth.generate import generate_object, object_seed

    return generate_object("StorageFurniture", object_seed(0, DOUBLE_DOOR_INDEX), out, "double_door")
