"""The opening environments: registration, Gymnasium conformity, determinism, grasp points, errors, and the
unusual grips (a notch, lips side by side) carried out by the scripted opener."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.data.case import BenchmarkCase
from spark_bench.envs import observation as OBS
from spark_bench.envs.assets import asset_folder
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.errors import InputError
from spark_bench.opening.planning.grasp import find_grasp

ENV_IDS = ("SparkDrawer-v0", "SparkDoor-v0")


def test_import_registers_both_environments():
    for env_id in ENV_IDS:
        assert env_id in gym.registry
        assert gym.registry[env_id].max_episode_steps == 100


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_on_procedural_cabinet(env_id):
    env = gym.make(env_id, asset="procedural:0")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (OBS.OBS_SIZE,)
    assert env.action_space.shape == (4,)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reset_and_step_are_deterministic(env_id):
    env_a, env_b = gym.make(env_id, asset="procedural:1"), gym.make(env_id, asset="procedural:1")
    obs_a, _ = env_a.reset(seed=7)
    obs_b, _ = env_b.reset(seed=7)
    # exact: one code path run twice in one process (MuJoCo steps on one thread); determinism is the claim
    np.testing.assert_array_equal(obs_a, obs_b)
    actions = np.random.default_rng(0).uniform(-1, 1, size=(30, 4)).astype(np.float32)
    for action in actions:
        obs_a, reward_a, *_ = env_a.step(action)
        obs_b, reward_b, *_ = env_b.step(action)
    np.testing.assert_array_equal(obs_a, obs_b)
    assert reward_a == reward_b
    other, _ = env_a.reset(seed=8)
    assert not np.allclose(other[:3], env_b.reset(seed=7)[0][:3])


def test_an_environment_that_never_renders_leaves_the_visuals_out_and_moves_the_same():
    """Visual geoms have no contacts and no mass: without them (no ``render_mode``) the scene compiles
    faster and the same actions give the same motion (to 1e-6: two compiled models, one code path)."""
    plain = gym.make("SparkDrawer-v0", asset="procedural:0")
    rendered = gym.make("SparkDrawer-v0", asset="procedural:0", render_mode="rgb_array")
    names = [plain.unwrapped.model.geom(i).name for i in range(plain.unwrapped.model.ngeom)]
    assert "link_0_collision_0" in names and not any(n.endswith("_visual") for n in names)
    obs_a, _ = plain.reset(seed=3)
    obs_b, _ = rendered.reset(seed=3)
    for action in np.random.default_rng(1).uniform(-1, 1, size=(40, 4)).astype(np.float32):
        obs_a, *_ = plain.step(action)
        obs_b, *_ = rendered.step(action)
    np.testing.assert_allclose(obs_a, obs_b, atol=1e-6)
    assert not np.allclose(obs_a[:3], plain.reset(seed=3)[0][:3])  # the actions moved the gripper


def test_object_comes_from_the_sim_conversion():
    """The object's geoms are spark_bench.sim's (named collision hulls in class ``collision``), and the
    gripper's pads collide with them (contype 2 & conaffinity 1) but not with each other."""
    env = gym.make("SparkDrawer-v0", asset="procedural:0", render_mode="rgb_array")
    model = env.unwrapped.model
    names = [model.geom(i).name for i in range(model.ngeom)]
    assert "link_0_collision_0" in names and "link_0_visual" in names
    hull, pad = model.geom("link_0_collision_0"), model.geom("spark_gripper_pad_left")
    assert (hull.contype & pad.conaffinity) or (pad.contype & hull.conaffinity)
    other = model.geom("spark_gripper_pad_right")
    assert not (pad.contype & other.conaffinity) and not (other.contype & pad.conaffinity)
    assert model.geom("link_0_visual").contype == 0


def test_grasp_picks_one_of_several_labelled_knobs():
    """A handle link holding two knobs (a wide drawer) is grasped at one knob, not between them."""
    from spark_bench.asset.model import Collision, Link, Visual

    asset = procedural_cabinet(0)
    drawer = asset.links["link_0"]
    knobs = []
    for y in (-0.15, 0.15):
        origin = np.eye(4)
        origin[:3, 3] = (-0.03, y, 0.0)
        knobs.append((trimesh_box(origin), Collision(kind="box", origin=origin, size=np.full(3, 0.03))))
    drawer.visuals, drawer.collisions = drawer.visuals[:5], drawer.collisions[:5]  # no bar
    asset.links["knobs"] = Link(name="knobs", visuals=[Visual(mesh=m) for m, _ in knobs],
                                collisions=[c for _, c in knobs], label="handle")
    from spark_bench.asset.model import Joint

    asset.joints["knobs_fixed"] = Joint("knobs_fixed", "fixed", "link_0", "knobs", origin=np.eye(4))
    grasp = find_grasp(asset, "joint_0")
    knob_y = asset.link_poses()["link_0"][1, 3] + np.array([-0.15, 0.15])
    assert grasp.source == "label" and np.min(np.abs(grasp.point[1] - knob_y)) < 0.01


def trimesh_box(origin):
    import trimesh

    return trimesh.creation.box(extents=(0.03, 0.03, 0.03), transform=origin)


def test_start_state_is_in_front_of_the_handle():
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    obs, info = env.reset(seed=0)
    tcp, grasp = obs[OBS.TCP], obs[OBS.GRASP]
    # the cabinet's front faces -X: the gripper starts ~0.1 m in front of (smaller x than) the handle
    assert 0.06 < grasp[0] - tcp[0] < 0.14
    assert obs[OBS.JOINT_FRACTION] == pytest.approx(0.0, abs=1e-9)
    assert obs[OBS.FINGERS] == pytest.approx(1.0, abs=1e-6)
    assert not info["is_success"] and 0.0 < info["reach"] < 1.0


def _pads_cover(grasp, center, thickness, outward):
    """The grasp is over the bar (in the front plane) and the pads, from the fingertips back along their
    length, cover the bar's whole depth."""
    from spark_bench.opening.planning.gripper import GripperConfig

    config = GripperConfig()
    lateral = (grasp.point - center) - ((grasp.point - center) @ outward) * outward
    tips = (grasp.point - center) @ outward - config.tip_beyond_tcp  # the fingertips' level, from the bar's
    return (np.linalg.norm(lateral) < 0.005 and tips < -thickness / 2
            and tips + config.finger_length > thickness / 2)


def test_grasp_point_is_the_handle_bar_on_the_procedural_cabinet():
    """The pads are centred on the bar and reach down past it towards the front (a bar or a knob's head is
    held from behind, not pinched at its rounded front), fingertips clear of the front."""
    from spark_bench.opening.planning.handles import TIP_CLEARANCE

    asset = procedural_cabinet(0)
    poses = asset.link_poses()
    drawer = find_grasp(asset, "joint_0")
    bar = asset.links["link_0"].collisions[5]  # the drawer's bar handle
    bar_center = (poses["link_0"] @ bar.origin)[:3, 3]
    assert _pads_cover(drawer, bar_center, bar.size[0], drawer.outward)
    front = (poses["link_0"] @ asset.links["link_0"].collisions[0].origin)[0, 3] - 0.01  # the panel's front, x
    assert drawer.point[0] + 0.012 == pytest.approx(front - TIP_CLEARANCE, abs=0.0025)  # tips 3 mm off it
    np.testing.assert_allclose(drawer.outward, [-1, 0, 0], atol=1e-6)
    assert abs(drawer.long_axis[1]) > 0.99  # a horizontal bar: fingers close vertically
    door = find_grasp(asset, "joint_1")
    bar = asset.links["link_1"].collisions[1]
    assert _pads_cover(door, (poses["link_1"] @ bar.origin)[:3, 3], bar.size[0], door.outward)
    assert abs(door.long_axis[2]) > 0.99 and door.source == "geometry"
    # nothing else stands beside these handles: the fingers approach fully open, with the default pads
    assert drawer.opening is None and door.opening is None and door.pad_thickness is None


def test_grasp_points_match_partnet_handle_annotations(real_object):
    """Found from geometry alone, the grasp point lies on the annotated handle (PartNet result.json)."""
    from spark_bench.asset.transforms import transform_points
    from spark_bench.data import load_object

    folder = real_object("41083")
    tree = json.loads((folder / "result.json").read_text())

    def handle_objs(nodes, inside=False):
        out = []
        for node in nodes:
            here = inside or node.get("name") == "handle"
            if here:
                out += node.get("objs", [])
            out += handle_objs(node.get("children", []), here)
        return out

    names = {f"textured_objs/{name}.obj" for name in handle_objs(tree)}
    asset = load_object(folder)
    poses = asset.link_poses()
    for joint in asset.movable_joints():
        link = asset.links[joint.child]
        points = np.concatenate([transform_points(poses[link.name], v.mesh.vertices)
                                 for v in link.visuals if v.source in names])
        grasp = find_grasp(asset, joint.name)
        assert np.all(grasp.point > points.min(0) - 0.02) and np.all(grasp.point < points.max(0) + 0.02), joint.name


def test_unknown_joint_and_wrong_kind_fail_at_make():
    with pytest.raises(InputError, match="no joint named 'nope'"):
        gym.make("SparkDrawer-v0", asset="procedural:0", joint="nope")
    with pytest.raises(InputError, match="is revolute, this task needs a prismatic joint"):
        gym.make("SparkDrawer-v0", asset="procedural:0", joint="joint_1")
    doorless = procedural_cabinet(0)
    del doorless.joints["joint_1"], doorless.links["link_1"]
    with pytest.raises(InputError, match="no revolute joint"):
        gym.make("SparkDoor-v0", asset=doorless)


def test_case_folder_maps_to_its_ground_truth(tmp_path):
    case = BenchmarkCase(tmp_path)
    case.write_record({"id": "c0"})
    with pytest.raises(InputError, match=f"no {case.gt_dir.name}/"):
        asset_folder(tmp_path)
    case.gt_dir.mkdir()
    assert asset_folder(tmp_path) == case.gt_dir
    assert asset_folder(case.gt_dir) == case.gt_dir  # the ground truth's own folder is an object folder
    with pytest.raises(InputError, match="no such"):
        asset_folder(tmp_path / "absent")


def test_default_cabinet_is_generated_once_per_generator_version(tmp_path, monkeypatch):
    from spark_bench.data import load_object
    from spark_bench.data.synth import GENERATOR_VERSION
    from spark_bench.envs import assets

    monkeypatch.setenv("SPARK_BENCH_HOME", str(tmp_path))
    folder = assets.default_asset_path()
    assert folder.parent == tmp_path / "envs" and assets.has_kinds(load_object(folder, load_meshes=False))
    marker = tmp_path / "envs" / f"default_cabinet_v{GENERATOR_VERSION}.txt"
    assert marker.read_text() == folder.name
    (folder / "mobility.urdf").write_text("<robot/>")  # a cache hit does not regenerate
    assert assets.default_asset_path() == folder and (folder / "mobility.urdf").read_text() == "<robot/>"
    monkeypatch.setattr(assets, "_synth_generator", lambda: (lambda *a: pytest.fail("regenerated"), "0.0-other"))
    with pytest.raises(pytest.fail.Exception, match="regenerated"):  # another generator version: generated anew
        assets.default_asset_path()


def test_sparse_reward_and_rgb_render():
    env = gym.make("SparkDoor-v0", asset="procedural:0", reward_type="sparse", render_mode="rgb_array",
                   width=160, height=120)
    env.reset(seed=0)
    _, reward, *_ = env.step(env.action_space.sample())
    assert reward == 0.0
    frame = env.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8 and frame.std() > 5
    env.close()


@pytest.mark.slow
@pytest.mark.parametrize("object_id,env_ids", [("41083", ENV_IDS), ("45780", ("SparkDoor-v0",))])
def test_check_env_on_real_objects(real_object, object_id, env_ids):
    """Gymnasium-conformant on real objects, and a sound start: the gripper in front of the grasp point
    (:data:`START_OFFSET` along the part's outward direction, give or take the start noise), the joint
    shut, and an idle gripper leaves the object at rest (nothing pushed, nothing falling open)."""
    from spark_bench.envs.base import START_NOISE, START_OFFSET

    folder = real_object(object_id)
    for env_id in env_ids:
        env = gym.make(env_id, asset=str(folder))
        check_env(env.unwrapped, skip_render_check=True)
        obs, info = env.reset(seed=0)
        tcp, grasp = obs[OBS.TCP].astype(float), obs[OBS.GRASP].astype(float)
        outward = env.unwrapped.scene.grasp.outward
        noise = np.sqrt(3.0) * START_NOISE  # the start's uniform noise, at most this far from its centre
        assert START_OFFSET - noise < (tcp - grasp) @ outward < START_OFFSET + noise, env_id
        assert obs[OBS.JOINT_FRACTION] == pytest.approx(0.0, abs=1e-9) and not info["is_success"]
        for _ in range(20):  # hold still (an action of zero keeps the TCP's target where the TCP is)
            obs, _, terminated, _, info = env.step(np.zeros(4, dtype=np.float32))
        assert not terminated and np.all(np.isfinite(obs))
        assert abs(env.unwrapped.joint_fraction) < 1e-3, (env_id, env.unwrapped.joint_fraction)
        assert np.linalg.norm(obs[OBS.GRASP] - grasp) < 1e-3  # the grasp point (on the part) has not moved
        env.close()


NOTCH_WIDTH, NOTCH_DEPTH = 0.10, 0.028


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


def test_a_notch_in_a_front_is_found_and_gripped_from_inside():
    asset = notched_cabinet(0)
    poses = asset.link_poses()
    drawer = find_grasp(asset, "joint_0")
    assert drawer.source == "notch" and drawer.grip == "inside" and drawer.inside_grip
    np.testing.assert_allclose(drawer.press, [0, 0, -1], atol=1e-6)  # the notch opens upwards
    np.testing.assert_allclose(drawer.notch_size, (NOTCH_DEPTH, NOTCH_WIDTH), atol=0.004)
    front = poses["link_0"] @ asset.links["link_0"].collisions[1].origin  # an upper piece of the front
    top = front[2, 3] + NOTCH_DEPTH / 2
    assert abs(drawer.point[1] - poses["link_0"][1, 3]) < 0.003  # centred across the drawer
    assert abs(drawer.point[2] - (top - NOTCH_DEPTH / 2)) < 0.003
    assert abs(drawer.closing[1]) > 0.99  # fingers open across the notch's width
    door = find_grasp(asset, "joint_1")
    assert door.source == "notch" and abs(door.closing[2]) > 0.99
    assert door.press[1] < -0.99  # from the free edge towards the hinge
    env = gym.make("SparkDrawer-v0", asset=asset)
    pad = env.unwrapped.model.geom("spark_gripper_pad_left")
    assert 2 * pad.size[2] <= NOTCH_DEPTH - 0.008  # pads low enough to enter the notch


@pytest.mark.parametrize("env_id,joint", [("SparkDrawer-v0", "joint_0"), ("SparkDoor-v0", "joint_1")])
def test_scripted_opener_opens_notched_fronts_with_an_inside_grip(env_id, joint):
    """No handle, a notch: the closed fingers enter it and open against its sides; a predicted axis 90
    degrees off still fails on the notched drawer."""
    from spark_bench.opening.episodes import ground_truth_joint, open_with_joint

    env = gym.make(env_id, asset=notched_cabinet(0), joint=joint, max_episode_steps=150)
    assert env.unwrapped.scene.grasp.inside_grip
    axis, pivot, joint_type = ground_truth_joint(env)
    result = open_with_joint(env, axis, pivot, joint_type, seed=0)
    assert result.success and result.fraction >= 0.75
    if joint_type == "prismatic":
        bad = open_with_joint(env, np.cross(axis, [0.0, 0.0, 1.0]), pivot, joint_type, seed=0)
        assert not bad.success and bad.max_fraction < 0.3


#: Synth StorageFurniture object 7 of ``generate_dataset(seed=0)`` (the benchmark's set): a double door
#: whose two edge lips (the handles) stand about 6 mm apart, half a default pad's thickness.
DOUBLE_DOOR_INDEX = 7


def double_door_cabinet(out):
    """Generate the synth double-door cabinet into ``out``; returns its folder."""
    from spark_bench.data.synth.generate import generate_object, object_seed

    return generate_object("StorageFurniture", object_seed(0, DOUBLE_DOOR_INDEX), out, "double_door")


@pytest.fixture(scope="module")
def double_door(tmp_path_factory):
    return double_door_cabinet(tmp_path_factory.mktemp("synth"))


def _door_joints(asset) -> list[str]:
    return [j.name for j in asset.movable_joints() if j.type == "revolute"]


def _handle_points(asset, joint: str) -> np.ndarray:
    links = [name for name in asset.part_of_joint(joint) if asset.links[name].label == "handle"]
    return np.asarray(asset.mesh(links=links).vertices)


def test_clipped_vertices_are_the_mesh_inside_the_box():
    import trimesh

    from spark_bench.opening.planning.pads import clipped_vertices

    cube = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    frame = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # box u = world y, v = z, w = x
    inside = clipped_vertices(cube, np.array([0.0, 0.0, 0.0]), frame, [0.1, -np.inf, 0.2], [0.3, np.inf, np.inf])
    np.testing.assert_allclose(inside.min(0), [0.1, -0.5, 0.2], atol=1e-9)
    np.testing.assert_allclose(inside.max(0), [0.3, 0.5, 0.5], atol=1e-9)
    assert len(clipped_vertices(cube, np.zeros(3), frame, [0.6, -1, -1], [0.9, 1, 1])) == 0


def test_double_door_lips_are_pinched_one_at_a_time(double_door):
    """The two leaves' edge lips stand closer than a default pad is thick: each door's grasp puts its
    pads into the gaps beside its own lip, thin enough that the other lip stays outside the fingers."""
    from spark_bench.data import load_object
    from spark_bench.opening.planning.gripper import GripperConfig

    asset = load_object(double_door)
    doors = _door_joints(asset)
    assert len(doors) == 2
    lips = [_handle_points(asset, joint) for joint in doors]
    closing = find_grasp(asset, doors[0]).closing
    across = [lip @ closing for lip in lips]
    gap = max(across[1].min() - across[0].max(), across[0].min() - across[1].max())
    assert 0.002 < gap < GripperConfig().pad_thickness  # the case: a default pad does not fit between the lips
    for joint, own, other in ((doors[0], lips[0], lips[1]), (doors[1], lips[1], lips[0])):
        grasp = find_grasp(asset, joint)
        assert grasp.source == "label" and grasp.opening is not None
        assert grasp.pad_thickness < gap and grasp.clearance >= 0.001
        inner, outer = grasp.opening, grasp.opening + grasp.pad_thickness  # each pad's faces from the TCP
        assert np.all(np.abs((own - grasp.point) @ grasp.closing) < inner - 0.0009)  # own lip between the pads
        assert np.all(np.abs((other - grasp.point) @ grasp.closing) > outer + 0.0009)  # the other lip outside
        env = gym.make("SparkDoor-v0", asset=str(double_door), joint=joint)
        pad = env.unwrapped.model.geom("spark_gripper_pad_left")
        assert 2 * pad.size[1] == pytest.approx(grasp.pad_thickness)
        env.close()


def test_scripted_opener_opens_each_leaf_of_a_double_door_alone(double_door):
    """The edge lips of a double door stand ~6 mm apart: with the default 12 mm pads closing from fully
    open, the fingers pinched both lips and neither door opened past 10 %. Each leaf must open while the
    other stays shut."""
    from spark_bench.opening.episodes import open_with_ground_truth

    folder = str(double_door)
    env = gym.make("SparkDoor-v0", asset=folder, max_episode_steps=150)
    doors = [j.name for j in env.unwrapped.scene.asset.movable_joints() if j.type == "revolute"]
    env.close()
    assert len(doors) == 2
    for joint, other in ((doors[0], doors[1]), (doors[1], doors[0])):
        env = gym.make("SparkDoor-v0", asset=folder, joint=joint, max_episode_steps=150)
        unwrapped = env.unwrapped
        assert unwrapped.scene.grasp.opening is not None  # the pads go beside the lip, not around both
        result = open_with_ground_truth(env, seed=0)
        assert result.success and result.fraction >= 0.75, (joint, result)
        other_q = unwrapped.data.qpos[unwrapped.model.jnt_qposadr[unwrapped.model.joint(other).id]]
        assert abs(other_q) < 0.02, (other, other_q)  # rad: the neighbour was not dragged along
        env.close()
