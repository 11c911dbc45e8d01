"""FreeArt3D's PivotErr rule end to end, the two averages (per object, over joints), the GAPartNet part
class carried per joint, and their aggregation in the eval summary."""

from __future__ import annotations

import json

import pytest
from helpers_assets import box_cabinet

from spark_bench import CONVENTION_VERSION
from spark_bench.errors import SparkBenchError
from spark_bench.evaluation.aggregate import by_part_class, summarize
from spark_bench.metrics import compute_metrics
from spark_bench.metrics.report import joint_errors, mean_by_part_class, mean_over_joints, mean_over_objects


def test_revolute_predicted_as_prismatic_has_a_pivot_error():
    """The door, predicted as a slider along its hinge line moved 0.2 off: PivotErr 0.2 (it was left out before
    FreeArt3D's rule), TypeErr counts it, the drawer (a ground-truth slider) has no pivot."""
    result = compute_metrics(box_cabinet(handle=True, door_type="prismatic", door_pivot=(-0.7, -0.5, 0.0)),
                             box_cabinet(handle=True), n_samples=3000, n_match_samples=1000)
    door, drawer = result.matches
    assert door.gt_joint == "door_joint" and door.pred_type == "prismatic"
    assert door.pivot_err == pytest.approx(0.2, abs=1e-9) and not door.type_match
    assert drawer.pivot_err is None
    d = result.to_dict()
    assert d["pivot_err"] == pytest.approx(0.2, abs=1e-9) and d["type_err"] == 0.5
    assert d["joint_mean"] == {"axis_err": pytest.approx(0.0, abs=1e-12), "pivot_err": pytest.approx(0.2, abs=1e-9),
                               "type_err": 0.5}
    assert d["convention"] == CONVENTION_VERSION == "spark-bench-conv-11"


def test_part_classes_per_joint_from_gapartnet_annotations():
    result = compute_metrics(box_cabinet(handle=True, with_drawer=False),
                             box_cabinet(handle=True, annotate=True), n_samples=2000, n_match_samples=1000)
    assert result.part_classes == {"door_joint": "hinge_door", "drawer_joint": "slider_drawer"}
    assert [(m.gt_joint, m.gt_part_class) for m in result.matches] == [("door_joint", "hinge_door")]
    d = json.loads(json.dumps(result.to_dict()))  # as a results row stores it
    assert d["missing_joints"] == ["drawer_joint"] and d["matching"][0]["gt_part_class"] == "hinge_door"
    records = joint_errors(d)
    assert [(r["gt_joint"], r["part_class"], r["type_err"]) for r in records] == [
        ("door_joint", "hinge_door", 0.0), ("drawer_joint", "slider_drawer", 1.0)]
    assert mean_by_part_class(records) == {
        "hinge_door": {"axis_err": 0.0, "pivot_err": 0.0, "type_err": 0.0, "n_joints": 1},
        "slider_drawer": {"axis_err": None, "pivot_err": None, "type_err": 1.0, "n_joints": 1}}
    result = compute_metrics(box_cabinet(handle=True), box_cabinet(handle=True), n_samples=1000,
                             n_match_samples=500)
    assert result.part_classes == {}


def _metrics(*joints, missing=()) -> dict:
    """A stored metrics dict: ``joints`` as (axis_err, pivot_err, type_match, part class)."""
    matching = [{"gt_joint": f"j{k}", "axis_err": a, "pivot_err": p, "type_match": t, "gt_part_class": c}
                for k, (a, p, t, c) in enumerate(joints)]
    n = len(joints) + len(missing)
    wrong = len(missing) + sum(not t for _, _, t, _ in joints)
    pivots = [p for _, p, _, _ in joints if p is not None]
    return {"matching": matching, "missing_joints": list(missing), "gt_part_classes": {},
            "axis_err": sum(a for a, _, _, _ in joints) / len(joints),
            "pivot_err": sum(pivots) / len(pivots) if pivots else None, "type_err": wrong / n}


# one object with one door, one with three joints (a drawer without pivot) and a missing one
OBJ_A = _metrics((0.6, 0.3, True, "hinge_door"))
OBJ_B = _metrics((0.0, 0.1, True, "hinge_door"), (0.3, None, False, "slider_drawer"), (0.0, 0.7, True, None),
                 missing=["m"])


def test_per_object_and_per_joint_means_by_hand():
    out = mean_over_objects([OBJ_A, OBJ_B])
    # per object then over objects: axis (0.6 + 0.1) / 2, pivot (0.3 + 0.4) / 2, type (0 + 0.5) / 2
    assert out["axis_err"] == pytest.approx(0.35) and out["pivot_err"] == pytest.approx(0.35)
    assert out["type_err"] == pytest.approx(0.25)
    # over joints: axis (0.6 + 0 + 0.3 + 0) / 4, pivot (0.3 + 0.1 + 0.7) / 3, type 2 wrong of 5
    assert out["joint_mean"] == {"axis_err": pytest.approx(0.225), "pivot_err": pytest.approx(1.1 / 3),
                                 "type_err": pytest.approx(0.4)}
    assert mean_over_joints([]) == {"axis_err": None, "pivot_err": None, "type_err": None}


def _store_row(case_id, metrics, status="ok", convention=CONVENTION_VERSION) -> dict:
    return {"case_id": case_id, "status": status, "convention": convention, "metrics": metrics,
            "axis_err": metrics.get("axis_err"), "pivot_err": metrics.get("pivot_err"),
            "type_err": metrics.get("type_err")}


def test_summary_carries_joint_mean_and_part_classes():
    rows = [_store_row("a", OBJ_A), _store_row("b", OBJ_B),
            _store_row("c", {"matching": [{"axis_err": 9.0}]}, status="failed")]
    summary = summarize(rows, sim=False)
    assert summary["axis_err"] == pytest.approx(0.35) and summary["type_err"] == pytest.approx(0.25)
    assert summary["joint_mean"]["axis_err"] == pytest.approx(0.225)  # the failed case enters neither
    assert summary["pivot_err"] == pytest.approx(0.35) and summary["joint_mean"]["pivot_err"] == pytest.approx(1.1 / 3)
    assert summary["joint_mean"]["type_err"] == pytest.approx(0.4)
    classes = by_part_class(rows)
    assert classes["hinge_door"] == {"axis_err": pytest.approx(0.3), "pivot_err": pytest.approx(0.2),
                                     "type_err": 0.0, "n_joints": 2}
    assert classes["slider_drawer"]["type_err"] == 1.0 and set(classes) == {"hinge_door", "slider_drawer"}


def test_rows_of_two_conventions_are_not_averaged():
    rows = [_store_row("a", OBJ_A), _store_row("b", OBJ_B, convention="spark-bench-conv-1")]
    with pytest.raises(SparkBenchError, match="different metric conventions"):
        summarize(rows, sim=False)


@pytest.mark.real
def test_cli_json_joint_mean_and_part_classes_on_a_real_object(real_object, capsys):
    from spark_bench.cli import main

    folder = real_object("45780")  # a GAPartNet-annotated cabinet with two hinged doors
    assert main(["metrics", "--pred", str(folder), "--gt", str(folder), "--json", "--samples", "2000",
                 "--match-samples", "1000"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["joint_mean"] == {"axis_err": 0.0, "pivot_err": 0.0, "type_err": 0.0}
    assert d["gt_part_classes"] == {"joint_0": "hinge_door", "joint_1": "hinge_door"}
    assert [m["gt_part_class"] for m in d["matching"]] == ["hinge_door", "hinge_door"]
