"""``eval --protocol`` and ``leaderboard --protocol``: each case scored as a paper's code scores it, stored in
the row, and the paper's own table made from the rows."""

from __future__ import annotations

from dataclasses import replace

import pytest
from helpers_bench import FAST, make_tiny_bench

from spark_bench.cli import main
from spark_bench.evaluation.runner import run_eval
from spark_bench.evaluation.store import ResultsStore
from spark_bench.evaluation.tasks import EvalOptions
from spark_bench.methods.base import MethodSpec


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """A tiny benchmark evaluated by the oracle under two protocols and by the geometry baseline without."""
    root = tmp_path_factory.mktemp("protocols")
    bench = make_tiny_bench(root)
    db = root / "r.sqlite"
    options = replace(FAST, protocols=("urdf-anything", "real2code"))
    run_eval(MethodSpec.create("oracle"), str(bench), options, db=db, workers=0, runs_root=root / "runs",
             progress=False)
    run_eval(MethodSpec.create("geometry"), str(bench), FAST, db=db, workers=0, runs_root=root / "runs",
             progress=False)
    return bench, db


def test_rows_carry_each_protocols_numbers_under_the_papers_names(scored):
    _, db = scored
    with ResultsStore(db) as store:
        oracle = store.rows(bench="tiny", label="oracle")
        geometry = store.rows(bench="tiny", label="geometry")
    assert len(oracle) == 3
    for row in oracle:
        protocols = row["metrics"]["protocols"]
        assert set(protocols) == {"urdf-anything", "real2code"}
        # the ground truth against itself: every joint a success; Real2Code's axis error is in degrees
        assert protocols["urdf-anything"]["metrics"]["joint_success_rate"] == pytest.approx(1.0)
        assert protocols["real2code"]["units"]["axis_err"] == "deg"
        assert protocols["real2code"]["metrics"]["axis_err"] == pytest.approx(0.0, abs=1e-4)
    assert all("protocols" not in row["metrics"] for row in geometry)


def test_a_run_without_protocols_keeps_its_identity():
    """Runs made before protocols existed are the same runs (their results key does not move)."""
    assert "protocols" not in EvalOptions().identity()
    assert EvalOptions(protocols=("cage",)).identity()["protocols"] == ["cage"]


def test_leaderboard_prints_the_papers_table_with_its_coverage(scored, capsys):
    _, db = scored
    assert main(["leaderboard", "--db", str(db), "--protocol", "urdf-anything"]) == 0
    text = capsys.readouterr().out
    assert "## urdf-anything" in text and "| oracle |" in text
    assert "oracle (regime: ground truth): 3 cases scored, 0 without" in text
    assert "geometry" in text.split("Coverage:")[1]  # evaluated without the protocol: said, not hidden
    assert main(["leaderboard", "--db", str(db), "--protocol", "urdf-anything", "--format", "csv"]) == 0
    csv_text = capsys.readouterr().out
    assert csv_text.startswith("# protocol: urdf-anything") and "\noracle," in csv_text


def test_a_protocol_no_row_was_scored_under_is_an_error(scored, capsys):
    _, db = scored
    assert main(["leaderboard", "--db", str(db), "--protocol", "cage"]) == 2
    assert "eval ... --protocol cage" in capsys.readouterr().err


def test_an_unknown_protocol_is_refused_before_any_case_runs(tmp_path, capsys):
    code = main(["eval", "--method", "oracle", "--bench", str(tmp_path / "nowhere"), "--protocol", "paper-x",
                 "--db", str(tmp_path / "r.sqlite"), "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert "paper-x" in err and "articulate-anything" in err
