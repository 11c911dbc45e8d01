"""The suction cup (``end_effector="suction"`` / ``"auto"``): the environment loads with the observation's
size unchanged, the cup attaches and holds by its rated force only, it opens a drawer and a door with no
handle planned from the true joint and fails planned from a wrong axis, and ``auto`` keeps the gripper where
a handle exists."""

from __future__ import annotations

import numpy as np
import pytest

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs import make_env
from spark_bench.envs import observation as OBS
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.manipulation.scene import N_SUBSTEPS
from spark_bench.manipulation.suction import SuctionConfig, choose_end_effector
from spark_bench.manipulation.task import build_scene
from spark_bench.mujoco_gl import mujoco_module
from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint

mujoco = mujoco_module()


def _handleless(part: str = "link_0"):
    """The procedural cabinet with the drawer's (link_0) or the door's (link_1) handle taken off: a flat front."""
    asset = procedural_cabinet(0)
    link = asset.links[part]
    keep = 5 if part == "link_0" else 1  # the drawer's box (5 panels), the door's panel
    link.visuals, link.collisions = link.visuals[:keep], link.collisions[:keep]
    return asset


def _quarter_turned(axis: np.ndarray, about: np.ndarray) -> np.ndarray:
    """``axis`` turned by 90 degrees about the unit direction ``about``."""
    return np.cross(about, axis) + about * float(about @ axis)


def test_the_suction_environment_loads_with_the_observation_unchanged_in_size():
    asset = _handleless()
    for observation, size in (("basic", OBS.OBS_SIZE), ("frame", OBS.FRAME_OBS_SIZE)):
        env = make_env("SparkDrawer-v0", asset=asset, joint="joint_0", end_effector="suction", observation=observation)
        obs, info = env.reset(seed=0)
        assert obs.shape == (size,) and env.observation_space.contains(obs)
        assert info["end_effector"] == "suction" and env.unwrapped.end_effector == "suction"
        assert obs[OBS.SUCTION] == 0.0  # released at the start
        _, _, _, _, info = env.step(np.array([0, 0, 0, 1.0], dtype=np.float32))
        assert info["end_effector"] == "suction" and env.unwrapped._obs()[OBS.SUCTION] == 1.0
        env.close()
    grasp = env.unwrapped.scene.grasp
    front = procedural_cabinet(0).links["link_0"]  # the cup sits on the drawer's front face, well inside it
    assert grasp.source == "suction" and grasp.reason is None and grasp.outward @ [-1, 0, 0] > 0.99
    low, high = asset.mesh(links=[front.name]).bounds
    assert abs(grasp.point[0] - low[0]) < 0.003
    assert low[1] + 0.02 <= grasp.point[1] <= high[1] - 0.02 and low[2] + 0.02 <= grasp.point[2] <= high[2] - 0.02


def _pull_after_attach(max_force: float, suction: float) -> float:
    """Attach the cup to the handleless drawer held shut (its joint very stiffly damped), then pull it straight
    out with the carriage's largest single-axis pull (60 N) for 1 s; returns how far (m) the cup's face ends
    from its place on the drawer."""
    scene = build_scene(_handleless(), "prismatic", "joint_0", end_effector="suction",
                        suction=SuctionConfig(max_force=max_force))
    model, grasp = scene.model, scene.grasp
    data = mujoco.MjData(model)
    data.qpos[:] = scene.rest_qpos
    slides = [model.jnt_qposadr[model.joint(n).id] for n in scene.gripper.slide_joints]
    servos = [model.actuator(n).id for n in scene.gripper.slide_actuators]
    cup = model.actuator(scene.gripper.suction_actuator).id
    data.qpos[slides] = grasp.point + 0.01 * grasp.outward
    data.ctrl[servos] = grasp.point - 0.005 * grasp.outward
    model.dof_damping[model.jnt_dofadr[model.joint(scene.joint.name).id]] = 1e6
    data.ctrl[cup] = suction
    for _ in range(10):  # pressed on, sucking
        mujoco.mj_step(model, data, nstep=N_SUBSTEPS)
    for _ in range(25):  # pulled out: the servo target 2 cm out of the cup, as an action of 1 sets it
        data.ctrl[servos] = data.qpos[slides] + 0.02 * grasp.outward
        mujoco.mj_step(model, data, nstep=N_SUBSTEPS)
    body = model.body(scene.grasp_body).id
    place = data.xpos[body] + data.xmat[body].reshape(3, 3) @ scene.grasp_local
    return float(np.linalg.norm(data.qpos[slides] - place))


def test_the_cup_holds_up_to_its_rated_force_and_lets_go_beyond_it():
    """60 N straight out: a 75 N cup holds (its face stays on the drawer), a 20 N cup and a cup not sucking
    come off."""
    assert _pull_after_attach(75.0, 1.0) < 0.005
    assert _pull_after_attach(20.0, 1.0) > 0.05
    assert _pull_after_attach(75.0, 0.0) > 0.05


@pytest.mark.parametrize("env_id,part,joint", [("SparkDrawer-v0", "link_0", "joint_0"),
                                               ("SparkDoor-v0", "link_1", "joint_1")])
def test_the_cup_opens_a_flat_front_with_the_true_joint_and_fails_with_a_wrong_axis(env_id, part, joint):
    env = make_env(env_id, asset=_handleless(part), joint=joint, end_effector="suction", max_episode_steps=200)
    grasp = env.unwrapped.scene.grasp
    opened = open_with_ground_truth(env, seed=0, max_steps=200)
    assert opened.success and opened.end_effector == "suction"
    axis, pivot, joint_type = ground_truth_joint(env)
    # a drawer's axis turned sideways (about the vertical), a door's hinge turned in the door's plane
    about = np.array([0.0, 0.0, 1.0]) if joint_type == "prismatic" else grasp.outward
    wrong = open_with_joint(env, _quarter_turned(axis, about), pivot, joint_type, seed=0, max_steps=200)
    assert not wrong.success and wrong.max_fraction < 0.3
    env.close()


def test_auto_keeps_the_gripper_where_a_handle_exists_and_takes_the_cup_where_none_does():
    with_handle = make_env("SparkDrawer-v0", asset=procedural_cabinet(0), joint="joint_0", end_effector="auto")
    default = make_env("SparkDrawer-v0", asset=procedural_cabinet(0), joint="joint_0")
    scene = with_handle.unwrapped.scene
    assert scene.end_effector == "gripper" and scene.grasp.has_handle
    np.testing.assert_allclose(scene.grasp.point, default.unwrapped.scene.grasp.point)
    assert open_with_ground_truth(with_handle, seed=0).end_effector == "gripper"
    flat = make_env("SparkDrawer-v0", asset=_handleless(), joint="joint_0", end_effector="auto")
    assert flat.unwrapped.end_effector == "suction"
    gripper = make_env("SparkDrawer-v0", asset=_handleless(), joint="joint_0")
    assert gripper.unwrapped.scene.grasp.declined == "no_handle" and gripper.unwrapped.scene.grasp.reason
    for env in (with_handle, default, flat, gripper):
        env.close()


def test_auto_keeps_the_gripper_for_parts_declined_for_another_reason():
    """A push button or a blocked approach is no case for the cup: the planner's reason stands."""
    assert choose_end_effector("auto", "button") == "gripper"
    assert choose_end_effector("auto", "blocked") == "gripper"
    assert choose_end_effector("auto", "too_wide") == "suction"
    assert choose_end_effector("auto", None) == "gripper"
    with pytest.raises(ValueError, match="end_effector"):
        choose_end_effector("magnet", None)


def test_a_rollout_says_which_end_effector_opened_the_part():
    from spark_bench.rl.rollout import rollout, stats_json

    cup = rollout("SparkDrawer-v0", asset=_handleless(), joint="joint_0", episodes=1, end_effector="auto")
    assert cup.end_effector == "suction" and cup.success_rate == 1.0 and '"end_effector": "suction"' in stats_json(cup)
    gripper = rollout("SparkDrawer-v0", asset=_handleless(), joint="joint_0", episodes=1)
    assert gripper.end_effector == "gripper" and gripper.episodes == 0 and "no handle" in gripper.reason


def _framed_pane(recess: float):
    """A door's front seen along -x: a 20 mm frame (too narrow for the 40 mm cup) around a pane ``recess``
    behind it (a microwave door's glass), hinged along its left edge."""
    import trimesh

    from spark_bench.manipulation.features import Front, perpendicular_basis

    w, h, rim, t = 0.24, 0.33, 0.02, 0.02
    bars = [((t, rim, h), (0, -w / 2 + rim / 2, 0)), ((t, rim, h), (0, w / 2 - rim / 2, 0)),
            ((t, w, rim), (0, 0, -h / 2 + rim / 2)), ((t, w, rim), (0, 0, h / 2 - rim / 2))]
    parts = [trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c)) for e, c in bars]
    parts.append(trimesh.creation.box(extents=(0.004, w - 2 * rim, h - 2 * rim),
                                      transform=trimesh.transformations.translation_matrix((recess + 0.002 - t / 2, 0, 0))))
    part = trimesh.util.concatenate(parts)
    outward = np.array([-1.0, 0.0, 0.0])
    return Front(part=part, points=np.asarray(part.sample(20000, seed=0)), outward=outward, basis=perpendicular_basis(outward),
                 face=t / 2, origin=np.array([0.0, -w / 2, 0.0]), axis=np.array([0.0, 0.0, 1.0]), rotational=True)


def test_the_cup_sits_on_a_pane_recessed_behind_a_narrow_frame():
    from spark_bench.manipulation.suction import recessed_levels, suction_point

    config = SuctionConfig()
    front = _framed_pane(0.015)
    assert len(cup_footprint_on_face(front, config)) == 0  # the frame itself holds no cup
    levels = recessed_levels(front, config)
    assert levels and abs(levels[0] - (front.face - 0.015)) <= 0.002
    point = suction_point(front, config)
    assert point is not None and abs(point @ front.outward - levels[0]) < 1e-9
    # on the pane, clear of the frame by the cup's radius and its side clearance, far from the hinge
    assert point[1] >= 0.0 and abs(point[1]) <= 0.12 - 0.02 - config.cup_radius
    # a pane deeper than the cup's bellows reach is no place for it
    assert suction_point(_framed_pane(0.045), config) is None


def cup_footprint_on_face(front, config):
    from spark_bench.manipulation.suction import cup_footprint

    return cup_footprint(front, config)[0]


def test_smaller_cups_hold_with_the_same_vacuum_scaled_by_their_area():
    from spark_bench.manipulation.suction import cup_sizes

    cups = cup_sizes(SuctionConfig())
    assert [round(2000 * c.cup_radius) for c in cups] == [40, 32, 25, 20]
    assert [round(c.max_force) for c in cups] == [75, 48, 29, 19]  # 60 kPa x pi r^2
    assert len(cup_sizes(SuctionConfig(smaller_cups=()))) == 1
    # a "smaller" cup that is not smaller than the configured one is not offered
    assert [c.cup_radius for c in cup_sizes(SuctionConfig(cup_radius=0.015))] == [0.015, 0.0125, 0.010]


def _strip(height: float, width: float = 0.14):
    """A drawer's front seen along -x: a board ``height`` tall and ``width`` wide, 20 mm thick."""
    import trimesh

    from spark_bench.manipulation.features import Front, perpendicular_basis

    part = trimesh.creation.box(extents=(0.02, width, height))
    outward = np.array([-1.0, 0.0, 0.0])
    return Front(part=part, points=np.asarray(part.sample(20000, seed=0)), outward=outward, basis=perpendicular_basis(outward),
                 face=0.01, origin=np.zeros(3), axis=outward, rotational=False)


def test_a_front_too_small_for_the_40_mm_cup_takes_the_largest_smaller_cup_that_fits():
    from spark_bench.manipulation.suction import cup_sizes, suction_point

    cups = cup_sizes(SuctionConfig())
    front = _strip(0.036)  # a small drawer's front at its real size: room for a 25 mm cup, not a 32 mm one
    assert suction_point(front, cups[0]) is None and suction_point(front, cups[1]) is None
    fits = [c for c in cups if suction_point(front, c) is not None]
    assert fits and fits[0].cup_radius == 0.0125
    point = suction_point(front, fits[0])
    assert abs(point[2]) < 0.005 and abs(point[1]) < 0.01  # central on the drawer
    # 18 mm of front holds none of them
    assert all(suction_point(_strip(0.018), c) is None for c in cups)


@pytest.mark.slow
def test_the_scene_carries_the_cup_the_planner_chose_and_judges_the_part_with_its_hold():
    """A cup wider than the drawer's front has no place on it; the planner takes the smaller one offered, and
    the scene's adhesion actuator and its stuck check hold with that cup's force (its area's share)."""
    from dataclasses import replace

    from spark_bench.manipulation.suction import fitted_cup, largest_hold

    config = SuctionConfig(cup_radius=0.2, max_force=7500.0, smaller_cups=(0.02,))
    scene = build_scene(_handleless(), "prismatic", "joint_0", end_effector="suction", suction=config)
    assert scene.grasp.cup_radius == 0.02 and scene.grasp.reason is None
    cup = scene.gripper.config
    assert cup.cup_radius == 0.02 and cup.max_force == pytest.approx(75.0)
    gain = scene.model.actuator_gainprm[scene.model.actuator(scene.gripper.suction_actuator).id][0]
    assert gain == pytest.approx(75.0)
    assert largest_hold(cup) <= 75.0 + 1e-9
    assert fitted_cup(scene.grasp, config) == cup
    with pytest.raises(ValueError, match="not one of the configured cups"):
        fitted_cup(replace(scene.grasp, cup_radius=0.03), SuctionConfig())
    none_fits = build_scene(_handleless(), "prismatic", "joint_0", end_effector="suction",
                            suction=SuctionConfig(cup_radius=0.2, smaller_cups=(0.15,)))
    assert none_fits.grasp.reason and "no flat patch 300 mm across" in none_fits.grasp.reason
    assert "smallest suction cup" in none_fits.grasp.reason
