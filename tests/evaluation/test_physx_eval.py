"""``eval --engine mujoco|physx|all`` and the PhysX column of the leaderboard (issue #44): the default keeps a run's
identity and rows as they were; a run with PhysX is a run of its own whose rows carry PhysX's verdict
(``checks["sim_physx"]``) beside MuJoCo's; the board shows "Sim pass (PhysX)" with its coverage only where some row
has a PhysX verdict, in every format. The eval run with PhysX skips without SAPIEN.
"""

from __future__ import annotations

import csv
import io

import pytest
from helpers_bench import make_tiny_bench

from spark_bench import CONVENTION_VERSION
from spark_bench.evaluation.aggregate import summarize
from spark_bench.evaluation.leaderboard import build_leaderboard, render, to_csv, to_latex, to_markdown
from spark_bench.evaluation.runner import EvalOptions, run_eval, run_identity
from spark_bench.evaluation.store import ResultsStore
from spark_bench.methods.base import MethodSpec

BOTH = ("mujoco", "physx")


def test_the_default_engine_keeps_the_run_identity_and_physx_makes_a_run_of_its_own():
    plain = EvalOptions(n_samples=2000)
    assert "engines" not in plain.identity()  # as before engines existed: the stored runs keep their hash
    assert plain.identity() == {"sim": True, "rl": False, "n_samples": 2000, "seed": 0, "align": "none"}
    assert EvalOptions(n_samples=2000, engines=("mujoco",)).identity() == plain.identity()
    assert EvalOptions(n_samples=2000, engines=BOTH).identity()["engines"] == ["mujoco", "physx"]
    hashes = {engines: run_identity("b", MethodSpec.create("oracle"), EvalOptions(n_samples=2000, engines=engines))
              .config_hash for engines in (("mujoco",), BOTH, ("physx",))}
    assert len(set(hashes.values())) == 3
    assert not plain.physx and EvalOptions(engines=("physx",)).physx
    assert not EvalOptions(sim=False, engines=BOTH).physx


def _row(label: str, case_id: str, physx: bool | None = None, status: str = "ok", config_hash: str = "h",
         finished_at: float = 1.0) -> dict:
    checks = {"sim": {"passed": True}}
    if physx is not None:
        checks["sim_physx"] = {"passed": physx, "checks": {"joint_sweep": {"passed": physx, "value": 0.5}}}
    row = {"bench": "b", "case_id": case_id, "category": "Cab", "method": label, "label": label, "variant": "",
           "regime": "image", "config_hash": config_hash, "status": status, "finished_at": finished_at,
           "sim_pass": True, "open_success": 1.0, "convention": CONVENTION_VERSION, "checks": checks}
    if status == "failed":
        row.update(stage="generate", reason="boom", sim_pass=None, open_success=None, checks={})
    return row


def test_the_physx_rate_counts_failed_cases_as_not_passed_and_its_coverage_the_cases_with_a_verdict():
    rows = [_row("B", "c1", True), _row("B", "c2", False), _row("B", "c3", status="failed")]
    summary = summarize(rows, physx=True)
    assert summary["sim_pass_rate_physx"] == pytest.approx(1 / 3)
    assert summary["physx_coverage"] == {"with_verdict": 2, "cases": 3}
    # a case whose worker had no SAPIEN has no verdict: out of the rate, seen in the coverage
    skipped = [_row("C", "c1", True), {**_row("C", "c2"), "checks": {"sim_physx": {"skipped": "no sapien"}}}]
    assert summarize(skipped, physx=True)["sim_pass_rate_physx"] == 1.0
    assert summarize(skipped, physx=True)["physx_coverage"] == {"with_verdict": 1, "cases": 2}
    without = summarize([_row("A", "c1")], physx=True)
    assert without["sim_pass_rate_physx"] is None and without["physx_coverage"] is None
    assert "sim_pass_rate_physx" not in summarize(rows) and "physx_coverage" not in summarize(rows)


def test_the_board_shows_the_physx_column_with_its_coverage_only_where_a_row_has_a_verdict(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([_row("A", "c1"), _row("A", "c2")])
        store.put([_row("B", "c1", True), _row("B", "c2", False), _row("B", "c3", status="failed")])
        store.put([_row("C", "c1", True), _row("C", "c2")])
        board = build_leaderboard(store, bench="b")
        mujoco_only = build_leaderboard(store, bench="b", labels=["A"])
    sim = board.tables()[2]
    assert sim.metrics[:3] == ("sim_pass_rate", "sim_pass_rate_physx", "open_success_rate")
    assert sim.count_headers()[:3] == ["Cases", "Failed", "PhysX cases"]
    cells = {e.name: sim.count_cells(e)[2] for e in sim.entries}
    assert cells == {"A": "n/a", "B": "2/3", "C": "1/2"}
    md = to_markdown(board)
    assert "| Sim pass↑ | Sim pass (PhysX)↑ | Open success↑ |" in md
    assert "| B | image | _0.6667_ | _0.3333_ |" in md and "| C | image | **1.0000** | **1.0000** |" in md
    assert "| A | image | **1.0000** | n/a |" in md and "Sim pass (PhysX): the same sim-readiness checks" in md
    tex = to_latex(board)
    assert r"Sim pass (PhysX)$\uparrow$" in tex
    assert "Sim pass (PhysX) over the cases with a PhysX verdict: A n/a, B 2/3, C 1/2." in tex
    lines = {r["label"]: r for r in csv.DictReader(io.StringIO(to_csv(board)))}
    assert float(lines["B"]["sim_pass_rate_physx"]) == pytest.approx(1 / 3) and lines["A"]["sim_pass_rate_physx"] == "n/a"
    assert (lines["B"]["physx_coverage_with_verdict"], lines["B"]["physx_coverage_cases"]) == ("2", "3")
    page = render(board, "html", out=tmp_path / "board" / "index.html", max_cases=0)
    assert "<th>Sim pass (PhysX)↑</th>" in page and "<td>2/3</td>" in page
    # a board of runs without PhysX: no column, no coverage, no note, no CSV columns (as before PhysX)
    assert "PhysX" not in to_markdown(mujoco_only) + to_latex(mujoco_only)
    header = to_csv(mujoco_only).splitlines()[0]
    assert "physx" not in header and header.split(",")[17:19] == ["sim_pass_rate", "open_success_rate"]


def test_eval_engine_all_stores_physx_beside_mujoco_in_a_run_of_its_own(tmp_path, isolated_home):
    from spark_bench.sim.physx import sapien_available

    if not sapien_available():
        pytest.skip('sapien is not installed (pip install -e ".[physx]")')
    bench = make_tiny_bench(tmp_path, n=1)
    db, runs = tmp_path / "r.sqlite", tmp_path / "runs"
    plain = run_eval(MethodSpec.create("oracle"), str(bench), EvalOptions(n_samples=2000), db=db, workers=0,
                     runs_root=runs, progress=False)
    both = run_eval(MethodSpec.create("oracle"), str(bench), EvalOptions(n_samples=2000, engines=BOTH), db=db,
                    workers=0, runs_root=runs, progress=False)
    assert "sim_pass_rate_physx" not in plain.metrics and "physx_coverage" not in plain.metrics
    assert plain.run.config_hash != both.run.config_hash and both.n_skipped == 0
    with ResultsStore(db) as store:
        (mujoco_row,) = store.rows(where=[("config_hash", plain.run.config_hash)])
        (physx_row,) = store.rows(where=[("config_hash", both.run.config_hash)])
        board = build_leaderboard(store)
    assert "sim_physx" not in mujoco_row["checks"] and "sim_physx" not in mujoco_row["timings"]
    # MuJoCo's verdict is the same in both runs; PhysX's sits beside it with a verdict per check
    assert physx_row["sim_pass"] == mujoco_row["sim_pass"] is not None
    mujoco_checks = {k: c["passed"] for k, c in mujoco_row["checks"]["sim"]["checks"].items()}
    assert {k: c["passed"] for k, c in physx_row["checks"]["sim"]["checks"].items()} == mujoco_checks
    physx = physx_row["checks"]["sim_physx"]
    assert set(physx["checks"]) == {"mesh_files", "physx_loads", "mass_inertia", "joint_limits", "rest_stability",
                                    "rest_penetration", "joint_sweep"}  # the store keeps JSON keys sorted
    assert physx["passed"] == all(c["passed"] for c in physx["checks"].values()) and physx["sapien"].startswith("3.")
    assert physx["checks"]["joint_sweep"]["verdict_by"] == ["contact"]
    assert both.metrics["sim_pass_rate_physx"] == float(physx["passed"])
    assert both.metrics["physx_coverage"] == {"with_verdict": 1, "cases": 1}
    (entry,) = board.entries  # the run with PhysX, the label's latest; the MuJoCo-only rows stay in the store
    assert entry.config_hash == both.run.config_hash and board.has_stage("physx")
    assert "| 1 | 0 | 1/1 |" in to_markdown(board)


def test_eval_engine_physx_needs_the_sim_stage_and_sapien(tmp_path, isolated_home, capsys, monkeypatch):
    import sys

    from spark_bench.cli import main

    bench = make_tiny_bench(tmp_path, n=1)
    assert main(["eval", "--method", "oracle", "--bench", str(bench), "--engine", "all", "--no-sim"]) == 2
    assert "--no-sim" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "sapien", None)  # SAPIEN not installed
    assert main(["eval", "--method", "oracle", "--bench", str(bench), "--engine", "physx"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install" in err[0] and "physx" in err[0]
    assert not (isolated_home / "results.sqlite").exists()  # refused before anything ran
