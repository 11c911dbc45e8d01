"""MJCF output (PhysX-Anything's ``basic.xml``, Particulate's ``mjcf_<timestamp>/model.xml``, Real2Code's
dm_control model) read through MuJoCo into our frame.

The runs are written here the way each method's code writes them, from a ground-truth cabinet turned by
``YAW_DEG`` about the up axis (a view-dependent turn):

- Particulate (``RuiningLi/particulate``, ``export_utils.py`` ``export_mjcf``): the object in a unit box
  (``infer_single_asset``), ``<compiler angle="degree"/>``, a body per part at its origin (the hinge's
  point, else the part's mean vertex) relative to its parent's, ``meshes/part_<pid>.obj`` centred on it,
  a hinge's range converted from radians to degrees, ``%.6f`` numbers;
- PhysX-Anything (``ziangcao0312/PhysX-Anything``, ``4_simready_gen.py`` ``generate_mjcf``): ``basic.xml``
  by ElementTree, ``angle="radian"``, meshes ``./objs/<k>/<k>.obj`` in the normalized frame scaled to
  metres by the mesh ``scale``, textures, a plane floor, a ``base`` body at ``0 0 1`` with a freejoint,
  ``grouppart_<g>`` bodies nested under it, hinge ``pos`` scaled, ranges fractions times pi;
- Real2Code (``MandiZhao/real2code``, ``data_utils/obb_helper_functions.py``): ``meshdir``, radians, a
  ``root`` body with ``link_<k>`` bodies, joints at world positions, meshes with ``refquat``.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_boxes import box_mesh
from helpers_edits import edit_text
from helpers_formats import assert_matches_ground_truth, refused
from PIL import Image
from scipy.spatial.transform import Rotation

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data.readers import load_object
from spark_bench.formats.foreign import read_import_record
from spark_bench.formats.mjcf import read_run
from spark_bench.formats.runs import import_runs
from spark_bench.metrics.evaluate import compute_metrics

# MuJoCo keeps float32 vertices (about 1e-7 at unit size) and the writers print 6 decimals: 1e-5 still
# catches any frame, unit or sign error.
TOL = 1e-5
YAW_DEG = 31.0
STAMP = "20260125_134829"  # infer.py: datetime.now().strftime("%Y%m%d_%H%M%S")
REFQUAT = "0.5 -0.5 0.5 0.5"  # Real2Code's get_offset_xml


class Parts:
    """The ground truth's parts in a method's frame: turned by YAW_DEG about Z, centred on their box and
    scaled so that its largest side is 1 (Particulate's ``infer_single_asset``; PhysX-Anything's
    normalized frame). ``names``: the parts (links with geometry), the root first."""

    def __init__(self, gt):
        self.gt = gt
        meshes = gt.link_meshes(gt.rest_configuration())
        self.names = sorted(meshes, key=lambda n: (gt.joint_of_child(n) is not None, n))
        self.rotation = axis_angle_matrix([0, 0, 1], math.radians(YAW_DEG))
        turned = np.concatenate([m.vertices for m in meshes.values()]) @ self.rotation.T
        lo, hi = turned.min(0), turned.max(0)
        self.center, self.scale = (lo + hi) / 2, 1.0 / float((hi - lo).max())
        self.meshes = {n: self.point(meshes[n].vertices) for n in self.names}
        self.faces = {n: meshes[n].faces for n in self.names}

    def point(self, p) -> np.ndarray:
        return (np.asarray(p) @ self.rotation.T - self.center) * self.scale

    def direction(self, d) -> np.ndarray:
        return np.asarray(d) @ self.rotation.T

    def joint(self, name: str):
        """``(joint, point on the axis, unit axis)`` of the part ``name`` (None for the root), our frame."""
        joint = self.gt.joint_of_child(name)
        if joint is None or not joint.is_movable:
            return joint, None, None
        point, direction = self.gt.joint_frames()[joint.name]
        return joint, self.point(point), self.direction(direction)


def f6(values) -> str:
    return " ".join(f"{v:.6f}" for v in values)


def write_particulate(run: Path, gt, stamp: str = STAMP) -> Parts:
    """``export_mjcf`` as Particulate writes it (see the module docstring)."""
    parts = Parts(gt)
    folder = run / f"mjcf_{stamp}"
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    pid = {name: k for k, name in enumerate(parts.names)}
    origin = {}
    for name in parts.names:
        joint, point, direction = parts.joint(name)
        if joint is None:
            origin[name] = np.zeros(3)
        elif joint.type == "revolute":  # plucker_to_axis_point: the axis's point nearest the origin
            origin[name] = point - np.dot(point, direction) * direction
        else:  # prismatic (and fixed): the centroid of the part's vertices
            origin[name] = parts.meshes[name].mean(axis=0)
        local = trimesh.Trimesh(parts.meshes[name] - origin[name], parts.faces[name], process=False)
        local.export(folder / "meshes" / f"part_{pid[name]}.obj")

    def body(name: str, parent: str | None, indent: str) -> list[str]:
        rel = origin[name] - (origin[parent] if parent else 0.0)
        k = pid[name]
        lines = [f'{indent}<body name="link_{k}" pos="{f6(rel)}">',
                 f'{indent}  <geom type="mesh" mesh="mesh_part_{k}" name="visual_{k}"/>']
        joint, _, direction = parts.joint(name)
        if parent is not None and joint.type == "revolute":
            lines.append(f'{indent}  <joint name="joint_{k}" type="hinge" axis="{f6(direction)}" '
                         f'range="{f6(np.degrees([joint.lower, joint.upper]))}" limited="true"/>')
        elif parent is not None and joint.type == "prismatic":
            bounds = np.array([joint.lower, joint.upper]) * parts.scale
            lines.append(f'{indent}  <joint name="joint_{k}" type="slide" axis="{f6(direction)}" '
                         f'range="{f6(bounds)}" limited="true"/>')
        for child in parts.names:
            j = gt.joint_of_child(child)
            if j is not None and j.parent == name:
                lines += body(child, name, indent + "  ")
        return [*lines, f"{indent}</body>"]

    lines = ['<mujoco model="model">', '  <compiler angle="degree"/>', "  <asset>"]
    lines += [f'    <mesh name="mesh_part_{k}" file="meshes/part_{k}.obj"/>' for k in pid.values()]
    lines += ["  </asset>", "  <worldbody>", *body(parts.names[0], None, "    "), "  </worldbody>", "</mujoco>"]
    (folder / "model.xml").write_text("\n".join(lines))
    return parts


def test_particulate_round_trip_against_the_ground_truth(bench, gt, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    parts = write_particulate(runs / "cab0", gt, stamp="20260101_000000")  # an older export, not read
    write_particulate(runs / "cab0", gt)
    report = import_runs("mjcf", runs, bench, out, cases=["cab0"], reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"] and report.imported[0].articulated

    imported = load_object(out / "cab0")
    labels = {name: f"link_{k}" for k, name in enumerate(parts.names)}  # Particulate's body names
    mine = assert_matches_ground_truth(imported, gt, labels, TOL)
    for joint in gt.movable_joints():  # degrees in the file, radians here; the unit box undone
        assert mine[joint.name].lower == pytest.approx(joint.lower, abs=TOL)
        assert mine[joint.name].upper == pytest.approx(joint.upper, abs=TOL)
    assert any(j.type == "revolute" and j.upper > 1.0 for j in gt.movable_joints())  # a real turn

    # and as the metrics see it (alignment by ICP, as `eval --align icp` scores an import)
    metrics = compute_metrics(imported, gt, n_samples=3000, n_match_samples=2000, align="icp", workers=1)
    assert metrics.rest.cd < 1e-5 and not metrics.missing_joints and not metrics.extra_joints
    assert all(m.type_match and m.axis_err < 1e-5 for m in metrics.matches)
    assert [m.pivot_err < 1e-4 for m in metrics.matches if m.gt_type == "revolute"] == [True]

    record = read_import_record(out / "cab0")
    assert record["format"] == "mjcf" and record["layout"] == "Particulate"
    assert set(record["frame"]["open"]) == {"yaw", "scale", "front"}
    assert record["files"] == [f"mjcf_{STAMP}/model.xml", *(f"mjcf_{STAMP}/meshes/part_{k}.obj"
                                                            for k in range(len(parts.names)))]
    assert record["not_read"] == ["mjcf_20260101_000000/model.xml (an older export)"]
    assert record["compiler"]["angle"] == "degree"
    assert all("source" in f for f in record["facts"])


# ----- PhysX-Anything ---------------------------------------------------------------------------------------
DIMENSION_CM = "45*60*80"  # basic_info.json "dimension": the mesh scale is its largest / 100


def _write_png(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", (4, 4), (128, 90, 60)).save(path)


def write_physx(run: Path, gt, slide_range: tuple[float, float] | None = None,
                extra: dict[str, tuple] | None = None) -> Parts:
    """``basic.xml`` as ``generate_mjcf`` writes it (``--fixed_base 0 --deformable 0``).

    :param slide_range: the drawer's range as the VLM gave it (default: the ground truth's, normalized)
    :param extra: more groups, name -> ``(mesh, group type, param vector)`` (for ``CB``, ``D``...)
    """
    parts = Parts(gt)
    scale = max(int(v) for v in DIMENSION_CM.split("*")) / 100
    meshes = {n: (parts.meshes[n], parts.faces[n]) for n in parts.names}
    groups: dict[str, tuple] = {}
    for name in parts.names[1:]:
        joint, point, direction = parts.joint(name)
        if joint.type == "revolute":  # range: fractions of pi
            groups[name] = ("C", [*direction, *point, joint.lower / math.pi, joint.upper / math.pi])
        else:  # a slide's range as given, in the normalized frame (not scaled like the meshes)
            bounds = slide_range or (joint.lower * parts.scale, joint.upper * parts.scale)
            groups[name] = ("B", [*direction, 0.0, 0.0, 0.0, *bounds])
    for name, (mesh, kind, params) in (extra or {}).items():
        meshes[name] = (mesh.vertices, mesh.faces)
        groups[name] = (kind, params)
    index = {name: k for k, name in enumerate(meshes)}
    for name, (vertices, faces) in meshes.items():
        k = index[name]
        (run / "objs" / str(k)).mkdir(parents=True, exist_ok=True)
        trimesh.Trimesh(vertices, faces, process=False).export(run / "objs" / str(k) / f"{k}.obj")
        _write_png(run / "objs" / str(k) / "material_0.png")
    _write_png(run / "desert.png")  # shutil.copy('mjcf_source/desert.png', ...)

    mujoco = ET.Element("mujoco", attrib={"model": "test"})
    ET.SubElement(mujoco, "compiler", attrib={"angle": "radian", "autolimits": "true"})
    ET.SubElement(mujoco, "option", attrib={"timestep": "0.002", "gravity": "0 0 -9.81", "wind": "0 0 0",
                                            "integrator": "implicitfast", "density": "1.225",
                                            "viscosity": "1.8e-05"})
    asset = ET.SubElement(mujoco, "asset")
    pname = {name: f"l_{k}_{name}" for name, k in index.items()}
    for name, k in index.items():
        ET.SubElement(asset, "mesh", attrib={"name": pname[name], "file": f"./objs/{k}/{k}.obj",
                                             "scale": f"{scale} {scale} {scale}"})
        ET.SubElement(asset, "texture", attrib={"type": "2d", "name": f"{pname[name]}_tex",
                                                "file": f"./objs/{k}/material_0.png"})
        ET.SubElement(asset, "material", attrib={"name": f"{pname[name]}_img", "texture": f"{pname[name]}_tex"})
    ET.SubElement(asset, "texture", attrib={"type": "skybox", "file": "./desert.png", "gridsize": "3 4",
                                            "gridlayout": ".U..LFRB.D.."})
    ET.SubElement(asset, "texture", attrib={"name": "plane", "type": "2d", "builtin": "checker",
                                            "rgb1": ".1 .1 .1", "rgb2": ".5 .5 .5", "width": "512",
                                            "height": "512", "mark": "cross", "markrgb": ".8 .8 .8"})
    ET.SubElement(asset, "material", attrib={"name": "plane", "reflectance": "0.3", "texture": "plane",
                                             "texrepeat": "1 1", "texuniform": "true"})
    default = ET.SubElement(mujoco, "default")
    ET.SubElement(default, "geom", attrib={"solref": ".5e-4", "solimp": "0.9 0.99 1e-4",
                                           "fluidcoef": "0.5 0.25 0.5 2.0 1.0"})
    for name in index:
        cls = ET.SubElement(default, "default", attrib={"class": pname[name]})
        ET.SubElement(cls, "geom", attrib={"type": "mesh", "mesh": pname[name], "contype": "1",
                                           "conaffinity": "1", "density": "700.0", "fluidshape": "ellipsoid"})
    world = ET.SubElement(mujoco, "worldbody")
    ET.SubElement(world, "geom", attrib={"name": "floor", "pos": "0 0 0", "size": "0 0 .25", "type": "plane",
                                         "material": "plane", "condim": "6"})
    ET.SubElement(world, "light", attrib={"directional": "true", "ambient": ".3 .3 .3", "pos": "30 30 30",
                                          "dir": "0 -2 -1"})
    base = ET.SubElement(world, "body", attrib={"name": "base", "pos": "0 0 1", "euler": "0 0 0"})
    ET.SubElement(base, "freejoint")
    ET.SubElement(base, "geom", attrib={"class": pname[parts.names[0]], "material": f"{pname[parts.names[0]]}_img"})
    for g, (name, (kind, params)) in enumerate(groups.items(), start=1):
        body = ET.SubElement(base, "body", attrib={"name": f"grouppart_{g}", "pos": "0 0 0"})  # reparented
        hinge = {"type": "hinge", "name": f"pivot_{g}", "axis": " ".join(map(str, params[:3])),
                 "pos": " ".join(map(str, (np.array(params[3:6]) * scale).tolist())),
                 "range": " ".join(map(str, (np.array(params[6:8]) * np.pi).tolist()))}
        slide = {"type": "slide", "name": f"slide_{g}", "axis": " ".join(map(str, params[:3])),
                 "range": " ".join(map(str, params[6:8]))}
        if kind == "CB":
            slide.update(axis=" ".join(map(str, params[8:11])), range=" ".join(map(str, params[14:])))
        joints = {"B": [slide], "C": [hinge], "CB": [hinge, slide],
                  "D": [{"type": "ball", "name": f"ball_{g}", "pos": hinge["pos"]}]}[kind]
        for attrib in joints:
            ET.SubElement(body, "joint", attrib={**attrib, "damping": "0.001", "frictionloss": "0.0",
                                                 "stiffness": "0"})
        ET.SubElement(body, "geom", attrib={"class": pname[name], "material": f"{pname[name]}_img"})
    ET.indent(mujoco)
    ET.ElementTree(mujoco).write(run / "basic.xml", encoding="utf-8", xml_declaration=True)
    return parts


def test_physx_anything_round_trip_against_the_ground_truth(bench, gt, tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "pred"
    parts = write_physx(runs / "cab0", gt)
    report = import_runs("mjcf", runs, bench, out, cases=["cab0"], reader=read_run)
    assert [c.case_id for c in report.imported] == ["cab0"]

    imported = load_object(out / "cab0")
    labels = {name: f"grouppart_{g}" for g, name in enumerate(parts.names[1:], start=1)}
    mine = assert_matches_ground_truth(imported, gt, labels, TOL)
    door = next(j for j in gt.movable_joints() if j.type == "revolute")
    assert mine[door.name].upper == pytest.approx(door.upper, abs=1e-9)  # radians, as written

    record = read_import_record(out / "cab0")
    assert record["layout"] == "PhysX-Anything" and record["compiler"]["angle"] == "radian"
    assert record["files"] == ["basic.xml", *(f"objs/{k}/{k}.obj" for k in range(len(parts.names)))]
    assert "desert.png (texture)" in record["not_read"]
    assert record["skipped_geoms"] == ["geom 'floor' (body 'worldbody'): a plane, not a part's surface (a floor, "
                                       "a terrain)"]
    base = next(b for b in record["bodies"] if b["body"] == "base")
    assert base["fixed"] == ["free"] and base["joints"] == []
    hinged = next(b for b in record["bodies"] if b["body"] == "grouppart_2")
    assert [(j["name"], j["type"]) for j in hinged["joints"]] == [("pivot_2", "revolute")]


def test_physx_anything_placement_scale_and_slide_range_as_written(gt, tmp_path):
    """In the format's own frame: metres (the mesh scale), the base at z = 1 (its freejoint's rest), the
    slide's range in the VLM's normalized units (generate_mjcf does not scale it)."""
    parts = write_physx(tmp_path, gt, slide_range=(0.0, 0.25))
    asset = read_run(tmp_path).asset
    scale = 0.8
    expected = np.concatenate(list(parts.meshes.values())) * scale + [0, 0, 1]
    assert np.abs(asset.bounds() - [expected.min(0), expected.max(0)]).max() < 1e-6
    drawer = next(j for j in asset.joints.values() if j.type == "prismatic")
    assert drawer.upper == pytest.approx(0.25) and drawer.lower == 0.0


def test_physx_anything_hinge_and_slide_on_one_body_ball_and_free_parts(gt, tmp_path):
    """Group types CB (a hinge then a slide on one body: a chain through a link without geometry) and
    D (a ball joint: fixed at rest)."""
    cap = trimesh.creation.cylinder(radius=0.05, height=0.1, transform=trimesh.transformations.
                                    translation_matrix([0.1, 0.1, 0.55]))
    bob = trimesh.creation.icosphere(radius=0.05)
    bob.apply_translation([-0.1, 0.0, 0.55])
    write_physx(tmp_path, gt, extra={
        "cap": (cap, "CB", [0, 0, 1, 0.1, 0.1, 0.5, 0.0, 2.0, 0, 0, 1, 0, 0, 0, 0.0, 0.02]),
        "bob": (bob, "D", [0, 0, 0, -0.1, 0.0, 0.5, 0, 0])})
    asset = read_run(tmp_path).asset
    cap_link = next(n for n, link in asset.links.items() if link.label == "grouppart_3")
    turn = asset.joint_of_child(f"{cap_link}_helper_0")
    lift = asset.joint_of_child(cap_link)
    assert (turn.type, lift.type, lift.parent) == ("revolute", "prismatic", f"{cap_link}_helper_0")
    assert not asset.links[f"{cap_link}_helper_0"].has_geometry
    assert turn.upper == pytest.approx(2 * math.pi) and lift.upper == pytest.approx(0.02)
    frames = asset.joint_frames()
    assert np.allclose(frames[turn.name][0], [0.08, 0.08, 1.4]) and np.allclose(frames[turn.name][1], [0, 0, 1])
    # half a turn about the hinge, then the lift: the cap turns about (0.08, 0.08) and rises
    moved = asset.link_meshes({turn.name: math.pi, lift.name: 0.02})[cap_link].vertices
    rest = asset.link_meshes()[cap_link].vertices
    expected = (rest - [0.08, 0.08, 0]) @ axis_angle_matrix([0, 0, 1], math.pi).T + [0.08, 0.08, 0.02]
    assert np.abs(moved - expected).max() < 1e-9
    bob_link = next(n for n, link in asset.links.items() if link.label == "grouppart_4")
    assert asset.joint_of_child(bob_link).type == "fixed"


# ----- Real2Code and what MuJoCo applies ----------------------------------------------------------------
def write_real2code(run: Path, boxes: dict[str, trimesh.Trimesh], joints: dict[str, dict]) -> None:
    """A model as Real2Code's code builds it (dm_control: a ``/`` default class, ``meshdir``, radians), the
    meshes stored with ``refquat`` so that MuJoCo turns them into the world frame."""
    refquat = Rotation.from_quat(np.roll([float(v) for v in REFQUAT.split()], -1)).as_matrix()
    (run / "blender_meshes").mkdir(parents=True, exist_ok=True)
    for name, mesh in boxes.items():  # compiled = R^-1 v: stored = R v
        trimesh.Trimesh(mesh.vertices @ refquat.T, mesh.faces).export(run / "blender_meshes" / f"{name}.obj")
    assets = "".join(f'<mesh name="{n}" file="{n}.obj" refquat="{REFQUAT}"/>' for n in boxes)
    children = "".join(
        f'<body name="{n}"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>'
        f'<joint name="joint_{n.split("_")[1]}" type="{j["type"]}" pos="{f6(j["pos"])}" axis="{f6(j["axis"])}" '
        f'range="0 1"/><geom name="{n}_geom" type="mesh" mesh="{n}"/></body>' for n, j in joints.items())
    (run / "object.xml").write_text(
        '<mujoco model="object"><compiler meshdir="blender_meshes" angle="radian" autolimits="true"/>'
        '<default><default class="/"/></default>'
        f'<asset>{assets}</asset><worldbody><body name="root">'
        '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/><geom name="root_geom" type="mesh" mesh="link_0"/>'
        f"{children}</body></worldbody></mujoco>")


def test_real2code_model_joints_in_world_coordinates(tmp_path):
    boxes = {"link_0": box_mesh([0.6, 0.8, 1.0], [0, 0, 0.5]),
             "link_1": box_mesh([0.02, 0.8, 1.0], [-0.31, 0.0, 0.5]),
             "link_2": box_mesh([0.4, 0.6, 0.2], [-0.1, 0.0, 1.1])}
    joints = {"link_1": {"type": "hinge", "pos": [-0.31, -0.4, 0.5], "axis": [0, 0, 1]},
              "link_2": {"type": "slide", "pos": [-0.1, 0.0, 1.1], "axis": [-1, 0, 0]}}
    write_real2code(tmp_path, boxes, joints)
    found = read_run(tmp_path)
    asset = found.asset
    assert found.record["layout"] == "one MJCF" and found.record["files"][0] == "object.xml"
    rest = asset.link_meshes()
    for name, mesh in boxes.items():
        link = next(n for n, link in asset.links.items() if link.label == ("root" if name == "link_0" else name))
        assert np.abs(rest[link].bounds - mesh.bounds).max() < 1e-6  # refquat undone by MuJoCo
    by_label = {asset.links[j.child].label: j for j in asset.movable_joints()}
    frames = asset.joint_frames()
    door, drawer = by_label["link_1"], by_label["link_2"]
    assert door.type == "revolute" and door.upper == pytest.approx(1.0)  # range [0, 1] in radians
    assert np.allclose(frames[door.name][0], [-0.31, -0.4, 0.5]) and np.allclose(frames[door.name][1], [0, 0, 1])
    assert drawer.type == "prismatic" and np.allclose(frames[drawer.name][1], [-1, 0, 0])


SETTINGS_XML = """<mujoco model="settings">
  <compiler eulerseq="zyx" meshdir="shapes"/>
  <default>
    <default class="part"><geom type="mesh" rgba="0.2 0.4 0.6 1"/>
      <joint type="slide" axis="0 1 0" range="0 0.3"/></default>
    <default class="collision"><geom group="3" type="box" size="1 1 1"/></default>
  </default>
  <asset><mesh name="plate" file="plate.obj" scale="2 2 2"/></asset>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1"/>
    <body name="frame" pos="0 0 0.5" euler="90 0 30">
      <geom name="shell" type="box" size="0.5 0.4 0.3"/>
      <geom name="hull" class="collision"/>
      <body name="drawer" childclass="part" pos="0.2 0 0"><joint name="slide"/><geom mesh="plate"/></body>
      <body name="lid" pos="0 0 0.3">
        <joint name="hinge" type="hinge" axis="1 0 0" pos="0 0.1 0" range="-30 60" ref="10"/>
        <geom type="box" size="0.1 0.1 0.1"/>
      </body>
      <body name="knob" pos="0 0.3 0"><joint name="spin" type="hinge" axis="0 0 1"/>
        <geom type="sphere" size="0.05"/></body>
      <body name="empty" pos="0 0 -1"><joint type="hinge"/><site/></body>
    </body>
  </worldbody>
</mujoco>"""


def test_mujoco_applies_the_compiler_settings_and_default_classes(tmp_path):
    """Degrees (MJCF's default unit), ``eulerseq``, ``meshdir``, mesh ``scale``, default classes, a
    joint's ``ref``, an unlimited hinge, group 3 and planes, a body without geometry."""
    (tmp_path / "shapes").mkdir()
    box_mesh([0.1, 0.2, 0.05], [0.05, 0, 0]).export(tmp_path / "shapes" / "plate.obj")
    (tmp_path / "model.xml").write_text(SETTINGS_XML)
    found = read_run(tmp_path)
    asset, record = found.asset, found.record
    turn = Rotation.from_euler("ZYX", [90, 0, 30], degrees=True).as_matrix()  # zyx: axes moving with the frame
    frame_at = np.array([0, 0, 0.5])
    by_label = {asset.links[j.child].label: j for j in asset.movable_joints()}
    frames = asset.joint_frames()
    slide, hinge, spin = by_label["drawer"], by_label["lid"], by_label["knob"]
    assert slide.type == "prismatic" and slide.upper == pytest.approx(0.3)  # from the class
    assert np.allclose(frames[slide.name][1], turn @ [0, 1, 0])
    # the lid rests inside its range, [-40, 50] degrees about ref; toward 50 it swings into the frame, so it opens
    # toward -40: read about the opposite axis over [-50, 40] (spark_bench.asset.opening_direction)
    assert hinge.type == "revolute" and np.allclose(frames[hinge.name][1], -(turn @ [1, 0, 0]))
    assert np.allclose(frames[hinge.name][0], frame_at + turn @ [0, 0.1, 0.3])
    assert (hinge.lower, hinge.upper) == pytest.approx((math.radians(-50), math.radians(40)))  # about ref
    opened = {o["joint"]: o for o in asset.meta["opening_direction"]}
    assert (opened["hinge"]["opens_toward"], opened["hinge"]["rule"]) == ("lower", "geometry")
    assert opened["hinge"]["inside_at_lower_upper"][1] > opened["hinge"]["inside_at_lower_upper"][0] + 0.3
    assert {hinge.name, slide.name, spin.name} == {"hinge", "slide", "spin"}  # the author's names
    assert spin.type == "continuous"
    drawer = next(n for n, link in asset.links.items() if link.label == "drawer")
    plate = asset.link_meshes()[drawer]
    corners = 2 * box_mesh([0.1, 0.2, 0.05], [0.05, 0, 0]).vertices @ turn.T + frame_at + turn @ [0.2, 0, 0]
    assert np.abs(plate.bounds - [corners.min(0), corners.max(0)]).max() < 1e-6
    assert asset.links[drawer].visuals[0].rgba == pytest.approx((0.2, 0.4, 0.6, 1.0))
    assert record["compiler"] == {"angle": "degree", "eulerseq": "zyx", "meshdir": "shapes"}
    assert [s.split(":")[0] for s in record["skipped_geoms"]] == ["geom 'ground' (body 'worldbody')",
                                                                  "geom 'hull' (body 'frame')"]
    assert record["bodies"][-1] == {"dropped_bodies": ["empty"], "why": "no visual geom in their subtree"}
    assert "empty" not in {link.label for link in asset.links.values()}


# ----- bad input ------------------------------------------------------------------------------------------
@pytest.fixture
def run(gt, tmp_path) -> Path:
    write_particulate(tmp_path / "run", gt)
    return tmp_path / "run"


def _model(run: Path) -> Path:
    return run / f"mjcf_{STAMP}" / "model.xml"


def test_an_include_leaving_the_run_folder_is_refused(run, tmp_path):
    (tmp_path / "outside.xml").write_text('<mujoco><compiler angle="degree"/></mujoco>')
    edit_text(_model(run), "<asset>", '<include file="../../outside.xml"/>\n  <asset>')
    assert refused(read_run, run, "<include", "leads out of the run folder").path == str(_model(run))


def test_a_mesh_or_texture_path_leaving_the_run_folder_is_refused(run, tmp_path):
    trimesh.creation.box().export(tmp_path / "part_0.obj")
    edit_text(_model(run), 'file="meshes/part_0.obj"', 'file="../../part_0.obj"')
    refused(read_run, run, '<mesh file="../../part_0.obj">', "leads out of the run folder")
    edit_text(_model(run), 'file="../../part_0.obj"', f'file="{tmp_path / "part_0.obj"}"')  # an absolute name
    refused(read_run, run, "leads out of the run folder")
    edit_text(_model(run), f'file="{tmp_path / "part_0.obj"}"', 'file="meshes/part_0.obj"')
    edit_text(_model(run), "</asset>", '<texture name="t" type="2d" file="../../../etc/x.png"/></asset>')
    refused(read_run, run, "<texture file=", "leads out of the run folder")


def test_a_model_file_linked_from_outside_is_refused(run, tmp_path):
    outside = tmp_path / "elsewhere.xml"
    outside.write_text(_model(run).read_text())
    _model(run).unlink()
    _model(run).symlink_to(outside)
    refused(read_run, run, "the model file (a link)", "leads out of the run folder")


def test_a_meshdir_leaving_the_run_folder_is_refused(run, tmp_path):
    (tmp_path / "meshes").mkdir()
    for path in (_model(run).parent / "meshes").iterdir():
        (tmp_path / "meshes" / path.name).write_bytes(path.read_bytes())
    edit_text(_model(run), '<compiler angle="degree"/>', '<compiler angle="degree" meshdir="../.."/>')
    refused(read_run, run, "leads out of the run folder")


def test_an_include_cycle_is_refused(run):
    (_model(run).parent / "a.xml").write_text('<mujoco><include file="b.xml"/></mujoco>')
    (_model(run).parent / "b.xml").write_text('<mujoco><include file="a.xml"/></mujoco>')
    edit_text(_model(run), "<asset>", '<include file="a.xml"/>\n  <asset>')
    refused(read_run, run, "a.xml", "cycle of includes")


def test_a_missing_part_file_is_refused(run):
    (_model(run).parent / "meshes" / "part_1.obj").unlink()
    refused(read_run, run, '<mesh file="meshes/part_1.obj">', "no such file")


def test_a_truncated_mesh_is_refused(run):
    path = _model(run).parent / "meshes" / "part_1.obj"
    path.write_bytes(path.read_bytes()[:60])  # a few vertices and no face
    refused(read_run, run, "MuJoCo cannot compile it", "mesh_part_1", "meshes/part_1.obj")


def test_nan_in_an_axis_is_refused(run):
    text = _model(run).read_text()
    axis = text.split('type="hinge" axis="')[1].split('"')[0]
    edit_text(_model(run), f'axis="{axis}"', 'axis="nan 0 1"')
    refused(read_run, run, "joint 'joint_", "not finite")


def test_radians_where_degrees_are_declared_are_refused(run, gt):
    """Particulate declares degrees; the door's range written in radians (export_mjcf's np.degrees
    forgotten) reads as a turn of a degree or two."""
    door = next(j for j in gt.movable_joints() if j.type == "revolute")
    edit_text(_model(run), f'range="{f6(np.degrees([door.lower, door.upper]))}"',
              f'range="{f6([door.lower, door.upper])}"')
    refused(read_run, run, "reads as radians", 'angle="degree"')


def test_degrees_where_radians_are_declared_are_refused(gt, tmp_path):
    write_physx(tmp_path, gt)
    hinge = (tmp_path / "basic.xml").read_text().split('type="hinge"')[1].split('range="')[1].split('"')[0]
    edit_text(tmp_path / "basic.xml", f'range="{hinge}"', 'range="0 90"', count=-1)
    refused(read_run, tmp_path, "pivot_", "beyond a full turn in radians",
            "degrees written where radians are declared")


def test_other_files_are_refused(run, tmp_path):
    _model(run).write_text('<robot name="model"><link name="base"/></robot>')
    refused(read_run, run, "not an MJCF file", "<robot>", "URDF")
    _model(run).write_text("<mujoco><worldbody>")
    refused(read_run, run, "not an XML file")
    _model(run).write_text('<mujoco><worldbody><body><geom type="box" size="1 1"/></body></worldbody></mujoco>')
    refused(read_run, run, "MuJoCo cannot")
    _model(run).write_text('<mujoco><worldbody><geom type="plane" size="1 1 1"/></worldbody></mujoco>')
    refused(read_run, run, "no visual geom")
    empty = tmp_path / "empty"
    empty.mkdir()
    refused(read_run, empty, "no MJCF file")
    (empty / "a.xml").write_text("<mujoco/>")
    (empty / "b.xml").write_text("<mujoco/>")
    refused(read_run, empty, "2 *.xml files")


def test_from_a_method_output_folder_to_the_leaderboard(bench, gt, tmp_path, isolated_home, capsys):
    """The README's commands for another method, run as written: import the runs, score them with
    ``--align icp``, print the leaderboard; the row is the method's label, its joints are right, and the scale
    the alignment applied to the unit-box export stands beside the errors."""
    from spark_bench.cli import main

    runs, pred, db = tmp_path / "runs", tmp_path / "pred", tmp_path / "r.sqlite"
    write_particulate(runs / "cab0", gt)
    assert main(["import", "mjcf", "--runs", str(runs), "--bench", str(bench), "--out", str(pred)]) == 0
    assert "cab1" in capsys.readouterr().out  # the case without a run is listed
    assert main(["eval", "--method", "predictions", "--method-args", f"predictions={pred},label=Particulate",
                 "--bench", str(bench), "--align", "icp", "--no-sim", "--n-samples", "5000", "--db", str(db),
                 "--cases", "cab0", "--workers", "0", "--no-progress", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["metrics"]["axis_err"] < 1e-3 and summary["metrics"]["type_err"] == 0.0
    scale = summary["metrics"]["alignment_scale"]
    assert scale["cases"] == 1 and scale["median"] == pytest.approx(1.0, abs=0.11)
    assert main(["leaderboard", "--db", str(db), "--format", "md"]) == 0
    board = capsys.readouterr().out
    assert "Particulate" in board and "ICP scale" in board
