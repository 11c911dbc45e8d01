"""The leaderboard: aggregation, best / second-best marks, n/a for invalid shape metrics, variants,
every format, and the HTML page rendered in headless Chromium."""

from __future__ import annotations

import csv
import io
import shutil
import subprocess
from pathlib import Path

import pytest
from helpers_bench import FAST, make_tiny_bench

from spark_bench import CONVENTION_VERSION
from spark_bench.data.case import Benchmark, BenchmarkCase
from spark_bench.errors import SparkBenchError
from spark_bench.evaluation.leaderboard import build_leaderboard, render, to_csv, to_latex, to_markdown
from spark_bench.evaluation.store import ResultsStore

CHROMIUM = Path("/usr/bin/chromium")


def _row(label: str, case_id: str, regime: str = "image", variant: str = "", **metrics) -> dict:
    out = {"bench": "b", "case_id": case_id, "category": "Cab" if case_id < "c2" else "Oven", "method": label,
           "label": label, "variant": variant, "regime": regime, "config_hash": "h", "status": "ok",
           "finished_at": 1.0, "sim_pass": True, "open_success": 1.0, "convention": CONVENTION_VERSION}
    out.update(metrics)
    return out


@pytest.fixture
def store(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put([_row("oracle", c, regime="ground truth", cd=0.0, fscore_01=1.0, fscore_05=1.0, axis_err=0.0,
                    pivot_err=0.0, type_err=0.0) for c in ("c1", "c2")])
        s.put([_row("A", "c1", cd=0.2, fscore_01=0.5, fscore_05=0.9, axis_err=0.1, pivot_err=0.2, type_err=0.0),
               _row("A", "c2", cd=0.4, fscore_01=0.3, fscore_05=0.7, axis_err=0.3, pivot_err=0.4, type_err=0.5,
                    sim_pass=False, open_success=0.0)])
        s.put([_row("B", "c1", cd=0.1, fscore_01=0.6, fscore_05=0.95, axis_err=0.5, pivot_err=0.1, type_err=0.0),
               {**_row("B", "c2"), "status": "failed", "stage": "generate", "reason": "boom", "sim_pass": None}])
        s.put([_row("ours", c, regime="image + gt prior", shape_metrics_valid=False, cd=0.0, fscore_01=1.0,
                    fscore_05=1.0, axis_err=0.05, pivot_err=0.05, type_err=0.0) for c in ("c1", "c2")])
        s.put([_row("ours", c, regime="image + gt prior", variant="w/o joint opt.", shape_metrics_valid=False,
                    cd=0.0, axis_err=0.2, pivot_err=0.3, type_err=0.25) for c in ("c1", "c2")])
        yield s


def test_aggregation_and_marks(store):
    board = build_leaderboard(store)
    by_name = {e.name: e for e in board.entries}
    assert list(by_name) == ["oracle", "A", "B", "ours", "ours (w/o joint opt.)"]  # references first
    a, b = by_name["A"], by_name["B"]
    assert a.metrics["cd"] == pytest.approx(0.3) and a.metrics["type_err"] == pytest.approx(0.25)
    assert a.metrics["sim_pass_rate"] == 0.5 and a.metrics["open_success_rate"] == 0.5
    assert b.n_failed == 1 and b.metrics["cd"] == pytest.approx(0.1)  # mean over its ok case
    assert b.metrics["sim_pass_rate"] == 0.5  # the failed case counts as not passed
    assert by_name["ours"].metrics["cd"] is None  # ground-truth geometry: n/a, never 0
    shape, articulation, sim = board.tables()
    ranks = shape.ranks()
    names = [e.name for e in shape.entries]
    # B has the best CD among ranked rows, A the second; the oracle (reference) and ours (n/a) are not ranked
    assert ranks[(names.index("B"), "cd")] == 1 and ranks[(names.index("A"), "cd")] == 2
    assert (names.index("oracle"), "cd") not in ranks and (names.index("ours"), "cd") not in ranks
    art = articulation.ranks()
    assert art[(names.index("ours"), "axis_err")] == 1 and art[(names.index("A"), "axis_err")] == 2


def test_methods_select_labels_that_contain_commas(tmp_path):
    label = "ours (prior=retrieval,geometry=retrieval,opt=native)"
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put([_row("A", "c1", cd=0.2), _row("B", "c1", cd=0.1), _row(label, "c1", cd=0.3)])
        assert [e.name for e in build_leaderboard(s, labels=[label, "A"]).entries] == ["A", label]
        assert [e.name for e in build_leaderboard(s, labels=["A,B"]).entries] == ["A", "B"]  # the old comma list
        with pytest.raises(SparkBenchError, match="no results labelled 'ours'.*the labels are"):
            build_leaderboard(s, labels=["ours"])


def test_markdown_latex_csv(store):
    board = build_leaderboard(store)
    md = to_markdown(board, per_category=True)
    assert "| ours | image + gt prior | n/a | n/a | n/a |" in md
    assert "| B | image | **0.1000** | **0.6000** | **0.9500** |" in md
    assert "| A | image | _0.3000_ |" in md and "ours (w/o joint opt.)" in md
    assert "## Cab" in md and "## Oven" in md
    tex = to_latex(board)
    assert r"\cellcolor{Palette5}{0.1000}" in tex and r"\cellcolor{Palette4}{0.3000}" in tex
    assert r"\providecolor{Palette5}{RGB}{253,207,158}" in tex and r"AxisErr$\downarrow$" in tex
    assert r"ours (w/o joint opt.) & image + gt prior & n/a" in tex
    lines = list(csv.DictReader(io.StringIO(to_csv(board))))
    ours = next(r for r in lines if r["label"] == "ours" and r["variant"] == "")
    assert ours["cd"] == "n/a" and float(ours["axis_err"]) == pytest.approx(0.05)


def test_leaderboard_command_every_format(tmp_path, capsys, isolated_home):
    from spark_bench.cli import main
    from spark_bench.evaluation.runner import run_eval
    from spark_bench.methods.base import MethodSpec

    bench = make_tiny_bench(tmp_path, n=2)
    for method in ("oracle", "geometry"):
        run_eval(MethodSpec.create(method), str(bench), FAST, workers=0, progress=False)
    assert main(["leaderboard"]) == 0
    md = capsys.readouterr().out
    assert "| oracle | ground truth | 0.0000 | 1.0000 | 1.0000 |" in md
    assert "| geometry (AnyMesh-style) | part meshes | n/a | n/a | n/a |" in md
    for fmt in ("latex", "csv"):
        assert main(["leaderboard", "--format", fmt]) == 0
        assert "geometry (AnyMesh-style)" in capsys.readouterr().out
    out = tmp_path / "board" / "index.html"
    assert main(["leaderboard", "--format", "html", "--out", str(out), "--per-category"]) == 0
    page = out.read_text()
    assert page.count("<img") >= 2 + 2 * (2 + 2 * 2)  # charts + per case: input, gt and 2 methods x 2 states
    files = sorted(p.name for p in (tmp_path / "board" / "index_files").iterdir())
    assert "chart_articulation.png" in files and "case000_input.png" in files and "case000_m1_open.png" in files
    assert main(["leaderboard", "--format", "html"]) == 2  # HTML needs a file


def test_renders_differ_between_rest_and_open(tmp_path):
    import numpy as np
    from PIL import Image

    from spark_bench.evaluation.render import read_camera, render_folder

    case = Benchmark(make_tiny_bench(tmp_path, n=1)).case("cab0")
    rest = np.asarray(render_folder(case.gt_dir, read_camera(case.camera_path), "rest", 96))
    opened = np.asarray(render_folder(case.gt_dir, read_camera(case.camera_path), "open", 96))
    assert rest.shape == (96, 96, 3)
    assert (rest != 255).any(axis=2).mean() > 0.05  # the object covers part of the image
    assert np.abs(rest.astype(int) - opened).sum() > 0  # the door and drawer moved
    assert Image.open(case.input_image).size == (64, 64)


@pytest.mark.skipif(not CHROMIUM.is_file(), reason="headless Chromium not installed (/usr/bin/chromium); "
                                                  "CI installs it with apt-get install -y chromium")
def test_html_page_renders_in_headless_chromium(tmp_path, store):
    import numpy as np
    from PIL import Image

    board = build_leaderboard(store)
    out = tmp_path / "page" / "index.html"
    out.parent.mkdir()
    out.write_text(render(board, "html", out=out))
    shot = tmp_path / "shot.png"
    cmd = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp_path / 'profile'}", f"--screenshot={shot}", "--window-size=1280,2000",
           out.as_uri()]
    subprocess.run(cmd, check=True, timeout=120, capture_output=True)
    image = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert image.shape[:2] == (2000, 1280)
    # the page drew something: text and the best-value colour of the paper (Palette5)
    assert (image.sum(axis=2) < 200).mean() > 0.001
    palette5 = np.all(np.abs(image - np.array([253, 207, 158])) <= 3, axis=2)
    assert palette5.sum() > 100
    shutil.rmtree(tmp_path / "profile", ignore_errors=True)


def test_read_camera_default_and_bad_file(tmp_path):
    from spark_bench.data.camera import CameraView
    from spark_bench.errors import InputError
    from spark_bench.evaluation.render import default_camera, read_camera

    assert read_camera(tmp_path / "absent.json") == default_camera()
    view = CameraView.from_json(default_camera(64))  # the default is a valid camera.json
    assert view.fov_deg == pytest.approx(40.0) and view.position.tolist() == pytest.approx([-3.2, -1.6, 1.6])
    bad = BenchmarkCase(tmp_path).camera_path
    bad.write_text('{"width": 64')
    with pytest.raises(InputError, match=rf"{bad}: malformed JSON"):
        read_camera(bad)
    bad.write_text('{"width": 64, "height": 64}')
    with pytest.raises(InputError, match=rf"{bad}: malformed camera"):
        read_camera(bad)


def test_rows_of_older_conventions_left_out_and_noted(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put([_row("A", "c1", axis_err=0.1), _row("A", "c2", axis_err=0.3)])
        s.put([{**_row("old", c, axis_err=0.9), "convention": "spark-bench-conv-1"} for c in ("c1", "c2")])
        s.put({**_row("A", "c3", axis_err=5.0), "config_hash": "h0", "finished_at": 0.5,
               "convention": "spark-bench-conv-1"})
        board = build_leaderboard(s)
    assert [e.name for e in board.entries] == ["A"] and board.entries[0].n_cases == 2
    assert board.entries[0].metrics["axis_err"] == pytest.approx(0.2)  # never averaged with the old rows
    assert board.left_out == {"spark-bench-conv-1": 3}
    md = to_markdown(board)
    assert f"Metric convention: {CONVENTION_VERSION}." in md
    assert "Not shown: 3 result rows scored under older metric definitions (3 under spark-bench-conv-1)" in md
    assert "per object (the mean over its joints), then averaged over objects" in md
    with ResultsStore(tmp_path / "old.sqlite") as s:
        s.put({**_row("old", "c1", axis_err=0.9), "convention": "spark-bench-conv-1"})
        with pytest.raises(SparkBenchError, match=r"current metric definitions \(spark-bench-conv-11\).*"
                                                  r"spark-bench-conv-1 \(1 rows\)"):
            build_leaderboard(s)


def _joints(*joints) -> dict:
    """A stored metrics dict of matched joints ``(axis_err, pivot_err, type_match, part class)``."""
    return {"matching": [{"gt_joint": f"j{k}", "axis_err": a, "pivot_err": p, "type_match": t, "gt_part_class": c}
                         for k, (a, p, t, c) in enumerate(joints)], "missing_joints": []}


def test_per_part_class_tables(tmp_path):
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put([_row("A", "c1", axis_err=0.1, metrics=_joints((0.1, 0.2, True, "hinge_door"),
                                                             (0.3, None, False, "slider_drawer"))),
               _row("A", "c2", axis_err=0.5, metrics=_joints((0.5, 0.4, True, "hinge_door")))])
        s.put([_row("B", "c1", axis_err=0.0, metrics=_joints((0.0, 0.1, True, "hinge_door"), (0.0, None, True, None)))])
        board = build_leaderboard(s)
    tables = {t.key: t for t in board.part_class_tables()}
    assert list(tables) == ["part-hinge_door", "part-slider_drawer"]
    door = {e.name: e.metrics for e in tables["part-hinge_door"].entries}
    assert door["A"] == {"axis_err": pytest.approx(0.3), "pivot_err": pytest.approx(0.3), "type_err": 0.0,
                         "n_joints": 2}
    assert [e.name for e in tables["part-slider_drawer"].entries] == ["A"]  # B has no drawer
    md = to_markdown(board, per_part_class=True)
    assert "## URDF parameter estimation: hinge door" in md and "## URDF parameter estimation: slider drawer" in md
    assert "| Method | Regime | AxisErr↓ | PivotErr↓ | TypeErr↓ | Joints |" in md
    assert "| B | image | **0.0000** | **0.1000** | **0.0000** | 1 |" in md
    assert "| A | image | _0.3000_ | _0.3000_ | **0.0000** | 2 |" in md  # TypeErr ties at 0: both best
    assert "Per GAPartNet part class" in md and "hinge door" not in to_markdown(board)
    lines = list(csv.DictReader(io.StringIO(to_csv(board, per_part_class=True))))
    drawer = next(r for r in lines if r["part_class"] == "slider_drawer")
    assert drawer["label"] == "A" and float(drawer["type_err"]) == 1.0 and drawer["n_joints"] == "1"
    assert drawer["cd"] == "n/a" and next(r for r in lines if r["label"] == "A")["part_class"] == ""
    assert "tab:part-hinge_door" in to_latex(board, per_part_class=True)
    page = render(board, "html", out=tmp_path / "page" / "index.html", per_part_class=True)
    assert "<h2>URDF parameter estimation: hinge door</h2>" in page and "<th>Joints</th>" in page
    assert (tmp_path / "page" / "index_files" / "chart_part-slider_drawer.png").is_file()


def test_per_part_class_without_annotations_is_a_clear_error(store, tmp_path):
    board = build_leaderboard(store)
    for fmt in ("md", "csv", "latex", "html"):
        with pytest.raises(SparkBenchError, match="no GAPartNet part classes"):
            render(board, fmt, out=tmp_path / "x.html", per_part_class=True)


def test_rl_scores_beside_the_scripted_opener_and_one_episode_video_per_case(tmp_path):
    """Runs with ``eval --rl``: both RL columns after the scripted opener's, averaged over the cases with a
    drawer or door (a failed case counting as not opened), the note saying the oracle is the ceiling, and
    one episode video per case in the HTML gallery."""
    import numpy as np
    from PIL import Image

    bench = make_tiny_bench(tmp_path, n=2)
    cases = {c: str(Benchmark(bench).case_dir(c)) for c in ("cab0", "cab1")}
    video = tmp_path / "episode.gif"
    frames = [Image.fromarray(np.full((18, 24, 3), 40 * k, np.uint8)) for k in range(3)]
    frames[0].save(video, save_all=True, append_images=frames[1:], duration=80)

    def rl(success: float, zero: float, with_video: bool) -> dict:
        joint = {"type": "prismatic", "pred_joint": "joint_2", "success": success, "zero_shot": zero}
        return {"rl": {"success_rate": success, "zero_shot_success_rate": zero,
                       "joints": {"joint_2": {**joint, **({"video": str(video)} if with_video else {})}}}}

    def row(label, case_id, regime="image", **extra):
        out = {**_row(label, case_id, regime=regime), "case_dir": cases[case_id],
               "prediction_dir": str(Path(cases[case_id]) / "gt")}
        out.update(extra)
        return out

    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([row("oracle", c, "ground truth", rl_success=1.0, checks=rl(1.0, 1.0, True)) for c in cases])
        store.put([row("A", "cab0", rl_success=1.0, checks=rl(1.0, 0.5, True)),
                   {**row("A", "cab1"), "status": "failed", "stage": "generate", "reason": "boom"}])
        store.put([row("B", c) for c in cases])  # no --rl
        board = build_leaderboard(store, bench="b")
    by_name = {e.name: e for e in board.entries}
    assert by_name["A"].metrics["rl_success_rate"] == 0.5  # the failed case counts as not opened
    assert by_name["A"].metrics["rl_zero_shot_success_rate"] == 0.25
    assert by_name["oracle"].metrics["rl_success_rate"] == 1.0
    assert by_name["B"].metrics["rl_success_rate"] is None and by_name["B"].metrics["open_success_rate"] == 1.0
    sim = board.tables()[2]
    assert sim.metrics[-3:] == ("open_success_rate", "rl_success_rate", "rl_zero_shot_success_rate")
    md = to_markdown(board)
    assert "RL success↑ | RL zero-shot↑" in md and "ceiling" in md
    assert "| A | image | _0.5000_ | _0.5000_ | **0.5000** | **0.2500** | 2 | 1 |" in md
    assert "| B | image | **1.0000** | **1.0000** | n/a | n/a | 2 | 0 |" in md
    out = tmp_path / "board" / "index.html"
    page = render(board, "html", out=out, max_cases=2)
    files = sorted(p.name for p in (tmp_path / "board" / "index_files").iterdir())
    # oracle (entry 0) and A (entry 1) have an RL column; A's failed case says so, B has none
    assert "case000_m0_rl.gif" in files and "case000_m1_rl.gif" in files and "case001_m1_rl.gif" not in files
    assert page.count("class='episode'") == 3 and page.count("RL episode</th>") == 2
    assert "failed: generate" in page


def test_rl_cell_says_why_every_joint_was_left_out(tmp_path):
    from spark_bench.evaluation.leaderboard_html import rl_video_cell

    none = {"checks": {"rl": {"success_rate": None, "joints": {}, "left_out": {}}}}
    assert "no drawer or door" in rl_video_cell(none, tmp_path / "case")
    reason = "the scripted opener fails with the ground-truth joint too (max fraction 0.46)"
    left = {"checks": {"rl": {"success_rate": None, "joints": {"joint_0": {"success": None, "reason": reason}},
                              "left_out": {"joint_0": reason}}}}
    cell = rl_video_cell(left, tmp_path / "case")
    assert "left out: joint_0" in cell and "max fraction 0.46" in cell and "no drawer or door" not in cell


def _open_check(*joints) -> dict:
    """A row's ``checks`` with a scripted opening result over ``joints``: ``(success, kind or None)``."""
    rows = {}
    for k, (success, kind) in enumerate(joints):
        rows[f"joint_{k}"] = {"success": success, **({"reason": "why", "left_out_kind": kind} if kind else {})}
    return {"open": {"success_rate": None, "joints": rows}}


def test_coverage_counts_the_joints_scored_and_what_left_the_others_out(tmp_path):
    """The coverage beside the open rate: joints scored of all, summed over the ok cases, and the kinds
    that left the others out (a row stored before kinds were recorded counts as ``unknown``); shown as a
    count column in Markdown and HTML and as numbers in the CSV."""
    from spark_bench.evaluation.aggregate import joint_coverage, summarize
    from spark_bench.evaluation.board import coverage_line

    old = _open_check((True, None), (None, None))
    old["open"]["joints"]["joint_1"].update(reason="planner said so")  # no left_out_kind: an older row
    cup = _open_check((True, None), (False, None), (None, "planner"))
    cup["open"]["joints"]["joint_0"]["end_effector"] = "suction"  # opened with the cup
    rows = [_row("A", "c1", checks=cup),
            _row("A", "c2", checks=_open_check((None, "stuck"), (None, "planner"))),
            _row("A", "c3", checks=old),
            {**_row("A", "c4", checks=_open_check((True, None))), "status": "failed"}]
    coverage = joint_coverage(rows, "open")
    assert coverage == {"joints_scored": 3, "joints_total": 7, "cases": 3, "scored_by": {"gripper": 2, "suction": 1},
                        "left_out_kinds": {"planner": 2, "stuck": 1, "unknown": 1}}
    assert joint_coverage(rows, "rl") is None
    assert summarize(rows)["open_coverage"] == coverage and "open_coverage" not in summarize(rows, sim=False)
    assert coverage_line(coverage) == ("3/7 ground-truth drawer and door joints scored in 3 cases (1 with the "
                                       "suction cup); left out: planner 2, stuck 1, unknown 1")
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put(rows)
        board = build_leaderboard(s)
    text = render(board, "md")
    sim_table = text.split("Sim-readiness", 1)[1]
    assert "| Open joints |" in sim_table and "| 3/7 (1 by cup) |" in sim_table
    header, line = render(board, "csv").splitlines()[:2]
    values = dict(zip(header.split(","), line.split(",")))
    assert (values["open_coverage_scored"], values["open_coverage_total"]) == ("3", "7")
    assert values["rl_coverage_total"] == "n/a"


def test_rows_made_with_other_package_versions_are_listed_but_not_ranked(tmp_path):
    """A run made with another MuJoCo (or CoACD, NumPy...) than the rest is shown, never marked best, and the
    board says why; rows stored before versions were recorded compare with anything."""
    new = {"mujoco": "4.0.0", "coacd": "1.0.14"}
    old = {"mujoco": "3.2.0", "coacd": "1.0.14"}
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put([_row("A", c, cd=0.3, axis_err=0.3, info={"versions": new}) for c in ("c1", "c2")])
        s.put([_row("B", c, cd=0.2, axis_err=0.2, info={"versions": new}) for c in ("c1", "c2")])
        s.put([_row("C", c, cd=0.1, axis_err=0.1, info={"versions": old}) for c in ("c1", "c2")])  # best, other MuJoCo
        s.put([_row("D", c, cd=0.4, axis_err=0.4) for c in ("c1", "c2")])  # no versions recorded
        board = build_leaderboard(s)
    by_name = {e.name: e for e in board.entries}
    assert not by_name["C"].ranked and "mujoco 3.2.0" in by_name["C"].other_versions
    assert by_name["A"].ranked and by_name["B"].ranked and by_name["D"].ranked
    shape = next(t for t in board.tables() if t.key == "shape")
    ranks = shape.ranks()
    best = {shape.entries[i].name for (i, metric), rank in ranks.items() if metric == "cd" and rank == 1}
    assert best == {"B"}  # C's lower CD is not comparable
    assert any("Not ranked" in n and "C: " in n and "mujoco 4.0.0" in n for n in board.notes())


def test_rows_made_on_unpinned_cpu_kernels_are_named_on_the_board(tmp_path):
    """A run whose process ran NumPy's AVX-512 kernels (NumPy loaded before spark_bench) is never silent: the
    board's notes name it, how many of its rows and which kernels, in every format; a pinned board says nothing."""
    pinned = {"mujoco": "3.2.0", "cpu kernels": "NPY_DISABLE_CPU_FEATURES=X86_V4 AVX512_ICL AVX512_SPR"}
    unpinned = {**pinned, "cpu kernels": "not pinned (numpy runs X86_V4 AVX512_ICL: loaded before spark_bench "
                                         "set the pins)"}
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put([_row("A", c, cd=0.3, info={"versions": pinned}) for c in ("c1", "c2")])
        board = build_leaderboard(s)
        assert board.kernels_note is None and not any("CPU kernels" in n for n in board.notes())
        s.put([_row("B", "c1", cd=0.2, info={"versions": pinned}),
               _row("B", "c2", cd=0.2, info={"versions": unpinned})])
        board = build_leaderboard(s)
    assert board.kernels_note and "B: 1 of 2 rows, not pinned (numpy runs X86_V4 AVX512_ICL" in board.kernels_note
    assert "A:" not in board.kernels_note
    for fmt in ("md", "latex"):
        assert "other CPU kernels than the pinned ones" in render(board, fmt)


def test_every_results_row_records_the_verdict_package_versions(tmp_path):
    from helpers_bench import FAST, make_tiny_bench

    from spark_bench.evaluation.runner import run_eval
    from spark_bench.kernels import cpu_kernels
    from spark_bench.methods.base import MethodSpec
    from spark_bench.versions import CPU_KERNELS, VERDICT_PACKAGES

    bench = make_tiny_bench(tmp_path, n=1)
    run_eval(MethodSpec.create("oracle"), str(bench), FAST, db=tmp_path / "r.sqlite", workers=0,
             runs_root=tmp_path / "runs", progress=False)
    with ResultsStore(tmp_path / "r.sqlite") as s:
        (row,) = s.rows()
    versions = row["info"]["versions"]
    assert set(versions) == {*VERDICT_PACKAGES, CPU_KERNELS} and versions["mujoco"] != "absent"
    assert versions[CPU_KERNELS] == cpu_kernels()


def _aligned(scale: float, yaw_deg: float) -> dict:
    """A row's stored metrics after ``--align icp`` found ``scale`` and a turn of ``yaw_deg`` about Z."""
    import numpy as np

    from spark_bench.metrics.align import rotation_z

    matrix = np.eye(4)
    matrix[:3, :3] = scale * rotation_z(np.radians(yaw_deg))
    matrix[:3, 3] = (0.1, -0.2, 0.0)
    return {"align": "icp", "alignment": matrix.tolist()}


def test_the_scale_the_alignment_applied_is_shown_beside_the_errors(tmp_path):
    """A run scored with ``--align icp`` says by how much its predictions were scaled (median and range over
    its aligned cases, from the stored matrices): in eval's summary, a Markdown column and the CSV; a run
    scored without alignment says ``none``, and a board where nothing was aligned has no such column."""
    from spark_bench.evaluation.aggregate import alignment_scales, summarize
    from spark_bench.metrics.report import alignment_found

    found = alignment_found("icp", _aligned(0.9, 90.0)["alignment"])
    assert found["alignment_scale"] == pytest.approx(0.9) and found["alignment_yaw_deg"] == pytest.approx(90.0)
    assert alignment_found("none", _aligned(0.9, 90.0)["alignment"]) == {"alignment_scale": None,
                                                                          "alignment_yaw_deg": None}
    rows = [_row("A", "c1", cd=0.1, metrics=_aligned(0.9, 90.0)), _row("A", "c2", cd=0.2, metrics=_aligned(1.1, 0.0)),
            _row("A", "c3", cd=0.3, metrics=_aligned(1.0, -90.0)),
            {**_row("A", "c4", metrics=_aligned(3.0, 0.0)), "status": "failed"},
            _row("B", "c1", cd=0.1, metrics={"align": "none", "alignment": _aligned(2.0, 0.0)["alignment"]})]
    scales = alignment_scales(rows[:4])
    assert scales["cases"] == 3 and scales["median"] == pytest.approx(1.0)
    assert (scales["min"], scales["max"]) == (pytest.approx(0.9), pytest.approx(1.1))
    assert summarize(rows[:4])["alignment_scale"] == scales and "alignment_scale" not in summarize(rows[4:])
    with ResultsStore(tmp_path / "r.sqlite") as s:
        s.put(rows)
        board = build_leaderboard(s)
    text = render(board, "md")
    assert "ICP scale" in text and "| 1.00 (0.90-1.10) |" in text and "| none |" in text
    lines = render(board, "csv").splitlines()
    by_label = {line.split(",")[3]: dict(zip(lines[0].split(","), line.split(","))) for line in lines[1:]}
    assert float(by_label["A"]["alignment_scale_max"]) == pytest.approx(1.1)
    assert by_label["B"]["alignment_scale_median"] == "n/a"
    with ResultsStore(tmp_path / "plain.sqlite") as s:
        s.put(rows[4:])
        assert "ICP scale" not in render(build_leaderboard(s), "md")


def test_the_maniskill_rule_is_shown_beside_the_opening_score_where_rows_record_it(tmp_path):
    """Rows whose opening score also judged each episode by ManiSkill3's rule get a column after Open success
    (over the same joints, a failed case counting as not opened); rows stored before it have none, and a board
    of only such rows shows no such column."""
    def opened(rate: float, maniskill: float | None) -> dict:
        return {"open": {"success_rate": rate, **({} if maniskill is None else {"success_rate_maniskill": maniskill}),
                         "joints": {"joint_0": {"success": rate > 0, "success_maniskill": bool(maniskill)}}}}

    with ResultsStore(tmp_path / "r.sqlite") as store:
        store.put([_row("A", "c1", open_success=1.0, checks=opened(1.0, 0.0)),
                   _row("A", "c2", open_success=1.0, checks=opened(1.0, 1.0)),
                   {**_row("A", "c3"), "status": "failed", "stage": "generate", "reason": "boom", "sim_pass": None}])
        store.put([_row("B", c, checks=opened(1.0, None)) for c in ("c1", "c2")])  # stored before the rule
        board = build_leaderboard(store, bench="b")
        old = build_leaderboard(store, bench="b", labels=["B"])
    by_name = {e.name: e for e in board.entries}
    assert by_name["A"].metrics["open_success_rate"] == pytest.approx(2 / 3)
    assert by_name["A"].metrics["open_success_rate_maniskill"] == pytest.approx(1 / 3)
    assert by_name["B"].metrics["open_success_rate_maniskill"] is None
    sim = board.tables()[2]
    assert sim.metrics[-2:] == ("open_success_rate", "open_success_rate_maniskill")
    md = to_markdown(board)
    assert "Open success (ManiSkill rule)↑" in md and "nearly still" in md
    assert "open_success_rate_maniskill" not in old.tables()[2].metrics
