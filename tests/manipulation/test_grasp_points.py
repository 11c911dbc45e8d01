"""Where the grasp planner (:func:`spark_bench.manipulation.grasp.find_grasp`) takes the procedural cabinet's
handles, PartNet-Mobility's annotated handles, one of several labelled knobs, a finger-pull notch (from
inside), and each of a double door's two lips standing closer than a pad is thick; the pads' box clip."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from helpers_open import NOTCH_DEPTH, NOTCH_WIDTH, double_door_cabinet, notched_cabinet

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.manipulation.grasp import find_grasp


@pytest.fixture(scope="module")
def double_door(tmp_path_factory):
    return double_door_cabinet(tmp_path_factory.mktemp("synth"))


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


def _pads_cover(grasp, center, thickness, outward):
    """The grasp is over the bar (in the front plane) and the pads, from the fingertips back along their
    length, cover the bar's whole depth."""
    from spark_bench.manipulation.gripper import GripperConfig

    config = GripperConfig()
    lateral = (grasp.point - center) - ((grasp.point - center) @ outward) * outward
    tips = (grasp.point - center) @ outward - config.tip_beyond_tcp  # the fingertips' level, from the bar's
    return (np.linalg.norm(lateral) < 0.005 and tips < -thickness / 2
            and tips + config.finger_length > thickness / 2)


def test_grasp_point_is_the_handle_bar_on_the_procedural_cabinet():
    """The pads are centred on the bar and reach down past it towards the front (a bar or a knob's head is
    held from behind, not pinched at its rounded front), fingertips clear of the front."""
    from spark_bench.manipulation.handles import TIP_CLEARANCE

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


def _door_joints(asset) -> list[str]:
    return [j.name for j in asset.movable_joints() if j.type == "revolute"]


def _handle_points(asset, joint: str) -> np.ndarray:
    links = [name for name in asset.part_of_joint(joint) if asset.links[name].label == "handle"]
    return np.asarray(asset.mesh(links=links).vertices)


def test_clipped_vertices_are_the_mesh_inside_the_box():
    import trimesh

    from spark_bench.manipulation.pads import clipped_vertices

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
    from spark_bench.manipulation.gripper import GripperConfig

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
