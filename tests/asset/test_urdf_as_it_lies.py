"""A user's own URDF, read as it lies: mesh paths as ROS resolves them (``..``, ``package://``, absolute) when
the URDF is named directly; the refusal, with the option that allows it, where a folder is read.

The fixture reproduces URDFormer's shipped predictions (``WEIRDLabUW/urdformer`` ``output/label3.urdf``):
``output/label*.urdf`` beside ``meshes/``, mesh paths ``../meshes/cabinet.obj`` and
``../meshes/parts/drawer.obj`` with a per-link ``scale``, ``<inertial>`` of 0.2 kg, knobs on fixed joints.
It is made here, not copied.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers_boxes import box_between
from helpers_edits import edit_text

from spark_bench.data.readers import load_object
from spark_bench.errors import InputError

INERTIAL = ('<inertial><mass value="0.2" /><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4" />'
            '</inertial>')


def _link_xml(name: str, mesh: str, scale: str = "1 1 1") -> str:
    geometry = f'<geometry><mesh filename="{mesh}" scale="{scale}" /></geometry>'
    return (f'<link name="{name}"><visual><origin xyz="0 0 0" rpy="0 0 0" /><material name="white"><color '
            f'rgba="0.8 0.8 0.8 1" /></material>{geometry}</visual><collision><origin xyz="0 0 0" rpy="0 0 0" />'
            f'{geometry}</collision>{INERTIAL}</link>')


def urdformer_layout(root: Path, prefix: str = "../meshes/") -> Path:
    """``root/output/label3.urdf`` and ``root/meshes/`` as URDFormer writes them; returns the URDF."""
    (root / "output").mkdir(parents=True, exist_ok=True)
    (root / "meshes" / "parts").mkdir(parents=True, exist_ok=True)
    box_between((0, -0.5, 0), (0.5, 0.5, 1.0)).export(root / "meshes" / "cabinet.obj")
    box_between((-0.02, -0.23, 0.0), (0.0, 0.23, 0.22)).export(root / "meshes" / "parts" / "drawer.obj")
    box_between((-0.03, -0.01, -0.01), (0.0, 0.01, 0.01)).export(root / "meshes" / "parts" / "knob.obj")
    text = ("<?xml version='1.0' encoding='utf-8'?>\n<robot name=\"my_urdf\">"
            + _link_xml("base_link", f"{prefix}cabinet.obj")
            + _link_xml("drawer0", f"{prefix}parts/drawer.obj", "1 1.98 0.98")
            + '<joint name="drawer0_to_base_link" type="prismatic"><axis xyz="-1 0 0" /><limit effort="5" lower="0" '
              'upper="0.4" velocity="2.283" /><origin xyz="0 0.0 0.75" rpy="0.0 0.0 0.0" /><parent link="base_link" />'
              '<child link="drawer0" /></joint>'
            + _link_xml("knob1", f"{prefix}parts/knob.obj")
            + '<joint name="knob1_to_drawer0" type="fixed"><axis xyz="0 0 1" /><limit effort="5" lower="0" '
              'upper="1.57" velocity="2.283" /><origin xyz="0 0.25 0.125" rpy="1.5707963267948963 0.0 0.0" />'
              '<parent link="drawer0" /><child link="knob1" /></joint></robot>')
    urdf = root / "output" / "label3.urdf"
    urdf.write_text(text)
    return urdf


def test_urdformer_output_loads_as_it_lies(tmp_path):
    urdf = urdformer_layout(tmp_path)
    asset = load_object(urdf)
    assert set(asset.links) == {"base_link", "drawer0", "knob1"}
    drawer = asset.links["drawer0"]
    assert drawer.visuals[0].source == "../meshes/parts/drawer.obj"
    # the URDF's scale is applied: 0.46 m wide drawer mesh times 1.98, 0.22 m tall times 0.98
    extents = drawer.visuals[0].mesh.extents
    assert extents[1] == pytest.approx(0.46 * 1.98, rel=1e-6) and extents[2] == pytest.approx(0.22 * 0.98, rel=1e-6)
    joint = asset.joints["drawer0_to_base_link"]
    assert (joint.type, joint.lower, joint.upper) == ("prismatic", 0.0, pytest.approx(0.4))
    open_bounds = asset.bounds({"drawer0_to_base_link": 0.4})
    assert open_bounds[0][0] == pytest.approx(-0.4 - 0.03, abs=1e-6)  # the knob (3 cm deep at x 0) came out 0.4 m


def test_folder_read_still_refuses_traversal_and_names_the_way_out(tmp_path):
    urdf = urdformer_layout(tmp_path)
    with pytest.raises(InputError, match="escapes the object folder") as info:
        load_object(urdf.parent)  # a folder: its URDF is confined to it, as for benchmark cases
    assert "name the URDF file itself" in str(info.value) and "--package-path" in str(info.value)


def test_package_paths_from_the_option_and_from_ros_package_path(tmp_path, monkeypatch):
    urdf = urdformer_layout(tmp_path / "ws" / "cabinet_description", prefix="package://cabinet_description/meshes/")
    moved = tmp_path / "elsewhere" / urdf.name
    moved.parent.mkdir()
    urdf.rename(moved)  # the URDF away from its package: only the package path finds the meshes
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    with pytest.raises(InputError, match="package 'cabinet_description' not found") as info:
        load_object(moved)
    assert "--package-path" in str(info.value) and str(moved.resolve()) in str(info.value)
    asset = load_object(moved, package_paths=[tmp_path / "ws"])
    source = Path(asset.links["drawer0"].visuals[0].source)
    assert (moved.parent / source).resolve() == (tmp_path / "ws/cabinet_description/meshes/parts/drawer.obj").resolve()
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'nothing'}:{tmp_path / 'ws'}")
    assert set(load_object(moved).links) == {"base_link", "drawer0", "knob1"}


def test_package_found_in_a_workspace_by_its_package_xml(tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    package = tmp_path / "ws" / "src" / "furniture" / "cabinet_description"
    urdf = urdformer_layout(package, prefix="package://cabinet_description/meshes/")
    (package / "package.xml").write_text("<package><name>cabinet_description</name></package>")
    moved = tmp_path / "label3.urdf"
    urdf.rename(moved)
    assert "drawer0" in load_object(moved, package_paths=[tmp_path / "ws"]).links  # ws/src/furniture/NAME


def test_package_url_inside_its_own_package_needs_no_path(tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    urdf = urdformer_layout(tmp_path / "cabinet_description", prefix="package://cabinet_description/meshes/")
    assert "drawer0" in load_object(urdf).links  # urdf/ (here output/) inside the package folder


def test_absolute_and_file_url_paths(tmp_path):
    urdf = urdformer_layout(tmp_path)
    meshes = (tmp_path / "meshes").resolve()
    edit_text(urdf, "../meshes/cabinet.obj", f"{meshes}/cabinet.obj", count=-1)
    edit_text(urdf, "../meshes/parts/drawer.obj", f"file://{meshes}/parts/drawer.obj", count=-1)
    asset = load_object(urdf)
    assert asset.links["base_link"].visuals[0].mesh.extents == pytest.approx([0.5, 1.0, 1.0])
    assert asset.links["drawer0"].visuals[0].source == "../meshes/parts/drawer.obj"


def test_missing_mesh_as_it_lies_names_the_file(tmp_path):
    urdf = urdformer_layout(tmp_path)
    (tmp_path / "meshes" / "cabinet.obj").unlink()
    with pytest.raises(InputError, match="'../meshes/cabinet.obj' not found"):
        load_object(urdf)


def test_convert_takes_package_path_and_a_urdf_outside_any_object_folder(tmp_path, monkeypatch, capsys):
    from spark_bench import cli

    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    urdf = urdformer_layout(tmp_path / "ws" / "cabinet_description", prefix="package://cabinet_description/meshes/")
    moved = tmp_path / "elsewhere" / urdf.name
    moved.parent.mkdir()
    urdf.rename(moved)
    out = tmp_path / "sim"
    args = ["convert", str(moved), "--out", str(out), "--workers", "1", "--no-progress"]
    assert cli.main(args) == 2 and "--package-path" in capsys.readouterr().err
    assert cli.main(args + ["--package-path", str(tmp_path / "ws")]) == 0
    assert (out / "model.xml").is_file() and (out / "model.urdf").is_file()
