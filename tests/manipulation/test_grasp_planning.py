"""The grasp planner on handles real objects have: a small knob on a large front, a knob's boss on a wide
rosette, a lever on its own hinge, a spoked wheel held by a spoke, a shallow front with no handle (pinched by its edges), a front with
nothing to hold (declined, with a reason); the default joint; the fingers' closing speed. Then one real
PartNet-Mobility drawer whose round knob the fingers used to close through."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import trimesh
from helpers_boxes import box_mesh, box_part
from helpers_real import PARTNET_DEV

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.asset.model import Collision, Joint, Link, Visual
from spark_bench.envs.cabinet import METAL, procedural_cabinet
from spark_bench.manipulation.grasp import find_grasp, is_push_button


def _cylinder(center, radius, length) -> tuple[Visual, Collision]:
    """A cylinder along -X (out of a -X-facing front), its base at ``center``."""
    origin = np.eye(4)
    origin[:3, :3] = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])[:3, :3]
    origin[:3, 3] = np.asarray(center) + [-length / 2, 0, 0]
    mesh = trimesh.creation.cylinder(radius=radius, height=length, sections=24, transform=origin)
    return Visual(mesh=mesh, rgba=METAL), Collision(kind="cylinder", origin=origin, size=np.array([radius, length]))


def _drawer_with(parts) -> object:
    """The procedural cabinet with the drawer's bar handle replaced by ``parts`` (link frame: the front
    face at x = 0, facing -X)."""
    asset = procedural_cabinet(0)
    drawer = asset.links["link_0"]
    drawer.visuals, drawer.collisions = drawer.visuals[:5], drawer.collisions[:5]
    for visual, collision in parts:
        drawer.visuals.append(visual)
        drawer.collisions.append(collision)
    return asset


def _drawer_world(asset, local) -> np.ndarray:
    pose = asset.link_poses()["link_0"]
    return pose[:3, :3] @ np.asarray(local, float) + pose[:3, 3]


def test_a_small_knob_on_a_large_front_is_found():
    """A 16 mm knob is a few dozen of the part's 20 000 surface samples: the surface standing out of the
    front is sampled on its own, densely."""
    asset = _drawer_with([_cylinder((0.0, 0.12, 0.04), 0.008, 0.02)])
    grasp = find_grasp(asset, "joint_0")
    assert grasp.source == "geometry" and grasp.reason is None
    knob = _drawer_world(asset, (-0.01, 0.12, 0.04))
    lateral = (grasp.point - knob) - ((grasp.point - knob) @ grasp.outward) * grasp.outward
    assert np.linalg.norm(lateral) < 0.004


def test_a_boss_on_a_wide_rosette_is_pinched_down_to_the_rosette():
    """A 120 mm rosette is wider than the open fingers (82 mm with margins); its 24 mm boss is held, the
    fingertips stopping just above the rosette, not at the front."""
    from spark_bench.manipulation.handles import TIP_CLEARANCE

    asset = _drawer_with([_cylinder((0.0, 0.0, 0.0), 0.06, 0.012), _cylinder((-0.012, 0.0, 0.0), 0.012, 0.03)])
    grasp = find_grasp(asset, "joint_0")
    boss = _drawer_world(asset, (-0.027, 0.0, 0.0))
    lateral = (grasp.point - boss) - ((grasp.point - boss) @ grasp.outward) * grasp.outward
    assert grasp.source == "geometry" and np.linalg.norm(lateral) < 0.004
    tips = grasp.point - 0.012 * grasp.outward  # the fingertips, 12 mm ahead of the TCP
    rosette_top = _drawer_world(asset, (-0.012, 0.0, 0.0))
    height = (tips - rosette_top) @ grasp.outward
    assert TIP_CLEARANCE - 0.001 < height < TIP_CLEARANCE + 0.0045  # the level search steps 4 mm


def test_a_flat_front_is_declined_with_a_reason():
    asset = _drawer_with([])
    grasp = find_grasp(asset, "joint_0")
    assert grasp.source == "face" and not grasp.has_handle
    assert grasp.reason is not None and "no handle" in grasp.reason and "\n" not in grasp.reason


def test_a_shallow_front_with_no_handle_is_pinched_by_its_edges():
    """A 60 mm drawer front standing clear of the carcass around it: the fingers close across its height."""
    asset = procedural_cabinet(0)
    drawer = asset.links["link_0"]
    front = drawer.collisions[0]
    size = front.size.copy()
    size[2] = 0.06
    drawer.visuals, drawer.collisions = [], []
    visual, collision = box_part(size, front.origin[:3, 3], METAL)
    drawer.visuals.append(visual)
    drawer.collisions.append(collision)
    grasp = find_grasp(asset, "joint_0")
    assert grasp.source == "edge" and grasp.reason is None
    assert abs(grasp.closing[2]) > 0.99  # across the front's height
    center = _drawer_world(asset, front.origin[:3, 3])
    assert abs(grasp.point[2] - center[2]) < 0.004


def _door_with_lever(continuous: bool = True):
    """The procedural cabinet whose door has no bar but a 120 mm lever on a hinge of its own (its axis
    out of the door), hanging down from its pivot near the free edge."""
    asset = procedural_cabinet(0)
    door = asset.links["link_1"]
    door.visuals, door.collisions = door.visuals[:1], door.collisions[:1]
    panel = door.collisions[0]
    width = panel.size[1]
    lever = [box_part((0.015, 0.02, 0.12), (-0.02, 0.0, -0.05), METAL),
             box_part((0.02, 0.025, 0.025), (-0.01, 0.0, 0.0), METAL)]
    asset.links["lever"] = Link(name="lever", visuals=[v for v, _ in lever], collisions=[c for _, c in lever],
                                label="handle", semantic_joint="hinge")
    origin = np.eye(4)
    origin[:3, 3] = (-0.02, width - 0.08, 0.05)  # on the door's front, near its free edge
    kind = "continuous" if continuous else "revolute"
    asset.joints["lever_joint"] = Joint("lever_joint", kind, "link_1", "lever", origin=origin,
                                        axis=np.array([-1.0, 0.0, 0.0]), lower=0.0, upper=1.0 if not continuous else 0.0)
    return asset


def test_a_hinged_lever_is_the_doors_handle_held_near_its_pivot():
    """The lever is a part of its own (its own joint): it is the door's handle, and it is held near its
    pivot, where pulling does not turn it."""
    asset = _door_with_lever()
    grasp = find_grasp(asset, "joint_1")
    assert grasp.source == "label"
    pivot, axis = asset.joint_frames()["lever_joint"]
    r = grasp.point - pivot
    off_axis = np.linalg.norm(r - (r @ axis) * axis)
    assert off_axis < 0.03  # the lever's free end is 110 mm from the pivot


def test_default_joint_is_the_door_not_a_knob_or_a_lever():
    """With no joint named, the door task opens the door: not a continuous knob, nor a small part on a
    revolute joint listed before it."""
    from spark_bench.manipulation.scene import choose_joint

    asset = _door_with_lever(continuous=False)
    # put the lever's joint first, as PartNet-Mobility files often do
    asset.joints = {"lever_joint": asset.joints.pop("lever_joint"), **asset.joints}
    assert choose_joint(asset, "revolute", None).name == "joint_1"
    asset.joints["lever_joint"].type = "continuous"
    assert choose_joint(asset, "revolute", None).name == "joint_1"


def test_fingers_close_at_a_bounded_speed():
    """Slamming shut at 20 m/s, a 12 mm pad crossed 18 mm in one 4 ms step and landed inside a real
    drawer's knob; the finger damping caps the closing speed near grip_force / damping."""
    from spark_bench.manipulation.gripper import finger_target
    from spark_bench.mujoco_gl import mujoco_module

    mujoco = mujoco_module()
    env = gym.make("SparkDrawer-v0", asset="procedural:0")
    unwrapped = env.unwrapped
    config = unwrapped.scene.gripper.config
    env.reset(seed=0)
    model, data = unwrapped.model, unwrapped.data
    dofs = [model.jnt_dofadr[model.joint(n).id] for n in unwrapped.scene.gripper.finger_joints]
    data.ctrl[unwrapped._act_fingers] = finger_target(config, 1.0)  # close, in the air
    top = 0.0
    for _ in range(60):  # physics steps (4 ms)
        mujoco.mj_step(model, data)
        top = max(top, float(np.max(np.abs(data.qvel[dofs]))))
    cap = config.grip_force / config.finger_damping
    assert 0.6 * cap < top < 1.1 * cap
    assert top * model.opt.timestep < 0.01  # under 10 mm per step (18 mm at the old 2 N s/m)
    env.close()


@pytest.mark.slow
def test_a_real_drawer_with_a_round_knob_opens():
    """PartNet-Mobility table 24644: a 25 mm mushroom knob (70 mm in its file's units). The fingers closed through its hull and the
    drawer stayed shut; it must open in both episodes within the registered 100 steps."""
    from spark_bench.rl.rollout import rollout

    folder = PARTNET_DEV / "24644"
    if not folder.is_dir():
        pytest.skip(f"partnet_dev objects not available ({folder} is absent)")
    stats = rollout("SparkDrawer-v0", asset=str(folder), policy="scripted", episodes=2)
    assert stats.success_rate == 1.0 and stats.reason is None


def test_a_joint_that_opens_into_the_object_is_declined():
    """A drawer whose axis is reversed (annotation errors do this) 'opens' into the cabinet: its grasp
    would be inside the carcass, and the planner says the way in is blocked."""
    asset = procedural_cabinet(0)
    asset.joints["joint_0"].axis = -np.asarray(asset.joints["joint_0"].axis)
    grasp = find_grasp(asset, "joint_0")
    assert grasp.reason is not None and "opens into the object" in grasp.reason
    assert find_grasp(procedural_cabinet(0), "joint_0").reason is None


def test_a_drawer_behind_a_closed_door_is_declined_for_the_door_not_its_axis():
    """A tray behind an oven's closed door: the door stands across the whole way in, and the reason names
    the door to open first, not a reversed axis (the drawer's own axis is right)."""
    asset = procedural_cabinet(0)
    asset.joints["joint_1"].origin[:3, 3] += [-0.06, 0.0, 0.26]  # the door moved up, in front of the drawer
    reason = find_grasp(asset, "joint_0").reason
    assert reason is not None and "behind the rotation door (joint_1)" in reason and "reversed" not in reason


def test_the_workspace_holds_a_wide_swinging_door():
    """A door opening 170 degrees (a safe's) stands a door's width in front of the cabinet half-way, out of
    the box of its rest and open positions: the gripper's workspace must hold its whole sweep, or the hand
    stops at the workspace's wall with the door a third open."""
    from spark_bench.manipulation.scene import WORKSPACE_MARGIN, workspace_box

    asset = procedural_cabinet(0)
    door = asset.joints["joint_1"]
    door.upper = np.radians(170.0)
    box = workspace_box(asset, joint=door)
    links = asset.part_of_joint("joint_1")
    # between two of the sampled positions (21 degrees apart) the arc bulges past their chord by at most
    # r (1 - cos 10.6 deg), under 2 cm for this door: well inside the margin the hand has
    inner = box + np.array([[WORKSPACE_MARGIN - 0.02], [-WORKSPACE_MARGIN + 0.02]])
    for angle in np.linspace(0.0, door.upper, 18):
        points = asset.mesh({"joint_1": angle}, links=links).vertices
        assert np.all(points >= inner[0]) and np.all(points <= inner[1])
    # the rest and open boxes alone miss it: at 90 degrees the door reaches further out than either
    rest, opened = asset.bounds(), asset.bounds(asset.open_configuration())
    half = asset.mesh({"joint_1": np.pi / 2}, links=links).vertices
    assert half.min(0)[0] < min(rest[0][0], opened[0][0]) - 0.1


def test_a_push_button_is_declined_as_one():
    """A small part on a prismatic joint travelling a few millimetres (a microwave's or a safe's keypad
    button) is pressed, not pulled: the planner says so instead of looking for its handle (or calling its
    axis reversed). A large part lifted as little (a coffee machine's drip-tray grate) is no button."""
    asset = procedural_cabinet(0)
    lo, hi = asset.bounds()
    front = lo[0]
    asset.links["button"] = Link("button", visuals=[Visual(mesh=box_mesh(
        (0.01, 0.03, 0.03), (front - 0.005, 0.5 * (lo[1] + hi[1]), hi[2] - 0.05)))])
    asset.joints["joint_button"] = Joint("joint_button", "prismatic", "base", "button",
                                         axis=np.array([1.0, 0.0, 0.0]), lower=0.0, upper=0.004)
    assert is_push_button(asset, "joint_button")
    grasp = find_grasp(asset, "joint_button")
    assert grasp.declined == "button"
    assert grasp.reason is not None and "push button (4.0 mm" in grasp.reason and "\n" not in grasp.reason
    drawer = asset.joints["joint_0"]
    drawer.lower, drawer.upper = 0.0, 0.004  # the drawer moving 4 mm is not pressed: it is planned as a drawer
    assert not is_push_button(asset, "joint_0")
    assert find_grasp(asset, "joint_0").declined != "button"


def _cone(center, radius, height) -> tuple[Visual, Collision]:
    """A cone along -X (out of a -X-facing front), its base (``radius``) at ``center``."""
    transform = np.eye(4)
    transform[:3, :3] = trimesh.transformations.rotation_matrix(-np.pi / 2, [0, 1, 0])[:3, :3]
    transform[:3, 3] = center
    mesh = trimesh.creation.cone(radius=radius, height=height, sections=32, transform=transform)
    return Visual(mesh=mesh, rgba=METAL), Collision(kind="mesh", mesh=mesh)


def test_a_dome_knob_is_pinched_on_its_steep_cap_not_its_sloping_foot():
    """A 140 mm knob shaped like a dome (a cone, 30 mm high: its sides slope 2.3 sideways per unit of
    height) with a 36 mm cylindrical cap: the pads closing on the foot's slope slide off when pulled, so
    the fingertips reach only down to the cap, whose sides hold them (the level search steps 3 mm)."""
    from spark_bench.manipulation.handles import MAX_WALL_SLOPE

    asset = _drawer_with([_cone((0.0, 0.0, 0.0), 0.07, 0.03), _cylinder((-0.022, 0.0, 0.0), 0.018, 0.015)])
    grasp = find_grasp(asset, "joint_0")
    assert grasp.source == "geometry" and grasp.reason is None
    tips = grasp.point - 0.012 * grasp.outward
    height = (tips - _drawer_world(asset, (0.0, 0.0, 0.0))) @ grasp.outward
    # where the sides slope by at most MAX_WALL_SLOPE over the 6 mm band above the tips: the cap, from 22 mm
    # up (the cone is 18 mm across there); the foot's part narrow enough to pinch starts at 12 mm (the raised
    # piece's level search gives 16 mm: the tips there, on the slope, is what this test refuses)
    assert MAX_WALL_SLOPE < 70 / 30
    assert 0.019 < height < 0.026


def test_a_pad_landing_on_the_object_is_measured():
    """:func:`pad_landing`: an open pad coming down on a plate beside the grasp stands on it (the hand
    would stop short); over a bar that fits between the pads, nothing is in their way."""
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.pads import LANDING_MARGIN, pad_landing

    gripper = GripperConfig()
    front = box_mesh([0.02, 0.6, 0.6], [0.01, 0, 0])
    bar = box_mesh([0.03, 0.02, 0.2], [-0.015, 0, 0])
    plate = box_mesh([0.02, 0.1, 0.1], [-0.01, 0.05, 0])
    out, closing, along = np.array([-1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
    tcp = np.array([-0.012 - 0.002, 0.0, 0.0])  # fingertips 2 mm above the front (x = 0)
    clear = pad_landing(trimesh.util.concatenate([front, bar]), tcp, out, closing, along, 0.045, 0.012, gripper)
    assert clear == 0.0
    # the same grasp at the plate's edge: the pad at +y comes down on the plate's face, 20 mm proud
    landed = pad_landing(trimesh.util.concatenate([front, plate]), tcp, out, closing, along, 0.045, 0.012, gripper)
    assert landed == pytest.approx(0.02 - 0.002, abs=1e-6) and landed > LANDING_MARGIN


def test_a_knob_whose_simulated_shape_is_a_cone_is_not_pinched():
    """The dome knob with its cylindrical cap, its collision shape the convex hull of both (a cone: the cap's
    wall gone): the pads would slide off it, so the planner passes it over and declines the part as
    ``unholdable`` (``auto`` takes the cup); with the cap's own shape the sides hold."""
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.handles import sides_hold
    from spark_bench.manipulation.suction import choose_end_effector

    asset = _drawer_with([_cone((0.0, 0.0, 0.0), 0.07, 0.03), _cylinder((-0.022, 0.0, 0.0), 0.018, 0.015)])
    knob = trimesh.util.concatenate([visual.mesh for visual in asset.links["link_0"].visuals[5:]])
    pose = asset.link_poses()["link_0"]
    hull, pieces = knob.convex_hull.copy(), knob.copy()
    hull.apply_transform(pose)
    pieces.apply_transform(pose)
    planned = find_grasp(asset, "joint_0")
    tips = float(planned.point @ planned.outward) - GripperConfig().tip_beyond_tcp
    args = (planned.point, planned.outward, planned.closing, planned.long_axis, tips, GripperConfig())
    assert sides_hold(pieces, *args) and not sides_hold(hull, *args)
    grasp = find_grasp(asset, "joint_0", collision=hull)
    assert grasp.declined == "unholdable" and not grasp.has_handle
    assert "collision shape" in grasp.reason and choose_end_effector("auto", grasp.declined) == "suction"
    assert find_grasp(asset, "joint_0", collision=pieces).source == "geometry"


def test_approach_blocked_finds_what_stands_in_the_way_in():
    """:func:`approach_blocked`: a plate in front of the grasp is hit by every ray (``through``) at its
    distance; a post beside the grasp, in one open pad's way, by the pad's ray only; far triangles and a
    plate beyond the clear distance are in nobody's way (the rays' bounding box must not drop a hit)."""
    from types import SimpleNamespace

    from spark_bench.manipulation.grasp_target import GraspTarget
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.pads import approach_blocked

    gripper = GripperConfig()
    near = gripper.finger_length - gripper.tip_beyond_tcp

    def asset(**meshes):
        links = {name: SimpleNamespace(has_geometry=True) for name in meshes}
        return SimpleNamespace(links=links, mesh=lambda links: meshes[links[0]])

    grasp = GraspTarget(point=np.zeros(3), outward=np.array([-1.0, 0, 0]), long_axis=np.array([0, 0, 1.0]),
                        has_handle=True, source="geometry")  # fingers close along y
    far = box_mesh([0.1, 0.1, 0.1], [-0.2, 2.0, 0])
    plate = box_mesh([0.01, 0.4, 0.4], [-(near + 0.1), 0, 0])
    name, distance, through = approach_blocked(asset(far=far, plate=plate), grasp, gripper, 0.5)
    assert name == "plate" and through and distance == pytest.approx(near + 0.095, abs=1e-9)
    post = box_mesh([0.01, 0.01, 0.01], [-(near + 0.05), -gripper.max_opening, 0])  # on one pad's line only
    name, distance, through = approach_blocked(asset(far=far, post=post), grasp, gripper, 0.5)
    assert name == "post" and not through and distance == pytest.approx(near + 0.045, abs=1e-9)
    beyond = box_mesh([0.01, 0.4, 0.4], [-(near + 0.7), 0, 0])
    assert approach_blocked(asset(far=far, beyond=beyond), grasp, gripper, 0.5) is None


def _bare_door_with(name: str, parts, at: np.ndarray, fin=None):
    """The procedural cabinet whose door has no bar but ``parts`` (``(Visual, Collision)`` pairs) as one
    link ``name`` on a continuous hinge of its own, its axis out of the door, at ``at`` in the door's
    frame (a safe's dial or wheel); ``fin``: a further piece of the door itself."""
    asset = procedural_cabinet(0)
    door = asset.links["link_1"]
    door.visuals, door.collisions = door.visuals[:1], door.collisions[:1]
    if fin is not None:
        door.visuals.append(fin[0])
        door.collisions.append(fin[1])
    asset.links[name] = Link(name=name, visuals=[v for v, _ in parts], collisions=[c for _, c in parts],
                             label="knob", semantic_joint="hinge")
    origin = np.eye(4)
    origin[:3, 3] = at
    asset.joints[f"{name}_joint"] = Joint(f"{name}_joint", "continuous", "link_1", name, origin=origin,
                                          axis=np.array([-1.0, 0.0, 0.0]), lower=0.0, upper=0.0)
    return asset


def _door_with_hinged_knob():
    """The procedural cabinet whose door has no bar but a 20 mm knob on a hinge of its own (a safe's dial,
    its axis out of the door) near the free edge, and, 30 mm towards the hinge, a thin fin of the door's own
    (a dial's index mark) standing in the open fingers' sweep."""
    width = procedural_cabinet(0).links["link_1"].collisions[0].size[1]
    knob_at = np.array([-0.02, width - 0.08, 0.05])  # on the door's front (x = -0.02 in the door's frame)
    fin = box_part((0.024, 0.004, 0.04), knob_at + (-0.012, -0.03, 0.0), METAL)
    return _bare_door_with("knob", [_cylinder((0.0, 0.0, 0.0), 0.01, 0.03)], knob_at, fin), knob_at


def test_a_knob_on_its_own_hinge_is_the_handle_not_an_obstacle_beside_the_door():
    """What moves with the door (a knob on a hinge of its own, held at rest while the door opens) is the
    handle's side when the pads are planned: it used to count as another part's obstacle, so the pads were
    thinned and shifted into the 'gap' beside the door's own fin and closed on it, or on nothing (a real
    safe, 102381: the fingers closed beside its dial)."""
    asset, knob_at = _door_with_hinged_knob()
    grasp = find_grasp(asset, "joint_1")
    assert grasp.reason is None and grasp.source == "geometry"
    knob = asset.link_poses()["link_1"] @ np.append(knob_at, 1.0)
    off = grasp.point - knob[:3]
    assert np.linalg.norm(off - (off @ grasp.outward) * grasp.outward) < 0.004  # on the knob's axis
    assert grasp.opening is None and grasp.pad_thickness is None  # the open pads, nothing in their way


def test_a_part_its_collision_shapes_jam_is_declined_as_jammed():
    """A drawer whose front runs into a collision shape 10 mm out (a stop fixed to the body that the visual
    meshes do not show: what a convex hull sunk into a real lid's rim does) opens for no one: the scene
    drives the joint directly when it is built and declines the part with that reason. The plain cabinet's
    drawer reaches the success fraction so, and keeps no reason. (The stop is a link of its own: MuJoCo
    leaves out contacts between a body and its parent.)"""
    from spark_bench.manipulation.drive_check import JAM_FRACTION
    from spark_bench.manipulation.task import build_scene

    plain = build_scene(procedural_cabinet(0), "prismatic", "joint_0", visuals=False)
    assert plain.grasp.reason is None and plain.free_fraction >= JAM_FRACTION
    asset = procedural_cabinet(0)
    front = _drawer_world(asset, (0.0, -0.25, -0.1))  # the drawer's front face, near its lower left corner
    base = asset.link_poses()["base"]
    stop = np.eye(4)
    stop[:3, 3] = np.linalg.inv(base)[:3] @ np.append(front + (-0.015, 0.0, 0.0), 1.0)
    asset.links["stop"] = Link(name="stop", visuals=[], label="stop",
                               collisions=[Collision(kind="box", origin=np.eye(4), size=np.array([0.01, 0.04, 0.02]))])
    asset.joints["stop_joint"] = Joint("stop_joint", "fixed", "base", "stop", origin=stop)
    scene = build_scene(asset, "prismatic", "joint_0", visuals=False)
    assert scene.free_fraction < 0.1  # 10 mm of a 323 mm travel, and the front's give
    assert scene.grasp.reason is not None and "jammed by its collision shapes" in scene.grasp.reason
    assert find_grasp(asset, "joint_0").reason is None  # the planner's geometry sees nothing wrong


def test_a_part_too_heavy_for_the_gripper_is_told_from_a_jammed_one():
    """A drawer whose joint friction (150 N) exceeds the hand's largest pull (104 N) but not four times it
    stays shut under that pull and opens under the harder one: the reason says it is too heavy for the
    gripper, not jammed."""
    from spark_bench.manipulation.drive_check import JAM_FRACTION, free_motion, stuck_reason
    from spark_bench.manipulation.gripper import largest_pull
    from spark_bench.manipulation.task import build_scene

    scene = build_scene(procedural_cabinet(0), "prismatic", "joint_0", visuals=False)
    pull = largest_pull(scene.gripper.config)
    assert 100.0 < pull < 110.0  # sqrt(3) x 3000 N/m x 0.02 m
    dof = scene.model.jnt_dofadr[scene.model.joint("joint_0").id]
    scene.model.dof_frictionloss[dof] = 1.5 * pull
    assert free_motion(scene, pull) < 0.05
    reason = stuck_reason(scene)
    assert reason is not None and "too heavy for the gripper" in reason
    assert scene.free_fraction < JAM_FRACTION


def test_the_drive_check_turns_a_door_with_the_pull_at_its_grasp_lever_arm():
    """A door is driven with the hand's largest pull at the grasp point's distance from the hinge: joint
    friction 0.8 times that torque lets it open, 1.3 times holds it (a unit lever, or none, would tell
    these apart wrongly: the cabinet's grasp is well under 1 m from the hinge), and a held part stops the
    drive early (it stands still) whatever the step limit."""
    from spark_bench.manipulation.drive_check import JAM_FRACTION, free_motion
    from spark_bench.manipulation.gripper import largest_pull
    from spark_bench.manipulation.task import build_scene

    scene = build_scene(procedural_cabinet(0), "revolute", "joint_1", visuals=False)
    pivot, axis = scene.asset.joint_frames()["joint_1"]
    r = scene.grasp.point - pivot
    lever = float(np.linalg.norm(r - (r @ axis) * axis))
    assert 0.1 < lever < 0.8
    pull = largest_pull(scene.gripper.config)
    dof = scene.model.jnt_dofadr[scene.model.joint("joint_1").id]
    scene.model.dof_frictionloss[dof] = 0.8 * pull * lever
    assert free_motion(scene, pull) >= JAM_FRACTION
    scene.model.dof_frictionloss[dof] = 1.3 * pull * lever
    held = free_motion(scene, pull)
    assert held < 0.05
    assert free_motion(scene, pull, steps=10_000) == pytest.approx(held, abs=1e-3)  # stopped once still


def _door_with_wheel():
    """The procedural cabinet whose door has no bar but a spoked wheel on a hinge of its own (a safe's
    handle, its axis out of the door) in the door's middle: a 90 mm hub standing 50 mm out, four 25 mm
    spokes 40 mm out reaching 130 mm from the axis (102318's proportions)."""
    center = np.array([-0.02, 0.5 * procedural_cabinet(0).links["link_1"].collisions[0].size[1], 0.0])
    parts = [_cylinder((0.0, 0.0, 0.0), 0.045, 0.05)]
    for sign in (-1.0, 1.0):
        parts.append(box_part((0.02, 0.025, 0.09), (-0.04, 0.0, sign * 0.085), METAL))
        parts.append(box_part((0.02, 0.09, 0.025), (-0.04, sign * 0.085, 0.0), METAL))
    return _bare_door_with("wheel", parts, center), center


def test_a_wheel_is_held_by_a_spoke_clear_of_its_hub():
    """A spoked wheel is wider than the open fingers: its pinchable pieces are searched from its axis out.
    The first one, beside the hub, would land an open pad on the hub (the hand stops on it, short of the
    spoke: a real safe, 102318, whose planner then took a wedge-shaped pull the pads slid off). Further
    pieces of the wheel are tried: the grasp is where a spoke leaves the hub, its open pads clear."""
    from spark_bench.envs import make_env
    from spark_bench.manipulation.grasp import part_front
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.handle_search import handle_searches, on_handle
    from spark_bench.manipulation.handles import candidates
    from spark_bench.manipulation.pinch import pinch_on
    from spark_bench.manipulation.rest_meshes import RestMeshes
    from spark_bench.opening.episodes import open_with_ground_truth

    asset, center = _door_with_wheel()
    grasp = find_grasp(asset, "joint_1")
    assert grasp.reason is None and grasp.source == "geometry" and not grasp.landing
    axis_at = asset.link_poses()["link_1"] @ np.append(center, 1.0)
    off = grasp.point - axis_at[:3]
    radial = np.linalg.norm(off - (off @ grasp.outward) * grasp.outward)
    assert 0.03 < radial < 0.13  # off the hub's middle (90 mm: no pinch there), where a spoke leaves it
    # the wheel's first piece (the nearest its axis) is the landing one the alternates get around
    rest, gripper = RestMeshes(asset), GripperConfig()
    front = part_front(rest, "joint_1", 0)
    source, pts, groups = list(handle_searches(rest, "joint_1", front, 0))[-1]
    fitting, _ = candidates(pts, groups, front, gripper, lambda p: on_handle(p, front.basis, front.origin, front.axis))
    first = [c for c in fitting if not c.alternate]
    assert first and all(pinch_on(rest, "joint_1", front, c, source, gripper).landing for c in first)
    assert any(c.alternate for c in fitting)
    # and the scripted opener opens the door by that spoke (the wheel held at rest on its hinge)
    env = make_env("SparkDoor-v0", asset=asset, joint="joint_1", max_episode_steps=100)
    assert np.allclose(env.unwrapped.scene.grasp.point, grasp.point)
    assert open_with_ground_truth(env, seed=0, max_steps=100).success
    env.close()


def _rib(radius, proud, length) -> tuple[Visual, Collision]:
    """A low rounded rib along Y on a -X-facing front (x = 0): the part of a cylinder of ``radius`` standing
    ``proud`` out of the front, ``length`` long."""
    transform = np.eye(4)
    transform[:3, :3] = trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])[:3, :3]
    transform[:3, 3] = [radius - proud, 0.0, 0.0]
    cylinder = trimesh.creation.cylinder(radius=radius, height=length, sections=64, transform=transform)
    mesh = trimesh.intersections.slice_mesh_plane(cylinder, [-1.0, 0, 0], [0, 0, 0], cap=True)
    return Visual(mesh=mesh, rgba=METAL), Collision(kind="mesh", mesh=mesh)


def test_a_low_rounded_rib_is_not_pinched_but_a_bar_is():
    """A decorative rib 45 mm wide standing 13 mm out of the front (a cylinder's 26 mm-radius cap): only its
    top 5 mm stands out by the handle search's 8 mm, and that piece fits the fingers; but its flanks, which
    the pads grip from the front up, rise 1.1-1.8 sideways per unit of height at every level (against
    MAX_WALL_SLOPE), and the pads slide off them. The planner passes it over, on its visual surface and on
    its collision shape alike, and declines the part as ``unholdable`` (``auto`` takes the cup). A bar
    handle of the same width, 25 mm out with straight sides, is still pinched."""
    from spark_bench.manipulation.handles import MAX_WALL_SLOPE
    from spark_bench.manipulation.suction import choose_end_effector

    radius, proud = 0.026, 0.013
    assert 2 * np.sqrt(radius ** 2 - (radius - proud) ** 2) == pytest.approx(0.045, abs=0.001)
    assert MAX_WALL_SLOPE < 1.0
    rib = _rib(radius, proud, 0.16)
    asset = _drawer_with([rib])
    grasp = find_grasp(asset, "joint_0")
    assert grasp.declined == "unholdable" and not grasp.has_handle
    assert "slope too gently" in grasp.reason and choose_end_effector("auto", grasp.declined) == "suction"
    shape = rib[1].mesh.copy()
    shape.apply_transform(asset.link_poses()["link_0"])
    assert find_grasp(asset, "joint_0", collision=shape).declined == "unholdable"

    bar = _drawer_with([box_part((0.025, 0.16, 0.02), (-0.0125, 0.0, 0.0), METAL)])
    grasp = find_grasp(bar, "joint_0")
    assert grasp.source == "geometry" and grasp.reason is None and grasp.declined is None


def _front_of_mesh(mesh):
    from spark_bench.manipulation.features import Front, perpendicular_basis

    outward = np.array([0.0, 0.0, 1.0])
    points = np.asarray(mesh.sample(20000, seed=0))
    return Front(part=mesh, points=points, outward=outward, basis=perpendicular_basis(outward),
                 face=float((points @ outward).max()), origin=np.array([0.0, 0.0, -0.1]),
                 axis=np.array([0.0, 1.0, 0.0]), rotational=True)


def test_an_edge_pinch_needs_sides_the_pads_hold():
    """The crown of a rounded chest lid (0.12 m radius) is a strip narrower than the open fingers at its
    face level, so the edge pinch found it; its sides slope away and the pads slid off (partnet_dev box
    100247 at its real size). A narrow front with square edges keeps its edge pinch."""
    from spark_bench.manipulation.grasp import edge_sides_hold
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.handles import edge_pinch

    gripper = GripperConfig()
    square = _front_of_mesh(trimesh.creation.box(extents=(0.04, 0.2, 0.04)))
    edge = edge_pinch(square, None, gripper)
    assert edge is not None and edge_sides_hold(square, edge, gripper)
    crown = trimesh.creation.cylinder(radius=0.12, height=0.3, sections=128,
                                      transform=trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    rounded = _front_of_mesh(crown)
    edge = edge_pinch(rounded, None, gripper)
    assert edge is not None and not edge_sides_hold(rounded, edge, gripper)


def test_a_feature_beside_an_elongated_handles_end_is_not_under_the_pads():
    """A safe's lever (60 x 10 mm, 12 mm proud) with a keypad standing 11 mm out 10 mm past its tip
    (partnet_dev 102278 at its real size): the pads, pinching across the lever, come down beside it on the
    door (level 0), not on the keypad; a round knob of the same height still sees the surface all around."""
    from spark_bench.manipulation.handle_search import feature_base

    rng = np.random.default_rng(0)
    lever = np.column_stack([rng.uniform(0, 0.06, 400), rng.uniform(-0.005, 0.005, 400), np.full(400, 0.012)])
    door = np.column_stack([rng.uniform(-0.05, 0.2, 4000), rng.uniform(-0.05, 0.05, 4000), np.zeros(4000)])
    keypad = np.column_stack([rng.uniform(0.07, 0.12, 400), rng.uniform(-0.03, 0.03, 400), np.full(400, 0.011)])
    front = _front_of_mesh(trimesh.creation.box(extents=(0.2, 0.2, 0.02)))
    assert feature_base(np.vstack([door, keypad]), lever, front) == pytest.approx(0.0, abs=1e-9)
    knob = lever[np.abs(lever[:, 0] - 0.055) < 0.005]  # a 10 mm knob at the lever's tip: the keypad is beside it
    assert feature_base(np.vstack([door, keypad]), knob, front) == pytest.approx(0.011, abs=1e-9)


def test_the_pads_slide_to_a_wheels_hub_not_its_spoke_roots():
    """On a wheel hinged to a door the pads, planned on the hub, overlap the roots of two spokes; they slide
    along the handle to where the piece is narrowest (partnet_dev 102309 at its real size)."""
    from types import SimpleNamespace

    from spark_bench.manipulation.grasp_target import GraspTarget
    from spark_bench.manipulation.gripper import GripperConfig
    from spark_bench.manipulation.pinch import clear_sweep

    gripper = GripperConfig()
    rng = np.random.default_rng(0)
    hub = np.column_stack([rng.uniform(-0.013, 0.013, 2000), rng.uniform(-0.013, 0.013, 2000), np.full(2000, 0.02)])
    # two spokes rising from the hub's upper half, spreading sideways: 67 mm across 12 mm above the centre
    t = rng.uniform(0, 1, 2000)
    spokes = np.column_stack([np.sign(t - 0.5) * (0.013 + 0.03 * np.abs(2 * t - 1)), 0.004 + 0.02 * np.abs(2 * t - 1),
                              np.full(2000, 0.02)])
    piece = SimpleNamespace(points=np.vstack([hub, spokes]))
    grasp = GraspTarget(point=np.zeros(3), outward=np.array([0.0, 0.0, 1.0]), long_axis=np.array([0.0, 1.0, 0.0]),
                        has_handle=True, source="geometry")  # closing along -x: across the handle
    shift = clear_sweep(piece, grasp, gripper)
    assert shift < -0.004  # away from the spokes, towards the hub's free side
    assert abs(shift) <= 0.5 * gripper.pad_height
    # a plain bar, as wide everywhere: the pads stay where planned
    bar = SimpleNamespace(points=hub * [1, 3, 1])
    assert clear_sweep(bar, grasp, gripper) == 0.0
