"""A PartNet-Mobility object is read at its real size (:mod:`spark_bench.data.real_size`): its ``info.json``
keypoint annotation's ``scale``, else its category's median; everything else is read as its files give it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from helpers_real import PARTNET_DEV

from spark_bench.data.readers import load_object
from spark_bench.data.real_size import CATEGORY_SCALE, annotated_scale, source_scale
from spark_bench.errors import InputError

URDF = """<?xml version="1.0"?>
<robot name="drawered">
  <link name="base"/>
  <link name="link_0"><visual><geometry><mesh filename="textured_objs/drawer.obj"/></geometry></visual></link>
  <link name="link_1"><visual><geometry><mesh filename="textured_objs/body.obj"/></geometry></visual></link>
  <joint name="joint_0" type="prismatic">
    <origin xyz="0.1 0.2 -0.3"/><axis xyz="0 0 1"/><child link="link_0"/><parent link="link_1"/>
    <limit lower="0" upper="0.6"/>
  </joint>
  <joint name="joint_1" type="fixed"><child link="link_1"/><parent link="base"/></joint>
</robot>
"""


def _drawered_folder(tmp_path: Path, category: str, info: dict | None, partnet: bool = True) -> Path:
    folder = tmp_path / "drawered"
    (folder / "textured_objs").mkdir(parents=True)
    trimesh.creation.box(extents=(0.8, 0.3, 0.1)).export(folder / "textured_objs" / "drawer.obj")
    trimesh.creation.box(extents=(1.0, 1.2, 0.9)).export(folder / "textured_objs" / "body.obj")
    (folder / "mobility.urdf").write_text(URDF)
    (folder / "meta.json").write_text(json.dumps({"model_cat": category}))
    if partnet:
        (folder / "mobility_v2.json").write_text("[]")
    if info is not None:
        (folder / "info.json").write_text(json.dumps(info))
    return folder


def _size(asset) -> np.ndarray:
    low, high = asset.bounds()
    return high - low


def test_an_annotated_object_is_read_at_its_annotated_scale(tmp_path):
    folder = _drawered_folder(tmp_path, "Table", {"scale": 0.25, "keypoints": {}})
    read = load_object(folder)
    (folder / "info.json").unlink()
    (folder / "mobility_v2.json").unlink()
    as_files = load_object(folder)
    np.testing.assert_allclose(_size(read), 0.25 * _size(as_files), rtol=1e-9)
    moved, still = read.joints["joint_0"], as_files.joints["joint_0"]
    np.testing.assert_allclose(moved.origin[:3, 3], 0.25 * still.origin[:3, 3], rtol=1e-9)
    assert moved.upper == pytest.approx(0.25 * 0.6)  # a drawer's travel is a length too
    assert source_scale(folder, "Table").rule == "as read"


def test_a_partnet_object_without_annotation_takes_its_category_median(tmp_path):
    folder = _drawered_folder(tmp_path, "Microwave", None)
    scale = source_scale(folder, "Microwave")
    assert (scale.factor, scale.rule) == (CATEGORY_SCALE["Microwave"], "category Microwave")
    assert _size(load_object(folder)).max() == pytest.approx(CATEGORY_SCALE["Microwave"] * 1.2)


def test_objects_in_metres_and_unknown_categories_are_read_as_they_are(tmp_path):
    # a synth object or a method's output (no mobility_v2.json) of a category the table has, even with an
    # info.json of its own, and a PartNet one of a category the table has not
    folder = _drawered_folder(tmp_path / "a", "Table", {"scale": 0.3}, partnet=False)
    assert source_scale(folder, "Table").rule == "as read"
    folder = _drawered_folder(tmp_path / "b", "StorageFurniture", None)
    assert source_scale(folder, "StorageFurniture").factor == 1.0
    assert _size(load_object(folder)).max() == pytest.approx(1.2)


@pytest.mark.parametrize("scale", [0, -0.2, "big", float("nan"), 1e6, [0.2, 0.3, 0.2], True, [True, True, True]])
def test_a_broken_scale_names_the_file(tmp_path, scale):
    path = tmp_path / "info.json"
    path.write_text(json.dumps({"scale": scale}))  # NaN is written as JSON5 NaN, which Python reads
    with pytest.raises(InputError, match="info.json.*scale"):
        annotated_scale(path)


def test_a_uniform_scale_written_per_axis_and_a_file_without_one(tmp_path):
    path = tmp_path / "info.json"
    path.write_text(json.dumps({"scale": [0.3, 0.3, 0.3, 1.0]}))
    assert annotated_scale(path) == pytest.approx(0.3)
    path.write_text('{"scale": [2, 2.0, 2]}')  # an int and floats of one value: uniform
    assert annotated_scale(path) == pytest.approx(2.0)
    path.write_text(json.dumps({"keypoints": {}}))
    assert annotated_scale(path) is None
    path.write_text("{not json")
    with pytest.raises(InputError, match="malformed JSON"):
        annotated_scale(path)


@pytest.mark.skipif(not PARTNET_DEV.is_dir(), reason="../shared/partnet_dev is not on this machine")
def test_partnet_dev_objects_come_back_at_a_tabletop_size():
    # as read, a wooden box of partnet_dev is 1.6 m long and its microwaves 1.6 m wide
    for object_id, lo, hi in (("100247", 0.25, 0.4), ("7263", 0.4, 0.55)):
        size = _size(load_object(PARTNET_DEV / object_id, load_meshes=True)).max()
        assert lo < size < hi, (object_id, size)


@pytest.mark.skipif(not PARTNET_DEV.is_dir(), reason="../shared/partnet_dev is not on this machine")
def test_the_category_table_is_the_median_of_partnet_devs_annotations():
    by_category: dict[str, list[float]] = {}
    for folder in sorted(p for p in PARTNET_DEV.iterdir() if (p / "info.json").is_file()):
        category = json.loads((folder / "meta.json").read_text())["model_cat"]
        by_category.setdefault(category, []).append(annotated_scale(folder / "info.json"))
    assert {c: float(np.median(v)) for c, v in by_category.items()} == pytest.approx(CATEGORY_SCALE)
