"""The procedural dataset generator: format, limits, clearance, watertightness, determinism."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from spark_bench.data import load_object
from spark_bench.data.synth import CATEGORIES, generate_dataset, generate_object, object_seed
from spark_bench.data.synth.clearance import asset_overlaps, box_polytope, separation
from spark_bench.data.synth.generate import VARIANTS
from spark_bench.errors import InputError

REQUIRED = {"StorageFurniture", "Table", "Refrigerator", "Microwave", "Oven", "Dishwasher", "WashingMachine", "Safe",
            "Box", "TrashCan", "Toilet", "Laptop", "Suitcase", "Door", "Window", "Faucet", "Bucket", "KitchenPot",
            "CoffeeMachine", "Toaster", "Printer"}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> list[Path]:
    """One object per category, then one per variant (every per-object check covers them too)."""
    out = tmp_path_factory.mktemp("synth")
    folders = generate_dataset(out, len(CATEGORIES), seed=0, progress=False)
    return folders + [generate_object(v, object_seed(0, k), out, f"{v}_{k:05d}") for k, v in enumerate(VARIANTS)]


@pytest.fixture(scope="module")
def assets(dataset):
    return {folder.name: load_object(folder) for folder in dataset}


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_categories_cover_the_list(dataset):
    assert REQUIRED <= set(CATEGORIES) and len(CATEGORIES) >= 20
    cats = [json.loads((f / "meta.json").read_text())["model_cat"] for f in dataset[:len(CATEGORIES)]]
    assert sorted(cats) == sorted(CATEGORIES)  # round-robin: n = number of categories covers all
    meta = json.loads((dataset[3] / "meta.json").read_text())
    assert meta["generator"]["seed"] == object_seed(0, 3) and meta["generator"]["version"]


def test_partnet_mobility_layout(dataset, assets):
    for folder in dataset:
        urdf = (folder / "mobility.urdf").read_text()
        assert '<link name="base"/>' in urdf
        assert '<origin rpy="1.570796 0 -1.570796" xyz="0 0 0"/>' in urdf
        asset = assets[folder.name]
        for name in asset.links:
            assert name == "base" or re.fullmatch(r"link_\d+", name), name
        for joint in asset.joints.values():
            if joint.parent != "base":  # joint_i moves link_i
                assert joint.name == "joint_" + joint.child.split("_")[1]
        lines = (folder / "semantics.txt").read_text().splitlines()
        assert {line.split()[0] for line in lines} == set(asset.links) - {"base"}
        for line in lines:
            link, word, label = line.split()
            joint = asset.joint_of_child(link)
            expected = {"prismatic": "slider", "revolute": "hinge", "continuous": "hinge"}.get(joint.type)
            assert word == expected if expected else word in ("heavy", "free", "static"), line
        size = asset.bounds()[1] - asset.bounds()[0]
        assert 0.1 < size.max() < 2.5, (folder.name, size)


def test_joint_types_and_limits(assets):
    types = {j.type for a in assets.values() for j in a.joints.values()}
    assert {"revolute", "prismatic", "continuous", "fixed"} <= types
    for name, asset in assets.items():
        movable = asset.movable_joints()
        assert movable, name
        for joint in movable:
            label = asset.links[joint.child].label
            if joint.type == "continuous":
                continue
            assert joint.lower == 0.0 and joint.upper > joint.lower, (name, joint.name)
            if label in ("rotation_door", "door") and joint.type == "revolute":
                assert 1.3 <= joint.upper <= 3 * np.pi / 4 + 1e-6, (name, label, joint.upper)
            if label == "drawer":
                mesh = asset.links[joint.child].merged_mesh()
                extent = np.ptp(mesh.vertices @ joint.axis)
                # 0.75-0.9 of the drawer box, which is the link minus its front (and merged handle)
                assert 0.55 * extent <= joint.upper <= 0.9 * extent, (name, joint.upper, extent)


def test_world_frame_conventions(assets):
    """After the root joint, Z is up and the front faces -X: drawers slide along world -X."""
    for name, asset in assets.items():
        frames = asset.joint_frames()
        for joint in asset.movable_joints():
            _, axis = frames[joint.name]
            label = asset.links[joint.child].label
            if label == "drawer":
                assert np.allclose(axis, [-1, 0, 0], atol=1e-6), (name, axis)
            if label == "rotation_door":
                assert abs(axis[2]) == pytest.approx(1.0), (name, axis)
        lo, hi = asset.bounds()
        if name.startswith(("StorageFurniture", "Refrigerator", "Dishwasher")):
            assert lo[2] == pytest.approx(0.0, abs=1e-3)  # standing on the floor


def test_no_part_overlaps_another_at_rest_open_or_along_its_motion(assets):
    for name, asset in assets.items():
        overlaps = asset_overlaps(asset, tolerance=0.0, samples=5)
        assert overlaps == [], (name, overlaps[:3])


def test_clearance_check_sees_a_wrong_joint(assets):
    """The checker is not vacuous: a door turning inwards or a drawer sliding backwards collides."""
    asset = next(a for n, a in assets.items() if n.startswith("StorageFurniture")).copy()
    door = next(j for j in asset.movable_joints() if asset.links[j.child].label == "rotation_door")
    drawer = next(j for j in asset.movable_joints() if asset.links[j.child].label == "drawer")
    door.axis = -door.axis
    hits = asset_overlaps(asset, samples=5)
    assert any(door.child in (h.link_a, h.link_b) for h in hits)
    door.axis = -door.axis
    drawer.axis = -drawer.axis
    hits = asset_overlaps(asset, samples=5)
    assert any(drawer.child in (h.link_a, h.link_b) for h in hits)


def test_separation_of_boxes():
    a = box_polytope(1.0, 1.0, 1.0)
    pose = np.eye(4)
    moved = np.eye(4)
    moved[0, 3] = 1.25
    assert separation(a, pose, a, moved) == pytest.approx(0.25)
    moved[0, 3] = 0.9
    assert separation(a, pose, a, moved) == pytest.approx(-0.1)
    turn = np.eye(4)  # a cube turned 45 degrees about z reaches sqrt(2)/2 from its centre
    turn[:3, :3] = trimesh.transformations.rotation_matrix(np.pi / 4, [0, 0, 1])[:3, :3]
    turn[0, 3] = 1.15
    assert separation(a, pose, a, turn) < 0
    turn[0, 3] = 1.25
    assert separation(a, pose, a, turn) == pytest.approx(1.25 - 0.5 - np.sqrt(0.5))


def test_meshes_watertight_colored_and_collisions_convex(dataset):
    for folder in dataset:
        urdf = (folder / "mobility.urdf").read_text()
        visuals = re.findall(r'<visual name="([^"]+)">', urdf)
        assert visuals
        assert len(re.findall(r"<color rgba=", urdf)) == len(visuals)
        colors = set()
        for name in visuals:
            mesh = trimesh.load(folder / "textured_objs" / f"{name}.obj", process=True)
            assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, (folder.name, name)
            assert len(mesh.faces) < 5000
            kd = re.search(r"^Kd (.+)$", (folder / "textured_objs" / f"{name}.mtl").read_text(), re.M)
            colors.add(kd.group(1))
        assert len(colors) >= 2, folder.name  # not a single-colour mask
        blocks = re.findall(r"<collision.*?</collision>", urdf, re.S)
        assert blocks
        for block in blocks:
            kind = re.search(r"<geometry>\s*<(\w+)", block).group(1)
            assert kind in ("box", "cylinder", "mesh"), block
            if kind == "mesh":
                mesh_file = re.search(r'filename="([^"]+)"', block).group(1)
                assert trimesh.load(folder / mesh_file).is_convex


def test_handles_contrast_with_their_part(assets):
    checked = 0
    for asset in assets.values():
        for joint in asset.joints.values():
            if joint.type == "fixed" and asset.links[joint.child].label == "handle":
                handle = np.array(asset.links[joint.child].visuals[0].rgba[:3])
                part = np.array(asset.links[joint.parent].visuals[0].rgba[:3])
                lum = np.array([0.2126, 0.7152, 0.0722])
                assert abs(handle @ lum - part @ lum) >= 0.2
                checked += 1
    assert checked > 0


def test_a_top_loading_washer_is_a_variant_a_dataset_never_draws(assets, tmp_path):
    """``TopLoadingWasher`` makes a ``WashingMachine`` whose door is a lid in the top deck, hinged along its back
    edge (a horizontal axis, across the front), opening upwards, with the console standing behind it; it is
    asked for by name only, so adding it leaves every named benchmark's round-robin as it was."""
    assert "TopLoadingWasher" in VARIANTS and "TopLoadingWasher" not in CATEGORIES
    folder = generate_dataset(tmp_path, 1, seed=3, categories=["TopLoadingWasher"], progress=False)[0]
    assert folder.name == "TopLoadingWasher_00000"
    assert json.loads((folder / "meta.json").read_text())["model_cat"] == "WashingMachine"
    asset = assets["TopLoadingWasher_00000"]
    door = next(j for j in asset.movable_joints() if asset.links[j.child].label == "door")
    pivot, axis = asset.joint_frames()[door.name]
    assert abs(axis[1]) == pytest.approx(1.0)  # along the width: front is -X, up is +Z
    lid = asset.mesh(links=[door.child]).vertices
    lo, hi = asset.bounds()
    assert lid[:, 2].min() > hi[2] - 0.25  # a lid on top, not a door in the front
    assert pivot[0] > lid[:, 0].mean() + 0.1  # hinged at its back edge (the front faces -X)
    raised = asset.mesh({door.name: 1.0}, links=[door.child]).vertices
    assert raised[:, 2].max() > lid[:, 2].max() + 0.2  # opening lifts its front edge


def test_same_seed_same_bytes_other_seed_other_object(tmp_path):
    cats = ["StorageFurniture", "Oven", "Faucet", "Door"]
    a = generate_dataset(tmp_path / "a", 4, seed=7, categories=cats, progress=False)
    b = generate_dataset(tmp_path / "b", 4, seed=7, categories=cats, progress=False)
    c = generate_dataset(tmp_path / "c", 4, seed=8, categories=cats, progress=False)
    assert [p.name for p in a] == [p.name for p in b]
    for x, y in zip(a, b):
        assert _files(x) == _files(y)
    assert (tmp_path / "a" / "synth_manifest.json").read_bytes() == (tmp_path / "b" / "synth_manifest.json").read_bytes()
    assert all((x / "mobility.urdf").read_bytes() != (z / "mobility.urdf").read_bytes() for x, z in zip(a, c))


def test_default_cabinet_has_handled_drawer_and_door(tmp_path):
    folder = generate_object("StorageFurniture", 0, tmp_path, "cabinet")
    asset = load_object(folder)
    handled = {asset.links[j.parent].label for j in asset.joints.values()
               if j.type == "fixed" and asset.links[j.child].label == "handle"}
    assert {"drawer", "rotation_door"} <= handled


def test_bad_input(tmp_path):
    with pytest.raises(InputError, match="unknown synth category"):
        generate_object("Spaceship", 0, tmp_path, "x")
    with pytest.raises(InputError, match="unknown synth categories"):
        generate_dataset(tmp_path, 2, categories=["Oven", "Spaceship"], progress=False)
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(InputError, match="refusing to overwrite"):
        generate_object("Box", 0, tmp_path, "mine")
    assert (foreign / "notes.txt").read_text() == "keep me"
    generate_object("Box", 0, tmp_path, "box")
    assert generate_object("Box", 1, tmp_path, "box").is_dir()  # a synth object may be regenerated in place
