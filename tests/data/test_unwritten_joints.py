"""A PartNet-Mobility joint written without ``<axis>`` or ``<limit>`` takes them from ``mobility_v2.json``
(:func:`spark_bench.data.readers.fill_unwritten_joints`); the URDF's defaults put a safe door about its
horizontal mid-line and left two suitcase lids resting wide open."""

from __future__ import annotations

import json
import logging
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_real import PARTNET_DEV

from spark_bench.data.readers import annotated_joint, load_object

URDF = """<?xml version="1.0"?>
<robot name="lidded">
  <link name="base"/>
  <link name="link_0"><visual><geometry><mesh filename="textured_objs/lid.obj"/></geometry></visual></link>
  <link name="link_1"><visual><geometry><mesh filename="textured_objs/box.obj"/></geometry></visual></link>
  <link name="link_2"><visual><geometry><mesh filename="textured_objs/knob.obj"/></geometry></visual></link>
  <joint name="joint_0" type="revolute">
    <origin xyz="0 0.2 -0.3"/><child link="link_0"/><parent link="link_1"/>
  </joint>
  <joint name="joint_1" type="fixed">
    <origin rpy="1.570796326794897 0 -1.570796326794897" xyz="0 0 0"/><child link="link_1"/><parent link="base"/>
  </joint>
  <joint name="joint_2" type="prismatic">
    <origin xyz="0 0 0"/><axis xyz="0 0 1"/><child link="link_2"/><parent link="link_1"/>
  </joint>
</robot>
"""


def _lidded_folder(tmp_path: Path, annotation: list | None) -> Path:
    folder = tmp_path / "lidded"
    (folder / "textured_objs").mkdir(parents=True)
    for name in ("lid", "box", "knob"):
        trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(folder / "textured_objs" / f"{name}.obj")
    (folder / "mobility.urdf").write_text(URDF)
    if annotation is not None:
        (folder / "mobility_v2.json").write_text(json.dumps(annotation))
    return folder


def _entry(index: int, joint: str, direction, a: float, b: float) -> dict:
    return {"id": index, "name": "lid", "joint": joint,
            "jointData": {"axis": {"origin": [0, 0, 0], "direction": direction},
                          "limit": {"a": a, "b": b, "noLimit": False}}}


def test_a_joint_without_axis_or_limit_takes_the_annotation(tmp_path, caplog):
    # a range that runs backwards (60 to -120 degrees about -x) is written as -60..120 about +x
    folder = _lidded_folder(tmp_path, [_entry(0, "hinge", [-1, 0, 0], 60, -120),
                                       _entry(2, "slider", [0, 0, 1], 0, 0.05)])
    with caplog.at_level(logging.WARNING):
        asset = load_object(folder)
    lid = asset.joints["joint_0"]
    np.testing.assert_allclose(lid.axis, [1.0, 0.0, 0.0], atol=1e-12)
    assert lid.lower == pytest.approx(np.radians(-60.0)) and lid.upper == pytest.approx(np.radians(120.0))
    assert lid.has_limits and lid.has_axis and lid.rest_value == pytest.approx(np.radians(-60.0))
    assert "joint_0" in caplog.text and "mobility_v2.json" in caplog.text
    # joint_2 writes its axis; only its missing limit is read, in its own direction
    knob = asset.joints["joint_2"]
    np.testing.assert_allclose(knob.axis, [0.0, 0.0, 1.0])
    assert (knob.lower, knob.upper) == pytest.approx((0.0, 0.05))


def test_an_opposite_written_axis_takes_the_range_turned_round(tmp_path):
    folder = _lidded_folder(tmp_path, [_entry(0, "hinge", [0, 1, 0], 0, 90),
                                       _entry(2, "slider", [0, 0, -1], 0, 0.05)])
    knob = load_object(folder).joints["joint_2"]  # written about +z, annotated about -z over 0..5 cm
    np.testing.assert_allclose(knob.axis, [0.0, 0.0, 1.0])
    assert (knob.lower, knob.upper) == pytest.approx((-0.05, 0.0))


def test_without_an_annotation_the_urdf_defaults_stay_with_a_warning(tmp_path, caplog):
    for annotation in (None, [_entry(2, "slider", [0, 0, 1], 0, 0.05)]):
        folder = _lidded_folder(tmp_path / str(annotation is None), annotation)
        with caplog.at_level(logging.WARNING):
            lid = load_object(folder).joints["joint_0"]
        np.testing.assert_allclose(lid.axis, [1.0, 0.0, 0.0])
        assert (lid.lower, lid.upper) == pytest.approx((0.0, np.pi))
        assert not lid.has_axis and not lid.has_limits  # what the URDF wrote, as read
        assert "URDF's defaults are used" in caplog.text


def test_the_annotation_rule_reproduces_partnet_mobilitys_own_joints():
    """Every joint of partnet_dev that writes both its axis and limit, read from the annotation instead:
    the same joint (or, for a symmetric range, the same motion about the opposite direction)."""
    if not PARTNET_DEV.is_dir():
        pytest.skip(f"partnet_dev objects not available ({PARTNET_DEV} is absent)")
    compared = 0
    for urdf in sorted(PARTNET_DEV.glob("*/mobility.urdf")):
        annotation = urdf.parent / "mobility_v2.json"
        if not annotation.is_file():
            continue
        entries = {str(e.get("id")): e for e in json.loads(annotation.read_text())}
        for element in ET.parse(urdf).getroot().iter("joint"):
            kind, axis, limit = element.get("type"), element.find("axis"), element.find("limit")
            entry = entries.get(element.get("name", "").removeprefix("joint_"))
            if kind not in ("revolute", "prismatic") or axis is None or limit is None or entry is None:
                continue
            found = annotated_joint(entry, kind)
            assert found is not None, (urdf, element.get("name"))
            written = np.array([float(x) for x in axis.get("xyz").split()])
            written /= np.linalg.norm(written)
            lower, upper = float(limit.get("lower")), float(limit.get("upper"))
            direction, a, b = found
            same = np.allclose(direction, written, atol=1e-3) and np.allclose((a, b), (lower, upper), atol=1e-3)
            mirrored = (np.allclose(direction, -written, atol=1e-3) and np.allclose((a, b), (-upper, -lower), atol=1e-3))
            assert same or mirrored, (urdf, element.get("name"), written, lower, upper, found)
            compared += 1
    assert compared > 150
