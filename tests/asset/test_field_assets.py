"""The field's own assets as they ship (issue 43), read from fetched snapshots of their repositories (skipped
cleanly where ``$SPARK_BENCH_FIELD_ASSETS`` names none: ``tests/helpers_field.py``; nothing of them is kept here):

- GenSim2 (``GenSim2/GenSim2``): each of ``dishwasher/11700``, ``drawer/29921``, ``refrigerator/11178`` as Isaac Sim's
  URDF importer wrote it (``mobility/mobility.usd``) reads the joints of its own URDF (the joint frames kept in
  ``fixtures/gensim2_pairs.json``, worked out from the URDF's text: see its ``about``), and scores as itself
  against that URDF: AxisErr <= 0.01 rad, PivotErr <= 0.01, TypeErr 0, CD <= 0.02;
- Meta-World (``Farama-Foundation/Metaworld``) ``drawer.xml`` and LIBERO (``Lifelong-Robot-Learning/LIBERO``)
  ``white_cabinet.xml``: read with their authors' names, opening toward their upper limits, and ``rollout``
  opens them;
- Newton's joint test scenes (``newton-physics/newton``): each reads, or is one error naming the file and the
  joint it cannot map.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers_field import field_snapshot

from spark_bench.data.readers import load_object
from spark_bench.errors import InputError

FIXTURE = json.loads((Path(__file__).parent / "fixtures" / "gensim2_pairs.json").read_text())
PAIRS = sorted(FIXTURE["objects"])
NEWTON_SCENES = "newton/_src/solvers/kamino/_src/models/assets/testing/joints"

pytest.importorskip("pxr")


def gensim2_object(name: str) -> Path:
    return field_snapshot("GenSim2", "assets", "articulated_objs", name, "mobility", "mobility.usd").parents[1]


def _on_line(point, direction, want) -> float:
    """Distance of ``want`` from the line through ``point`` along ``direction``."""
    return float(np.linalg.norm(np.cross(np.asarray(want, float) - point, direction)))


@pytest.mark.parametrize("name", PAIRS)
def test_gensim2_usd_reads_the_joints_of_its_urdf(name, capfd):
    folder, want = gensim2_object(name), FIXTURE["objects"][name]
    usd = load_object(folder / "mobility" / "mobility.usd")
    assert "deprecated version" not in capfd.readouterr().err  # Isaac's crate 0.7.0: read, quietly
    assert usd.meta["usd"]["crate_version"] == "0.7.0"
    assert any(w.startswith("@OmniPBR.mdl@ not found") for w in usd.warnings)  # a warning, not a refusal
    urdf = load_object(folder)
    scale = want["info_json_scale"]  # the folder is read at its real size, the USD as Isaac wrote it
    for joint, frame in want["joints"].items():
        ours = usd.joints[joint]
        assert ours.type == frame["type"]
        assert (ours.lower, ours.upper) == pytest.approx(frame["limits"], abs=1e-6)
        point, direction = usd.joint_frames()[joint]
        assert direction == pytest.approx(frame["axis"], abs=1e-6)
        assert _on_line(point, direction, frame["point"]) < 1e-5
        point, direction = urdf.joint_frames()[joint]
        assert direction == pytest.approx(frame["axis"], abs=1e-6)
        assert _on_line(point, direction, np.asarray(frame["point"]) * scale) < 1e-5
    extra = sorted({j.name for j in usd.movable_joints()} - {j.name for j in urdf.movable_joints()})
    assert extra == want["extra_usd_joints"]


@pytest.mark.parametrize("name", PAIRS)
def test_gensim2_usd_scores_as_its_own_urdf(name):
    from spark_bench.metrics.evaluate import compute_metrics

    folder, want = gensim2_object(name), FIXTURE["objects"][name]
    bounds = FIXTURE["bounds"]
    result = compute_metrics(load_object(folder / "mobility" / "mobility.usd"), load_object(folder))  # 1e5, seed 0
    scores = result.to_dict()
    assert scores["axis_err"] <= bounds["axis_err"] and scores["type_err"] == bounds["type_err"]
    assert scores["pivot_err"] is None or scores["pivot_err"] <= bounds["pivot_err"]
    assert scores["cd"] <= bounds["cd"]
    assert scores["cd"] == pytest.approx(want["measured"]["cd"], abs=0.002)  # the number the fixture keeps
    assert not result.missing_joints and sorted(result.extra_joints) == want["extra_usd_joints"]


@pytest.mark.parametrize("snapshot, path, joint, links", [
    ("Metaworld", "metaworld/assets/objects/drawer.xml", "goal_slidey", {"drawercase_link", "drawer_link"}),
    ("LIBERO", "libero/libero/assets/articulated_objects/white_cabinet.xml", "top_level",
     {"cabinet_top", "cabinet_middle", "cabinet_bottom"}),
])
def test_robot_learning_drawers_open_toward_their_upper_limit(snapshot, path, joint, links, capsys):
    from spark_bench import cli

    file = field_snapshot(snapshot, path)
    asset = load_object(file)
    assert links <= set(asset.links) and asset.joints[joint].type == "prismatic"
    assert asset.joints[joint].upper == pytest.approx(0.16, abs=1e-6)
    found = {o["joint"]: o for o in asset.meta["opening_direction"]}[joint]
    assert found["opens_toward"] == "lower"
    code = cli.main(["rollout", "--env", "SparkDrawer-v0", "--asset", str(file), "--joint", joint,
                     "--episodes", "1", "--json"])
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 0 and result["success_rate"] == 1.0 and "reason" not in result, result


def test_newton_joint_scenes_read_or_say_why():
    scenes = sorted(field_snapshot("newton", NEWTON_SCENES).glob("test_*/test_*.usda"))
    assert scenes
    read, refused = [], []
    for scene in scenes:
        try:
            asset = load_object(scene)
            read.append((scene.parent.name, sorted(j.type for j in asset.joints.values())))
        except InputError as exc:
            message = str(exc)
            assert str(scene) in message and "\n" not in message and "joint /" in message, message
            refused.append(scene.parent.name)
    assert ("test_revolute", ["continuous"]) in read and ("test_prismatic", ["prismatic"]) in read
    assert {"test_spherical", "test_universal"} <= set(refused)
