"""The scripted opener pushes a door open from inside when its handle slips out with the door open so far that
re-grasping the handle fails: a passive wrist sprung back leaves the fingers far off square to a door swung
past a right angle (a real safe's door, let go at 0.64 of its 176 degrees, stopped at 0.746 and could not
be grasped again)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import observation as OBS
from spark_bench.envs.assets import load_asset
from spark_bench.opening.door_geometry import door_edge, turns_in_place
from spark_bench.opening.episodes import ground_truth_joint, opener_for
from spark_bench.opening.opener import FIT_CLEARANCE, ScriptedOpener, rotate_about

#: The procedural cabinet's door given a safe's range (172 degrees), let go at RELEASE of it, to be opened to
#: TARGET: the re-grasp reaches 0.78-0.87 on seeds 0-3 (the wrist has sprung back, the fingers meet the door
#: off square), the push from inside the full range.
RANGE, RELEASE, TARGET, STEPS = 3.0, 0.6, 0.9, 60


def _wide_door_env():
    asset = load_asset("procedural:0")[0].copy()
    door = next(j for j in asset.joints.values() if j.type == "revolute")
    door.upper = RANGE
    return gym.make("SparkDoor-v0", asset=asset, joint=door.name, max_episode_steps=300, target_fraction=TARGET)


def _released_then_reopened(env, seed: int, push: bool) -> tuple[float, float, set]:
    """Open the door with the opener to RELEASE, let go (fingers open, the hand runs on along the swing for 4
    steps, as when a handle slips out), then let the opener go on for STEPS steps; the fraction let go at,
    the largest fraction reached after, and the opener's phases. ``push=False``: the re-grasp only."""
    unwrapped = env.unwrapped
    axis, pivot, joint_type = ground_truth_joint(env)
    opener = opener_for(env, axis, pivot, joint_type)
    if not push:
        opener.edge = None
    obs, _ = env.reset(seed=seed)
    for _ in range(150):
        if unwrapped.joint_fraction >= RELEASE:
            break
        obs, *_ = env.step(opener(obs))
    assert unwrapped.joint_fraction >= RELEASE and opener.regrasps == 0
    grasp = obs[OBS.GRASP].astype(float)
    swing = np.cross(axis, grasp - pivot)
    swing /= np.linalg.norm(swing)
    for _ in range(4):
        obs, *_ = env.step(np.append(swing, -1.0).astype(np.float32))
    released, best, phases = unwrapped.joint_fraction, 0.0, set()
    for _ in range(STEPS):
        obs, *_ = env.step(opener(obs))
        best, phases = max(best, unwrapped.joint_fraction), phases | {opener.phase}
    return released, best, phases


def test_a_wide_door_let_go_far_open_is_pushed_open_from_inside_where_the_re_grasp_fails():
    env = _wide_door_env()
    for seed in (0, 2):
        released, regrasped, phases = _released_then_reopened(env, seed, push=False)
        assert regrasped < TARGET, (seed, released, regrasped)  # the premise: the re-grasp does not open it
        assert "around" not in phases
        released, pushed, phases = _released_then_reopened(env, seed, push=True)
        assert released < TARGET - 0.1
        assert {"around", "push"} <= phases
        assert pushed >= TARGET, (seed, released, pushed)
    env.close()


def test_door_edge_reads_the_free_edge_and_the_inside_face_near_it():
    """A 60 cm wide, 4 cm thick slab hinged about z at x = 0, its front face at y = 0 (outward -y), a 3 cm
    handle at x = 0.5: the edge is 60 cm from the hinge at the handle's height and level, the inside face 7 cm
    behind the handle's tip. A slab thicker towards the hinge only (a shelf on its inside) does not count."""
    rng = np.random.default_rng(0)
    slab = rng.uniform([0.0, 0.0, 0.0], [0.6, 0.04, 0.8], (4000, 3))
    handle = rng.uniform([0.48, -0.03, 0.35], [0.52, 0.0, 0.45], (200, 3))
    shelf = rng.uniform([0.05, 0.04, 0.3], [0.4, 0.25, 0.32], (500, 3))
    grasp, outward, axis, pivot = np.array([0.5, -0.03, 0.4]), np.array([0.0, -1.0, 0.0]), np.array([0, 0, 1.0]), 0
    edge = door_edge(np.concatenate([slab, handle, shelf]), grasp, outward, axis, np.zeros(3) + pivot)
    assert np.allclose(edge.point, [0.6, -0.03, 0.4], atol=0.01)
    assert abs(edge.depth - 0.07) < 0.005
    assert door_edge(np.zeros((0, 3)), grasp, outward, axis, np.zeros(3)) is None
    assert door_edge(slab, np.array([0.0, 0.0, 0.4]), outward, axis, np.zeros(3)) is None  # grasp on the hinge


def test_a_door_barely_open_is_re_grasped_not_pushed():
    """The push needs the hand (FIT_CLEARANCE) to fit between the door's inside face and the body's front:
    a door slipped 5 degrees open is grasped again, one slipped 60 degrees open is pushed."""
    rng = np.random.default_rng(0)
    slab = rng.uniform([0.0, 0.0, 0.0], [0.6, 0.04, 0.8], (4000, 3))
    grasp, outward, axis = np.array([0.5, -0.03, 0.4]), np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, -1.0])
    edge = door_edge(slab, grasp, outward, axis, np.zeros(3))
    for degrees, pushed in ((5, False), (60, True)):
        opener = ScriptedOpener(axis, np.zeros(3), "revolute", outward, edge=edge)
        opener.rest_grasp = grasp
        moved = rotate_about(grasp, np.zeros(3), axis, np.radians(degrees))
        assert ((opener._push_path(moved + np.array([0.0, -0.06, 0.0]), moved) is not None) == pushed), degrees
    assert FIT_CLEARANCE > 0.05


def test_a_drawer_has_no_edge_to_push():
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    axis, pivot, joint_type = ground_truth_joint(env)
    assert opener_for(env, axis, pivot, joint_type).edge is None
    env.close()


def test_a_cap_turns_in_place_and_a_door_swings():
    """A part around its axis (a cap: a cylinder about it) turns in place, and its re-grasp is a drawer's,
    never the door's guarded approach or the push; a slab hinged at its side, gripped near its free edge,
    swings, and so does a lid; a near-axis grasp on a side-hung door still swings (its centroid is off the
    axis). Shared bottle 3763's cap was lost on 4 of 5 seeds when it was re-grasped as a door."""
    rng = np.random.default_rng(0)
    angle, height = rng.uniform(0, 2 * np.pi, 4000), rng.uniform(0, 0.1, 4000)
    cap = np.stack([0.15 * np.cos(angle), 0.15 * np.sin(angle), height], axis=1)
    z = np.array([0.0, 0.0, 1.0])
    assert turns_in_place(cap, grasp=(0.15, 0.0, 0.05), axis=z, pivot=(0.0, 0.0, 0.0))
    door = np.stack([rng.uniform(-0.02, 0.0, 4000), rng.uniform(0.0, 0.6, 4000), rng.uniform(0, 0.8, 4000)], axis=1)
    assert not turns_in_place(door, grasp=(0.0, 0.55, 0.4), axis=z, pivot=(0.0, 0.0, 0.0))
    assert not turns_in_place(door, grasp=(0.0, 0.12, 0.4), axis=z, pivot=(0.0, 0.0, 0.0))
    lid = door[:, [2, 1, 0]]  # the same slab lying flat, hinged along x at its back edge
    assert not turns_in_place(lid, grasp=(0.4, 0.55, 0.0), axis=(1.0, 0.0, 0.0), pivot=(0.0, 0.0, 0.0))
    assert not turns_in_place(np.zeros((0, 3)), grasp=(0.1, 0.0, 0.0), axis=z, pivot=(0.0, 0.0, 0.0))

    opener = ScriptedOpener(z, np.zeros(3), "continuous", (1.0, 0.0, 0.0), in_place=True)
    assert opener.rotational and not opener.swinging
    assert ScriptedOpener(z, np.zeros(3), "revolute", (1.0, 0.0, 0.0)).swinging
