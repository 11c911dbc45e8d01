"""The seven shared PartNet-Mobility objects load with their structure intact (skip when absent)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers_real import REAL_IDS, real_object_path

from spark_bench.asset.urdf import write_object_folder
from spark_bench.data import load_object
from spark_bench.data.case import to_benchmark_frame

EXPECTED = {  # id: (category, movable joint types)
    "41083": ("StorageFurniture", ["revolute", "revolute", "prismatic", "prismatic"]),
    "40147": ("StorageFurniture", ["revolute", "prismatic"]),
    "45780": ("StorageFurniture", ["revolute", "revolute"]),
    "7179": ("Oven", ["prismatic"] * 3 + ["revolute"] * 2),
    "47645": ("Box", ["revolute"]),
    "102442": ("Camera", ["prismatic"] * 12),
    "3763": ("Bottle", ["continuous", "prismatic"]),
}


@pytest.mark.parametrize("object_id", REAL_IDS)
def test_real_object_loads(object_id):
    asset = load_object(real_object_path(object_id))
    category, types = EXPECTED[object_id]
    assert asset.category == category
    assert sorted(j.type for j in asset.movable_joints()) == sorted(types)
    assert asset.root == "base"
    bounds = asset.bounds()
    assert np.all(np.isfinite(bounds)) and (bounds[1] - bounds[0]).min() > 0.05
    # every movable part has geometry, and the open state moves it
    for joint in asset.movable_joints():
        part = asset.part_of_joint(joint.name)
        meshes = asset.link_meshes(None, part)
        if not meshes:  # a helper link: geometry hangs below the next joint
            continue
        moved = asset.link_meshes({joint.name: joint.open_value}, part)
        shift = max(np.abs(moved[k].vertices - meshes[k].vertices).max() for k in meshes)
        assert shift > 1e-3, f"{joint.name} does not move its part"


def test_bottle_helper_link_and_continuous_cap():
    asset = load_object(real_object_path("3763"))
    assert "link_0_helper" in asset.links and not asset.links["link_0_helper"].has_geometry
    cap = asset.joints["joint_0"]
    assert cap.type == "continuous" and cap.parent == "link_0_helper"
    assert asset.joints["joint_2"].child == "link_0_helper" and asset.joints["joint_2"].lower < 0
    # the prismatic joint moves the cap through the helper link
    assert asset.moving_links("joint_2") == ["link_0_helper", "link_0"]
    assert asset.links["link_0"].label == "rotation_lid"


def test_camera_has_twelve_buttons():
    asset = load_object(real_object_path("102442"))
    buttons = [j for j in asset.movable_joints() if asset.links[j.child].label == "button"]
    assert len(buttons) == 12


def test_flat_meshes_and_gapartnet_annotations():
    asset = load_object(real_object_path("41083"))
    flat = [n for n, link in asset.links.items() if link.has_geometry
            and min(v.mesh.extents.min() for v in link.visuals) < 1e-6]
    assert flat, "41083 is known for its flat (coplanar) meshes"
    annotated = load_object(real_object_path("45780"), variant="gapartnet")
    assert annotated.links["link_0"].annotations["category"] == "hinge_door"
    assert annotated.links["link_3"].label == "handle"


def test_real_object_round_trip_in_benchmark_frame(tmp_path):
    asset, center, scale = to_benchmark_frame(load_object(real_object_path("40147")))
    write_object_folder(asset, tmp_path / "normalized")
    back = load_object(tmp_path / "normalized")
    q = back.open_configuration()
    np.testing.assert_allclose(back.mesh(q).vertices, asset.mesh(q).vertices, atol=1e-6)
    assert np.abs(back.bounds()).max() == pytest.approx(1.0, abs=1e-6)
