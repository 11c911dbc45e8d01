"""The joint protocols (Articulate-Anything, URDF-Anything, Real2Code, spark) against the numbers the papers'
own code produced (fixtures written by ``python -m benchmarks.protocols.parity_joint``) and on perturbations with
known answers; the registry and ``spark-bench metrics --protocol``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers_assets import tiny_cabinet

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.cli import main
from spark_bench.errors import SparkBenchError
from spark_bench.metrics.protocols import PROTOCOLS, protocol_names, score
from spark_bench.metrics.protocols import articulate_anything as aa
from spark_bench.metrics.protocols import real2code as r2c
from spark_bench.metrics.protocols import urdf_anything as ua
from spark_bench.metrics.protocols.joints import joint_records, record_from_dict

FIXTURES = Path(__file__).parent / "fixtures" / "protocols_joint"
CASES = json.loads((FIXTURES / "cases.json").read_text())
CHAMFERS = json.loads((FIXTURES / "chamfer.json").read_text())
TOLERANCE = 1e-9
JOINT_SUCCESS = {"articulate-anything": "joint_success_rate", "urdf-anything": "joint_success_rate"}


@pytest.fixture(autouse=True)
def _few_samples(monkeypatch):
    """Real2Code's 100,000 samples per mesh and the matching's 10,000 per part are not needed on boxes."""
    from spark_bench.metrics.protocols import joints

    monkeypatch.setattr(r2c, "N_SAMPLES", 2_000)
    monkeypatch.setattr(joints, "MATCH_SAMPLES", 1_000)


def _records(case: dict):
    gt = {d["name"]: record_from_dict(d) for d in case["gt"]}
    pred = {d["name"]: record_from_dict(d) for d in case["pred"]}
    return gt, pred


def _close(ours, paper) -> bool:
    if paper is None:
        return ours is None
    return ours is not None and abs(ours - paper) <= TOLERANCE


# ----- parity with the papers' code -----------------------------------------------------------------
@pytest.mark.parametrize("case", CASES, ids=[c["case"] for c in CASES])
def test_articulate_anything_matches_its_code(case):
    gt, pred = _records(case)
    for entry in case["aa"]:
        g = gt[entry["gt"]]
        diff = aa.joint_diff(g, pred[case["matched"][g.name]])
        assert _close(diff["joint_axis"], entry["joint_axis"])
        assert _close(diff["joint_origin"]["xyz"], entry["xyz"])
        assert _close(diff["joint_origin"]["orientation"], entry["orientation"])
        assert _close(diff["joint_limit"]["direction_diff"], entry["direction_diff"])
        assert _close(diff["joint_limit"]["range_diff"], entry["range_diff"])
        assert diff["joint_type"] == entry["joint_type"]
        assert aa.failure_reason(diff, g.type) == entry["reason"]


@pytest.mark.parametrize("case", CASES, ids=[c["case"] for c in CASES])
def test_urdf_anything_matches_its_code(case):
    gt, pred = _records(case)
    pairs = [(g, pred.get(case["matched"].get(name, ""))) for name, g in gt.items()]
    ours = ua.articulation_metrics(pairs, len(pred))
    for key, value in case["ua"]["rates"].items():  # eval_root rounds its rates to 4 decimals
        assert round(ours[key], 4) == pytest.approx(value, abs=TOLERANCE), key
    for key, value in case["ua"]["means"].items():
        assert _close(ours[key], value), key
    for entry in case["ua"]["per_joint"]:
        joint = ua.joint_entry(gt[entry["gt"]], pred[case["matched"][entry["gt"]]])
        assert _close(joint["axis_err"], entry["axis"])
        assert _close(joint["xyz"], entry["xyz"])
        assert _close(joint["orientation"], entry["orientation"])


@pytest.mark.parametrize("case", CASES, ids=[c["case"] for c in CASES])
def test_real2code_joints_match_its_code(case):
    gt, pred = _records(case)
    ours = r2c.best_permutation(list(pred.values()), list(gt.values()))
    assert [p.name for p, _, _ in ours] == case["r2c"]["pairs"][:len(ours)]
    for (_, _, errors), paper in zip(ours, case["r2c"]["errors"]):
        assert errors["type"] == paper["type"]
        if paper["rot_is_nan"]:  # its unclipped arccos of a dot product that rounds above 1: 0 here
            assert errors["rot"] == pytest.approx(0.0, abs=1e-6)
        else:
            assert _close(errors["rot"], paper["rot"])
        assert _close(errors["pos"], paper["pos"])


@pytest.mark.parametrize("entry", CHAMFERS, ids=[c["case"] for c in CHAMFERS])
def test_real2code_chamfer_matches_its_code(entry):
    chamfer, chamfer_norm = r2c.squared_chamfer(np.asarray(entry["gt_points"]), np.asarray(entry["pred_points"]))
    assert chamfer == pytest.approx(entry["chamfer"], rel=1e-9, abs=1e-12)
    assert chamfer_norm == pytest.approx(entry["chamfer_norm"], rel=1e-9, abs=1e-12)


def test_fixtures_cover_the_known_answers():
    """The recorded papers' verdicts: 0.2 rad passes, 0.3 rad fails, a wrong type fails."""
    reasons = {}
    for case in CASES:
        kind = case["case"].split("/")[1]
        reasons.setdefault(kind, set()).update(e["reason"] for e in case["aa"])
    assert reasons["axis0.2"] == {"success"} and reasons["axis0.3"] == {"joint_axis"}
    assert reasons["type"] == {"joint_type"} and reasons["self"] == {"success"}


# ----- known perturbations on an asset ------------------------------------------------------------------
def _axes_tilted(asset, angle: float):
    out = asset.copy()
    for joint in out.movable_joints():
        axis = np.asarray(joint.axis, dtype=float)
        helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
        normal = np.cross(axis, helper)
        joint.axis = axis_angle_matrix(normal / np.linalg.norm(normal), angle) @ axis
    return out


def _swapped_types(asset):
    out = asset.copy()
    for joint in out.movable_joints():
        joint.type = "prismatic" if joint.is_rotational else "revolute"
    return out


@pytest.mark.parametrize("name", ["articulate-anything", "urdf-anything"])
def test_axis_turned_by_02_passes_and_03_fails(name):
    gt = tiny_cabinet()
    assert score(name, _axes_tilted(gt, 0.2), gt).metrics[JOINT_SUCCESS[name]] == 1.0
    failed = score(name, _axes_tilted(gt, 0.3), gt).metrics
    assert failed[JOINT_SUCCESS[name]] == 0.0
    if name == "urdf-anything":
        assert failed["axis_within"] == 0.0
    else:
        assert failed["failure_joint_axis"] == 1.0


def test_wrong_type_fails_every_joint_success_rule():
    gt = tiny_cabinet()
    pred = _swapped_types(gt)
    aa_metrics, ua_metrics = score("articulate-anything", pred, gt).metrics, score("urdf-anything", pred, gt).metrics
    assert aa_metrics["joint_success_rate"] == 0.0 and aa_metrics["failure_joint_type"] == 1.0
    assert ua_metrics["joint_success_rate"] == 0.0 and ua_metrics["type_correct"] == 0.0
    assert score("real2code", pred, gt).metrics["type_acc"] == 0.0


def test_continuous_counts_as_a_type_error_for_urdf_anything_but_not_for_real2code():
    gt = tiny_cabinet()
    pred = gt.copy()
    pred.joints["joint_door"].type = "continuous"
    assert score("urdf-anything", pred, gt).metrics["type_correct"] == 0.5
    assert score("real2code", pred, gt).metrics["type_acc"] == 1.0


@pytest.mark.parametrize("name", ["articulate-anything", "urdf-anything", "real2code"])
def test_self_pair_scores_perfectly(name):
    gt = tiny_cabinet()
    metrics = score(name, gt, gt).metrics
    for key in ("joint_success_rate", "type_correct", "axis_within", "origin_within", "type_acc",
                "link_placement_success"):
        if key in metrics:
            assert metrics[key] == 1.0, key
    for key in ("axis_err", "pivot_err", "chamfer", "chamfer_norm", "part_chamfer", "missing_rate"):
        if key in metrics:
            assert metrics[key] == pytest.approx(0.0, abs=1e-7), key


def test_real2code_axis_error_is_in_degrees():
    gt = tiny_cabinet()
    gt.joints["joint_drawer"].type = "fixed"  # one joint: no permutation to choose
    result = score("real2code", _axes_tilted(gt, 0.2), gt)
    assert result.metrics["rot_err_deg"] == pytest.approx(np.degrees(0.2), rel=1e-9)
    assert result.metrics["axis_err"] == result.metrics["rot_err_deg"]
    assert result.units["rot_err_deg"] == "deg"


def test_real2code_permutation_cost_prefers_a_type_swap_to_a_few_degrees():
    """Real2Code's quirk, reproduced: its permutation cost adds degrees to (1 - type accuracy), so two
    joints each 0.2 rad (11.5 degrees) off cost more than two type failures (cost 1/3): it pairs the
    drawer with the door."""
    gt = tiny_cabinet()
    result = score("real2code", _axes_tilted(gt, 0.2), gt)
    assert result.metrics["type_acc"] == 0.0 and result.metrics["rot_err_deg"] is None


def test_a_missing_joint_fails_under_both_rules():
    gt = tiny_cabinet()
    pred = gt.copy()
    pred.joints["joint_drawer"].type = "fixed"
    ua_metrics = score("urdf-anything", pred, gt).metrics
    assert ua_metrics["missing_rate"] == 0.5 and ua_metrics["joint_success_rate"] == 0.5
    aa_metrics = score("articulate-anything", pred, gt).metrics
    assert aa_metrics["failure_no_valid_result"] == 0.5 and aa_metrics["prismatic_success_rate"] == 0.0


def test_pivot_moved_along_the_papers_fallback_direction():
    """Parallel axes: AA's distance is the offset along ``a x (1, 0, 0)``; a move of 0.04 there gives
    (0.04 + 0) / 2 = 0.02 <= 0.05 (success), a move of 0.12 gives 0.06 (origin failure)."""
    gt = tiny_cabinet()
    for move, reason in ((0.04, "success"), (0.12, "joint_origin")):
        pred = gt.copy()
        door = pred.joints["joint_door"]
        door.origin = door.origin.copy()
        door.origin[:3, 3] += np.array([0.0, 1.0, 0.0]) * move  # z x (1, 0, 0) = (0, 1, 0)
        records = {r.name: r for r in joint_records(pred)}
        g = {r.name: r for r in joint_records(gt)}["joint_door"]
        diff = aa.joint_diff(g, records["joint_door"])
        assert diff["joint_origin"]["xyz"] == pytest.approx(move, abs=1e-12)
        assert aa.failure_reason(diff, "revolute") == reason


# ----- registry and command line ---------------------------------------------------------------------------
def test_protocol_names_expand_all_and_reject_unknown_ones():
    assert protocol_names(["all"]) == list(PROTOCOLS)
    assert protocol_names(["real2code", "spark", "real2code"]) == ["real2code", "spark"]
    with pytest.raises(SparkBenchError, match="known: all, articulate-anything"):
        protocol_names(["articulate_anything"])


def test_spark_protocol_reports_compute_metrics_unchanged(monkeypatch):
    from spark_bench.metrics import evaluate

    original = evaluate.compute_metrics
    monkeypatch.setattr(evaluate, "compute_metrics", lambda p, g, seed=0: original(p, g, n_samples=3_000, seed=seed))
    gt, pred = tiny_cabinet(), _axes_tilted(tiny_cabinet(), 0.2)
    result = score("spark", pred, gt)
    expected = original(pred, gt, n_samples=3_000).to_dict()
    for key in ("cd", "fscore@0.1", "axis_err", "pivot_err", "type_err", "part_cd"):
        assert result.metrics[key] == pytest.approx(expected[key], abs=1e-12), key
    assert result.metrics["axis_err"] == pytest.approx(0.2, abs=1e-9)
    assert "joint_success_rate" not in result.metrics


def test_cli_protocol_json_and_unknown_name(tmp_path, capsys):
    from spark_bench.asset.urdf import write_object_folder

    folder = tmp_path / "obj"
    write_object_folder(tiny_cabinet(), folder)
    args = ["metrics", "--pred", str(folder), "--gt", str(folder)]
    assert main([*args, "--protocol", "urdf-anything", "--json"]) == 0
    one = json.loads(capsys.readouterr().out)
    assert one["protocol"] == "urdf-anything" and one["metrics"]["joint_success_rate"] == 1.0
    assert main([*args, "--protocol", "urdf-anything", "--protocol", "articulate-anything", "--json"]) == 0
    several = json.loads(capsys.readouterr().out)
    assert [r["protocol"] for r in several] == ["urdf-anything", "articulate-anything"]
    assert main([*args, "--protocol", "nope"]) == 2
    assert "known: all, articulate-anything" in capsys.readouterr().err
    assert main([*args, "--samples", "1000", "--match-samples", "500", "--json"]) == 0  # no --protocol: as before
    assert "protocol" not in json.loads(capsys.readouterr().out)


# ----- the tables "as each paper reports it" -------------------------------------------------------------
def test_tables_pool_rates_over_joints_and_name_the_papers_columns():
    from spark_bench.metrics.protocols.tables import pooled, protocol_table

    one = {"protocol": "urdf-anything", "metrics": {"joint_success_rate": 1.0, "num_gt_joints": 1.0,
                                                     "type_correct": 1.0, "axis_angle_error_rad": 0.1}}
    three = {"protocol": "urdf-anything", "metrics": {"joint_success_rate": 0.0, "num_gt_joints": 3.0,
                                                       "type_correct": 1.0, "axis_angle_error_rad": 0.3}}
    numbers = pooled("urdf-anything", [one, three])
    assert numbers["joint_success_rate"] == pytest.approx(0.25)  # 1 of 4 joints, not the mean 0.5
    assert numbers["axis_angle_error_rad"] == pytest.approx(0.2)
    markdown = protocol_table({"ours": [one, three]}, "urdf-anything")
    assert markdown.splitlines()[0] == ("| Method | Type | Axis | Origin | Success | Axis err (rad) | "
                                         "Origin err |")
    assert "| ours | 1 | – | – | 0.25 | 0.2 | – |" in markdown and "URDF-Anything_CODE" in markdown
    for fmt, mark in (("latex", r"\toprule"), ("html", "<th>Success</th>"), ("csv", "Method,Type,Axis")):
        assert mark in protocol_table({"ours": [one, three]}, "urdf-anything", fmt)
    with pytest.raises(SparkBenchError, match="in the real2code table"):
        protocol_table({"ours": [one]}, "real2code")


@pytest.mark.parametrize("case", CASES, ids=[c["case"] for c in CASES])
def test_articulate_anything_link_placement_matches_its_code(case):
    paper = case["aa_links"]
    ours = aa.link_placement(paper["poses"])
    assert _close(ours["link_position_diff"], paper["position_diff"])
    if paper["orientation_is_nan"]:
        # its arccos of |q1.q2| rounding above 1 gives NaN, and NaN < 0.05 fails the link; 0 here
        assert ours["link_orientation_diff"] == pytest.approx(0.0, abs=1e-7)
        return
    for key in ("orientation_diff", "average_diff"):
        assert _close(ours[f"link_{key}"], paper[key]), key
    assert ours["link_placement_success"] == paper["success"]
