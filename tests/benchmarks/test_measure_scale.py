"""``benchmarks/measure_scale.py``'s pure parts: the stratified sample, the bootstrap, the projection to
PartNet-Mobility and the cluster wall time, on made-up rows with known answers (the measuring itself runs
``spark-bench`` for minutes per object and is not run here)."""

from __future__ import annotations

import json
from collections import Counter

import pytest

from benchmarks import measure_scale as ms


def _row(object_id: str, category: str, prepare_s: float, eval_s: float, wall_s: float = 1.0) -> dict:
    return {
        "id": object_id,
        "category": category,
        "load_before": [1.0, 1.0, 1.0],
        "load_after": [1.0, 1.0, 1.0],
        "prepare": {"exit": 0, "cpu_s": prepare_s, "wall_s": wall_s},
        "eval": {"exit": 0, "cpu_s": eval_s, "wall_s": wall_s},
        "sim_pass": True,
        "open_success": 1.0,
        "open_scored": 1,
        "open_total": 1,
        "coacd_calls": 2,
        "sim_coacd_cpu_s": eval_s / 2,
        "timings": {"sim": eval_s / 2, "open": eval_s / 4},
    }


def _failed(object_id: str) -> dict:
    return {
        "id": object_id,
        "category": "Box",
        "load_before": [1.0] * 3,
        "load_after": [1.0] * 3,
        "prepare": {"exit": 1, "cpu_s": 0.5, "wall_s": 0.6, "error": "boom"},
        "error": "prepare: boom",
    }


def test_apportion_is_proportional_with_one_per_category():
    assert ms.apportion({"A": 10, "B": 6, "C": 6, "D": 1}, 8) == {"A": 3, "B": 2, "C": 2, "D": 1}


def test_apportion_with_fewer_draws_than_categories_follows_the_largest_remainder():
    assert ms.apportion({"A": 5, "B": 3, "C": 2}, 2) == {"A": 1, "B": 1, "C": 0}


def test_apportion_never_draws_more_than_there_is():
    assert ms.apportion({"A": 1, "B": 1}, 5) == {"A": 1, "B": 1}
    assert ms.apportion({"A": 1, "B": 20}, 6) == {"A": 1, "B": 5}


def test_the_sample_is_deterministic_stratified_and_round_robin():
    groups = {
        "Bucket": [f"b{i}" for i in range(10)],
        "Safe": [f"s{i}" for i in range(6)],
        "Table": [f"t{i}" for i in range(6)],
        "Box": ["x0", "x1"],
    }
    first = ms.select_sample(groups, 8, seed=3)
    assert first == ms.select_sample({k: list(reversed(v)) for k, v in groups.items()}, 8, seed=3)
    assert len(first) == len(set(first)) == 8
    category = {i: c for c, ids in groups.items() for i in ids}
    assert Counter(category[i] for i in first) == Counter(
        ms.apportion({c: len(v) for c, v in groups.items()}, 8)
    )
    assert len({category[i] for i in first[:4]}) == 4  # a run stopped after 4 objects saw every category
    draws = {tuple(ms.select_sample(groups, 8, seed=s)) for s in range(5)}
    assert len(draws) > 1  # the seed matters


def test_bootstrap_of_a_constant_is_that_constant():
    mean, low, high = ms.bootstrap_mean([7.0] * 5)
    assert (mean, low, high) == pytest.approx((7.0, 7.0, 7.0))


def test_bootstrap_interval_matches_the_normal_approximation():
    mean, low, high = ms.bootstrap_mean([float(v) for v in range(100)], level=0.9, seed=1)
    half = 1.645 * 28.866 / 10  # z(0.95) x the standard error of the mean of 0..99
    assert mean == pytest.approx(49.5)
    assert low == pytest.approx(49.5 - half, abs=0.7)
    assert high == pytest.approx(49.5 + half, abs=0.7)


def test_bootstrap_refuses_no_values():
    with pytest.raises(ValueError):
        ms.bootstrap_mean([])


def test_projection_in_cpu_hours_and_against_the_target():
    rows = [_row(str(i), "Bucket", 36.0, 3564.0) for i in range(4)] + [_failed("9")]
    proj = ms.projection(rows, objects=2346)
    assert proj["n"] == 4  # the failed object is left out
    total = proj["stages"]["total"]
    assert total["mean_s"] == pytest.approx(3600.0)
    assert total["cpu_h"] == pytest.approx(2346.0)
    assert (total["low_h"], total["high_h"]) == pytest.approx((2346.0, 2346.0))
    assert proj["stages"]["prepare"]["cpu_h"] == pytest.approx(36.0 * 2346 / 3600)
    assert proj["over_target"] == pytest.approx(234.6)


def test_projection_under_the_target():
    rows = [_row("a", "Safe", 5.0, 10.0), _row("b", "Safe", 15.0, 0.0)]
    proj = ms.projection(rows, objects=2346)
    assert proj["stages"]["total"]["cpu_h"] == pytest.approx(15.0 * 2346 / 3600)
    assert proj["over_target"] < 1.0
    assert (
        proj["stages"]["prepare"]["low_s"] >= 5.0 - 1e-9
        and proj["stages"]["prepare"]["high_s"] <= 15.0 + 1e-9
    )


def test_projection_of_no_finished_row_is_empty():
    assert ms.projection([_failed("1")])["stages"] == {}


def test_cluster_wall_is_the_shared_cpu_or_the_longest_object():
    assert ms.cluster_wall_h(100.0, 60.0, 4, 16) == pytest.approx(100.0 / 64)
    assert ms.cluster_wall_h(0.01, 7200.0, 16, 16) == pytest.approx(2.0)


def test_category_means_and_shares():
    rows = [
        _row("a", "Safe", 2.0, 10.0),
        _row("b", "Safe", 4.0, 20.0),
        _row("c", "Box", 1.0, 1.0),
        _failed("d"),
    ]
    means = ms.category_means(rows)
    assert set(means) == {"Safe", "Box"}
    assert means["Safe"]["n"] == 2
    assert means["Safe"]["total_s"] == pytest.approx(18.0)
    shares = ms.stage_shares(rows)
    assert shares["prepare_cpu_s"] == pytest.approx(7.0)
    assert shares["sim_coacd_cpu_s"] == pytest.approx(15.5)
    assert shares["eval_sim_wall_s"] == pytest.approx(15.5)


def test_the_report_names_every_row_and_the_verdict():
    rows = [_row("a", "Safe", 36.0, 3564.0, wall_s=10.0), _failed("b")]
    meta = {
        "command": "python -m benchmarks.measure_scale",
        "commit": "abc1234",
        "cores": 2,
        "seed": 0,
        "load_start": [1.0, 1.0, 1.0],
        "load_now": [1.0, 1.0, 1.0],
        "planned": ["a", "b", "c"],
        "started": "now",
    }
    document = {
        "meta": meta,
        "rows": rows,
        "projection": ms.projection(rows),
        "categories": ms.category_means(rows),
        "shares": ms.stage_shares(rows),
    }
    text = ms.markdown(document)
    assert "| a | Safe |" in text and "error: prepare: boom" in text
    assert "2 of 3 planned" in text
    assert "NOT met" in text
    assert "--executor ray" in text


def test_help_runs():
    with pytest.raises(SystemExit) as stop:
        ms.main(["--help"])
    assert stop.value.code == 0


def test_the_conversion_share_is_cold_less_warm_eval():
    rows = [_row("a", "Safe", 10.0, 70.0), _row("b", "Safe", 10.0, 30.0), _row("c", "Box", 5.0, 5.0)]
    rows[0]["eval_warm"] = {"exit": 0, "cpu_s": 20.0, "wall_s": 20.0}
    rows[1]["eval_warm"] = {"exit": 0, "cpu_s": 10.0, "wall_s": 10.0}  # c never ran warm: left out
    shares = ms.stage_shares(rows)
    assert shares["warm_n"] == 2
    assert shares["warm_cold_eval_cpu_s"] == pytest.approx(100.0)
    assert shares["warm_eval_cpu_s"] == pytest.approx(30.0)
    text = " ".join(ms.conversion_lines(shares))
    assert "is 70 CPU s, 58% of those objects' prepare + eval CPU" in text  # 70 / (20 + 100)
    assert ms.conversion_lines(ms.stage_shares(rows[2:])) == []


def test_resume_keeps_finished_rows_and_redoes_the_incomplete(tmp_path, monkeypatch):
    measured = []

    def fake_measure(src, object_id, timeout):
        measured.append(object_id)
        return dict(_row(object_id, "Safe", 1.0, 2.0), eval_warm={"exit": 0, "cpu_s": 1.0, "wall_s": 1.0})

    monkeypatch.setattr(ms, "measure_object", fake_measure)
    out, report = tmp_path / "scale.json", tmp_path / "scale.md"
    common = ["--ids", "a", "b", "c", "--json", str(out), "--results", str(report)]
    assert ms.main(common) == 0
    assert measured == ["a", "b", "c"]
    document = json.loads(out.read_text())
    for row in document["rows"]:
        row["measured_in"] = "an earlier pass"
    document["rows"][1] = _failed("b")  # an error row
    del document["rows"][2]["eval_warm"]  # a row measured before the warm eval
    out.write_text(json.dumps(document))
    measured.clear()
    assert ms.main(common + ["--resume"]) == 0
    assert measured == []  # --resume alone keeps every row
    assert ms.main(common + ["--resume", "--redo-incomplete"]) == 0
    assert measured == ["b", "c"]
    rows = json.loads(out.read_text())["rows"]
    assert [r["id"] for r in rows] == ["a", "b", "c"] and all("error" not in r for r in rows)
    assert "rows kept from it: 1" in report.read_text()  # a
    report.write_text(report.read_text() + ms.NOTES + "\nA person's note.\n")
    assert ms.main(common + ["--report-only"]) == 0
    assert report.read_text().endswith(ms.NOTES + "\nA person's note.\n")
