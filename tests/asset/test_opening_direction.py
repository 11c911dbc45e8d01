"""Which way a part opens, read from the asset (issue 43, item 5; :mod:`spark_bench.asset.opening_direction`).

The same cabinet (the environments' procedural cabinet: a drawer sliding out along -X, a door hinged about +Z) is
written here as MJCF three ways, as robot-learning MJCF writes its parts: as PartNet-Mobility would (ranges from 0,
drawn closed at the lower limit), as Meta-World writes its drawer (the axis the other way, ``range="-t 0"``: drawn
closed at the upper limit) and as LIBERO writes its cabinets (``range="-t 0.01"``: drawn closed inside the range).
All three read as one cabinet whose joints open toward their upper limits, and ``rollout`` opens the Meta-World one
(today's rollout declined it: "the joint opens into the object"). A URDF keeps the convention as it stands, and
spark-bench's own USD export (bodies drawn at rest) reads back as written.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.asset.opening_direction import orient_joints
from spark_bench.data.readers import load_object
from spark_bench.envs.cabinet import procedural_cabinet

#: How each variant writes the drawer (joint_0) and the door (joint_1): axis sign and range.
VARIANTS = {
    "partnet": {"joint_0": (1.0, "0 {t}"), "joint_1": (1.0, "0 {d}")},
    "metaworld": {"joint_0": (-1.0, "-{t} 0"), "joint_1": (-1.0, "-{d} 0")},
    "libero": {"joint_0": (-1.0, "-{t} 0.01"), "joint_1": (1.0, "0 {d}")},
}


def cabinet_mjcf(cabinet: ArticulatedAsset, variant: str) -> str:
    """The cabinet as an MJCF model: a body per link at its joint's origin, its box visuals as box geoms, each
    joint written as ``variant`` says (its axis times the sign, its range)."""
    travel, door = cabinet.joints["joint_0"].upper, cabinet.joints["joint_1"].upper

    def geoms(link) -> str:
        out = []
        for visual in cabinet.links[link].visuals:
            low, high = visual.mesh.bounds
            rgba = " ".join(f"{c:g}" for c in visual.rgba)
            out.append(f'<geom type="box" size="{" ".join(f"{v:.6f}" for v in (high - low) / 2)}" '
                       f'pos="{" ".join(f"{v:.6f}" for v in (high + low) / 2)}" rgba="{rgba}"/>')
        return "".join(out)

    bodies = []
    for name, joint in cabinet.joints.items():
        sign, written = VARIANTS[variant][name]
        kind = "slide" if joint.type == "prismatic" else "hinge"
        axis = " ".join(f"{sign * v:g}" for v in joint.axis)
        pos = " ".join(f"{v:.6f}" for v in joint.origin[:3, 3])
        bodies.append(f'<body name="{joint.child}" pos="{pos}"><joint name="{name}" type="{kind}" axis="{axis}" '
                      f'range="{written.format(t=f"{travel:.6f}", d=f"{door:.6f}")}" damping="1"/>'
                      f'{geoms(joint.child)}</body>')
    return (f'<mujoco model="cabinet"><compiler angle="radian"/><worldbody><body name="carcass">'
            f'{geoms("base")}{"".join(bodies)}</body></worldbody></mujoco>')


@pytest.fixture
def cabinet():
    return procedural_cabinet(0)


def read_variant(cabinet, variant, tmp_path):
    path = tmp_path / f"{variant}.xml"
    path.write_text(cabinet_mjcf(cabinet, variant))
    return load_object(path)


def assert_same_motion(asset: ArticulatedAsset, cabinet: ArticulatedAsset, rest_offset: float = 0.0) -> None:
    """``asset``'s joints open as ``cabinet``'s: the same world direction, the same open pose of each part."""
    for name in ("joint_0", "joint_1"):
        ours, theirs = asset.joints[name], cabinet.joints[name]
        assert ours.upper == pytest.approx(theirs.upper, abs=1e-5)
        assert asset.joint_frames()[name][1] == pytest.approx(cabinet.joint_frames()[name][1], abs=1e-6)
        opened = asset.mesh({name: ours.upper}, links=[ours.child]).bounds
        assert opened == pytest.approx(cabinet.mesh({name: theirs.upper}, links=[theirs.child]).bounds, abs=1e-5)
    assert asset.joints["joint_0"].lower == pytest.approx(-rest_offset, abs=1e-6)


def test_a_part_drawn_at_its_lower_limit_reads_as_written(cabinet, tmp_path):
    asset = read_variant(cabinet, "partnet", tmp_path)
    assert {o["rule"] for o in asset.meta["opening_direction"]} == {"rest at lower"}
    assert_same_motion(asset, cabinet)


def test_metaworld_drawer_drawn_at_its_upper_limit_opens_toward_the_lower(cabinet, tmp_path):
    asset = read_variant(cabinet, "metaworld", tmp_path)
    found = {o["joint"]: o for o in asset.meta["opening_direction"]}
    assert found["joint_0"]["opens_toward"] == "lower" and found["joint_0"]["rule"] == "rest at upper"
    assert found["joint_0"]["written"] == pytest.approx([-cabinet.joints["joint_0"].upper, 0.0], abs=1e-6)
    assert found["joint_1"]["opens_toward"] == "lower"
    assert_same_motion(asset, cabinet)  # the same drawer, read as the PartNet-style file reads
    rest = asset.mesh(asset.rest_configuration(), links=["link_0"]).bounds
    assert rest == pytest.approx(cabinet.mesh(links=["link_0"]).bounds, abs=1e-5)  # at rest: closed, as drawn


def test_libero_drawer_drawn_inside_its_range_opens_where_it_leaves_the_cabinet(cabinet, tmp_path):
    asset = read_variant(cabinet, "libero", tmp_path)
    found = {o["joint"]: o for o in asset.meta["opening_direction"]}["joint_0"]
    assert (found["opens_toward"], found["rule"]) == ("lower", "geometry")
    at_lower, at_upper = found["inside_at_lower_upper"]
    assert at_upper > 0.9 and at_lower < 0.5  # pushed 1 cm in: inside; pulled out: mostly outside
    assert_same_motion(asset, cabinet, rest_offset=0.01)  # rest 1 cm behind the closed drawer, as written


def test_a_part_no_limit_moves_into_the_object_keeps_its_range(cabinet):
    """A knob on the carcass's top turning about its own vertical axis: neither limit tells, so as written."""
    from helpers_boxes import box_visual

    from spark_bench.asset.model import Joint, Link

    knob = Link("knob", [box_visual([0.04, 0.04, 0.02], [0.0, 0.0, 0.01])])
    top = float(cabinet.bounds()[1][2])
    origin = np.eye(4)
    origin[:3, 3] = [0.0, 0.0, top]
    cabinet.links["knob"] = knob
    cabinet.joints["turn"] = Joint("turn", "revolute", "base", "knob", origin, np.array([0.0, 0, 1]), -1.0, 1.0)
    found = {o.joint: o for o in orient_joints(cabinet)}["turn"]
    assert (found.toward, found.rule) == ("upper", "geometry") and found.inside[0] == pytest.approx(found.inside[1])
    assert (cabinet.joints["turn"].lower, cabinet.joints["turn"].upper) == (-1.0, 1.0)


def test_a_urdf_keeps_the_convention(cabinet, tmp_path):
    """URDFs are not read so: their rest stays their lower limit (PartNet-Mobility objects unchanged)."""
    from spark_bench.asset.urdf import write_object_folder

    drawer = cabinet.joints["joint_0"]
    drawer.axis, drawer.lower, drawer.upper = -drawer.axis, -drawer.upper, 0.0
    back = load_object(write_object_folder(cabinet, tmp_path / "cabinet"))
    assert (back.joints["joint_0"].lower, back.joints["joint_0"].upper) == pytest.approx((drawer.lower, 0.0))
    assert "opening_direction" not in back.meta


def test_spark_benchs_own_usd_export_reads_back_as_written(cabinet, tmp_path):
    """The export places the bodies at rest (the lower limit): a range below 0 is drawn at its lower limit."""
    pytest.importorskip("pxr")
    from spark_bench.sim.export import export
    from spark_bench.sim.options import ConvertOptions

    door = cabinet.joints["joint_1"]
    door.lower, door.upper = -0.3, 1.2  # rest 0.3 rad open: inside the range as PartNet-Mobility writes it
    written = export(cabinet, tmp_path / "out", "usd", ConvertOptions(workers=1))
    back = load_object(written.model)
    found = {o["joint"]: o for o in back.meta["opening_direction"]}["joint_1"]
    assert found["rule"] == "rest at lower" and found["drawn_at"] == pytest.approx(-0.3, abs=1e-5)
    assert (back.joints["joint_1"].lower, back.joints["joint_1"].upper) == pytest.approx((-0.3, 1.2), abs=1e-5)
    for q in ({}, {"joint_1": 1.2}):
        assert back.mesh(q, links=["link_1"]).bounds == pytest.approx(cabinet.mesh(q, links=["link_1"]).bounds,
                                                                      abs=1e-5)


def test_drawn_value_is_the_turn_or_slide_between_the_joint_frames():
    from spark_bench.asset.transforms import axis_angle_matrix
    from spark_bench.asset.usd_model import drawn_value

    side1 = np.eye(4)
    side1[:3, :3] = axis_angle_matrix([0, 0, 1.0], 0.3)
    assert drawn_value("revolute", np.eye(4), side1, np.array([0, 0, 1.0]), -1.0, 1.0) == pytest.approx(0.3)
    side1[:3, :3] = axis_angle_matrix([0, 0, 1.0], 4.0 - 2 * math.pi)  # 4 rad as a turn of -2.28
    assert drawn_value("revolute", np.eye(4), side1, np.array([0, 0, 1.0]), 3.0, 6.0) == pytest.approx(4.0)
    slid = np.eye(4)
    slid[:3, 3] = [0.05, 0.2, 0.0]
    assert drawn_value("prismatic", np.eye(4), slid, np.array([1.0, 0, 0]), 0.0, 0.1) == pytest.approx(0.05)


def test_rollout_opens_the_metaworld_style_drawer(cabinet, tmp_path, capsys):
    from spark_bench import cli

    path = tmp_path / "metaworld.xml"
    path.write_text(cabinet_mjcf(cabinet, "metaworld"))
    code = cli.main(["rollout", "--env", "SparkDrawer-v0", "--asset", str(path), "--joint", "joint_0",
                     "--episodes", "1", "--json"])
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 0 and result["success_rate"] == 1.0 and "reason" not in result, result
