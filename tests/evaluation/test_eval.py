"""The eval runner on a tiny benchmark written here: oracle, external predictions and commands, failed
cases, the ``--json`` document, worker pools, and resuming a killed run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from helpers_bench import FAST, copy_object, make_tiny_bench

from spark_bench import CONVENTION_VERSION
from spark_bench.cli import main
from spark_bench.data.case import Benchmark
from spark_bench.errors import InputError
from spark_bench.evaluation.runner import run_eval
from spark_bench.evaluation.store import ResultsStore
from spark_bench.methods.base import MethodSpec
from spark_bench.methods.registry import register_method, unregister_method


@pytest.fixture
def tiny_bench(tmp_path) -> Path:
    return make_tiny_bench(tmp_path)


def gt_dir(bench: Path, case_id: str) -> Path:
    return Benchmark(bench).case(case_id).gt_dir


def test_oracle_scores_zero_articulation_error(tiny_bench, tmp_path):
    summary = run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, db=tmp_path / "r.sqlite",
                       workers=0, runs_root=tmp_path / "runs", progress=False)
    assert summary.n_cases == 3 and summary.n_failed == 0
    m = summary.metrics
    assert m["axis_err"] == 0.0 and m["pivot_err"] == 0.0 and m["type_err"] == 0.0
    assert m["cd"] == 0.0 and m["fscore@0.1"] == 1.0 and m["fscore@0.5"] == 1.0  # same files, same samples
    assert m["sim_pass_rate"] is None  # --no-sim
    with ResultsStore(tmp_path / "r.sqlite") as store:
        rows = store.rows(bench="tiny")
    assert len(rows) == 3
    row = rows[0]
    assert row["label"] == "oracle" and row["regime"] == "ground truth" and row["convention"] == CONVENTION_VERSION
    assert row["metrics"]["n_gt_joints"] == 2 and set(row["timings"]) >= {"generate", "metrics"}
    assert {r["category"] for r in rows} == {"StorageFurniture", "Table"}


def test_geometry_baseline_runs_and_is_plausible(tiny_bench, tmp_path):
    summary = run_eval(MethodSpec.create("geometry"), str(tiny_bench), FAST, db=tmp_path / "r.sqlite",
                       workers=0, runs_root=tmp_path / "runs", progress=False)
    assert summary.n_failed == 0
    m = summary.metrics
    assert m["cd"] is None  # its geometry is the ground truth's: n/a, never zero
    assert m["type_err"] == 0.0  # a drawer and a door: both kinds found
    assert m["axis_err"] < 0.05 and m["pivot_err"] < 0.1


def test_failed_case_is_recorded_and_run_goes_on(tiny_bench, tmp_path):
    (gt_dir(tiny_bench, "cab1") / "mobility.urdf").write_text("<robot><link name='a'>")  # broken XML
    summary = run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, db=tmp_path / "r.sqlite",
                       workers=0, runs_root=tmp_path / "runs", progress=False)
    assert summary.n_failed == 1 and summary.n_cases == 3
    reason = summary.failures["cab1"]
    assert "malformed XML" in reason and "\n" not in reason
    assert summary.metrics["type_err"] == 0.0  # the two good cases


def test_predictions_folder_and_missing_case(tiny_bench, tmp_path):
    predictions = tmp_path / "preds"
    for case_id in ("cab0", "cab2"):
        copy_object(gt_dir(tiny_bench, case_id), predictions / case_id)
    summary = run_eval(MethodSpec.create("predictions", predictions=str(predictions), label="copy"),
                       str(tiny_bench), FAST, db=tmp_path / "r.sqlite", workers=0, runs_root=tmp_path / "runs",
                       progress=False)
    assert summary.run.label == "copy" and summary.n_failed == 1
    assert "no prediction folder" in summary.failures["cab1"]
    assert summary.metrics["axis_err"] == 0.0


def _methods_file(tmp_path: Path, script: str, timeout: float = 60) -> Path:
    program = tmp_path / "method.py"
    program.write_text(textwrap.dedent(script))
    methods = tmp_path / "methods.toml"
    methods.write_text(f'[methods.copier]\ncommand = [{json.dumps(sys.executable)}, {json.dumps(str(program))}, '
                       f'"{{image}}", "{{out}}", "{{case_id}}"]\ntimeout = {timeout}\nversion = "0.1"\n')
    return methods


def test_command_method_runs_without_shell_and_times_out(tiny_bench, tmp_path):
    # the external program sees the image path and the output folder; here it copies a fixed object
    source = gt_dir(tiny_bench, "cab0")
    input_name = Benchmark(tiny_bench).case("cab0").input_image.name
    methods = _methods_file(tmp_path, f"""
        import shutil, sys, time
        from pathlib import Path
        image, out, case_id = sys.argv[1:4]
        assert Path(image).parent.name == case_id and Path(image).name == {input_name!r}, image
        if case_id == "cab2":
            time.sleep(30)
        shutil.copytree({str(source)!r}, out + "/obj", dirs_exist_ok=True)
    """, timeout=3)
    summary = run_eval(MethodSpec.create("copier", methods_file=str(methods)), str(tiny_bench), FAST,
                       db=tmp_path / "r.sqlite", workers=0, runs_root=tmp_path / "runs", progress=False)
    assert summary.run.label == "copier" and summary.run.version == "0.1"
    assert summary.n_failed == 1 and "timed out" in summary.failures["cab2"]
    with ResultsStore(tmp_path / "r.sqlite") as store:
        ok = {r["case_id"]: r for r in store.rows(status="ok")}
    assert ok["cab0"]["axis_err"] == 0.0  # its own object
    assert ok["cab1"]["cd"] > 1e-3  # another cabinet's object: a real shape error


def test_eval_json_output_and_pool(tiny_bench, tmp_path, capsys, isolated_home):
    code = main(["eval", "--method", "oracle", "--bench", str(tiny_bench), "--no-sim", "--n-samples", "3000",
                 "--workers", "2", "--json", "--no-progress"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert list(doc) == ["method", "regime", "bench", "n_cases", "n_failed", "metrics"]
    assert doc["regime"] == "ground truth"
    assert doc["method"] == "oracle" and doc["bench"] == "tiny" and doc["n_cases"] == 3 and doc["n_failed"] == 0
    assert list(doc["metrics"]) == ["cd", "fscore@0.1", "fscore@0.5", "axis_err", "pivot_err", "type_err",
                                    "sim_pass_rate", "open_success_rate", "joint_mean"]
    assert set(doc["metrics"]["joint_mean"]) == {"axis_err", "pivot_err", "type_err"}
    assert (isolated_home / "results.sqlite").is_file()
    # a second run finds everything done: nothing is generated again
    main(["eval", "--method", "oracle", "--bench", str(tiny_bench), "--no-sim", "--n-samples", "3000", "--json",
          "--no-progress"])
    assert json.loads(capsys.readouterr().out)["metrics"] == doc["metrics"]
    with ResultsStore(isolated_home / "results.sqlite") as store:
        assert store.count() == 3


def test_eval_with_rl_scores_the_shipped_policy_on_the_ground_truth(tmp_path, isolated_home, capsys):
    """``eval --rl``: the shipped generalist, fine-tuned on the prediction, opens every ground-truth drawer
    and door; ``--json`` always has both RL rates; the episode video is kept beside the generation."""
    bench = make_tiny_bench(tmp_path, n=1)
    code = main(["eval", "--method", "oracle", "--bench", str(bench), "--no-sim", "--n-samples", "2000", "--rl",
                 "--rl-finetune-steps", "64", "--workers", "0", "--no-progress", "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert {"rl_success_rate", "rl_zero_shot_success_rate"} <= set(doc["metrics"])
    with ResultsStore(isolated_home / "results.sqlite") as store:
        (row,) = store.rows(status="ok")
    rl = row["checks"]["rl"]
    assert "error" not in rl, rl
    # the cabinet's drawer and door, each scored; the oracle's joint names are the truth's
    assert {j["type"] for j in rl["joints"].values()} == {"prismatic", "revolute"}
    assert all(j["pred_joint"] == name for name, j in rl["joints"].items())
    assert rl["finetune_steps"] == 64 and all(f["steps"] >= 64 for f in rl["finetune"].values())
    assert row["rl_success"] == rl["success_rate"] == doc["metrics"]["rl_success_rate"]
    assert doc["metrics"]["rl_zero_shot_success_rate"] == rl["zero_shot_success_rate"]
    assert rl["zero_shot_success_rate"] >= 0.5  # the oracle: the shipped policy opens the default cabinet
    assert rl["policy"]["weights"] == "shipped"
    (video,) = [j["video"] for j in rl["joints"].values() if "video" in j]
    assert Path(video).is_file() and Path(video).parent.name.endswith(".rl")
    assert list(Path(video).parent.glob("*_finetuned.zip")), "the fine-tuned policies are kept beside it"
    # without --rl the summary has no RL keys
    code = main(["eval", "--method", "oracle", "--bench", str(bench), "--no-sim", "--n-samples", "2000",
                 "--workers", "0", "--no-progress", "--json"])
    assert "rl_success_rate" not in json.loads(capsys.readouterr().out)["metrics"]


def assert_same_numbers(actual: dict, expected: dict, rel: float, abs_: float, where: str = "") -> None:
    """``actual`` has ``expected``'s keys; numbers agree within the tolerances, nested dicts key by key, and
    anything else (None: a metric with no value, text) exactly. (``pytest.approx`` over a dict holding None
    raises TypeError since pytest 9.2.)"""
    assert actual.keys() == expected.keys(), where
    for key, value in expected.items():
        here = f"{where}.{key}" if where else key
        if isinstance(value, dict):
            assert isinstance(actual[key], dict), here
            assert_same_numbers(actual[key], value, rel, abs_, here)
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            assert actual[key] == pytest.approx(value, rel=rel, abs=abs_), here
        else:
            assert actual[key] == value, here


def test_assert_same_numbers_compares_none_exactly_and_numbers_closely():
    assert_same_numbers({"a": 1.0 + 1e-14, "b": None, "c": {"d": None, "e": 2.0}},
                        {"a": 1.0, "b": None, "c": {"d": None, "e": 2.0}}, rel=1e-12, abs_=1e-15)
    for wrong in ({"a": 1.0, "b": 0.0}, {"a": 1.1, "b": None}, {"a": 1.0}):
        with pytest.raises(AssertionError):
            assert_same_numbers(wrong, {"a": 1.0, "b": None}, rel=1e-12, abs_=1e-15)


@pytest.mark.slow
def test_ray_executor_gives_the_same_results_as_the_process_pool(tiny_bench, tmp_path):
    pytest.importorskip("ray", reason="the Ray executor is optional: pip install 'spark-bench[ray]'")
    import ray

    local = run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, db=tmp_path / "local.sqlite", workers=0,
                     runs_root=tmp_path / "runs", progress=False)
    try:
        remote = run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, db=tmp_path / "ray.sqlite",
                          workers=1, executor="ray", runs_root=tmp_path / "runs_ray", progress=False)
    finally:
        ray.shutdown()
    assert remote.n_cases == 3 and remote.n_failed == 0
    # the same computation in other processes, possibly with another OpenMP thread count (Ray workers run
    # with OMP_NUM_THREADS=1). The k-d tree answers are exact per point whatever the threads and NumPy takes
    # the means in one thread, so the numbers agree today; rel=1e-12 is the float64 summation-order noise of
    # a mean over 5000 samples (~5000 x 1e-16), what a reduction in another order could add, and no more
    assert_same_numbers(remote.metrics, local.metrics, rel=1e-12, abs_=1e-15)
    with ResultsStore(tmp_path / "ray.sqlite") as store:
        pids = {row["info"]["pid"] for row in store.rows(status="ok")}
    assert os.getpid() not in pids, "cases ran in Ray workers, not in the driver"


def test_unknown_method_is_a_one_line_error(tiny_bench, capsys, isolated_home):
    assert main(["eval", "--method", "nope", "--bench", str(tiny_bench), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "unknown method 'nope'" in err and "oracle" in err


@pytest.mark.slow
def test_killed_run_resumes_with_one_result_per_case(tmp_path):
    bench = make_tiny_bench(tmp_path, n=6)
    db = tmp_path / "r.sqlite"
    methods = _methods_file(tmp_path, f"""
        import shutil, sys, time
        from pathlib import Path
        time.sleep(1.0)
        shutil.copytree({str(gt_dir(bench, "cab0"))!r}, sys.argv[2], dirs_exist_ok=True)
    """)
    cmd = [sys.executable, "-m", "spark_bench.cli", "eval", "--method", "copier", "--methods-file", str(methods),
           "--bench", str(bench), "--no-sim", "--n-samples", "2000", "--db", str(db), "--runs-dir",
           str(tmp_path / "runs"), "--workers", "1", "--no-progress"]
    env = {**os.environ, "SPARK_BENCH_HOME": str(tmp_path / "home")}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    deadline = time.time() + 120
    done_before = 0
    while time.time() < deadline:
        if db.is_file():
            with ResultsStore(db) as store:
                done_before = store.count()
            if done_before >= 2:
                break
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)  # the driver and its pool worker, mid-run
    proc.wait()
    assert 2 <= done_before < 6
    with ResultsStore(db) as store:
        before = {r["case_id"]: r["finished_at"] for r in store.rows()}
    assert len(before) < 6
    subprocess.run(cmd, env=env, check=True, timeout=300, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with ResultsStore(db) as store:
        rows = store.rows()
    assert sorted(r["case_id"] for r in rows) == Benchmark(bench).case_ids()  # exactly one result per case
    assert all(r["status"] == "ok" for r in rows)
    for r in rows:  # no finished case was repeated
        if r["case_id"] in before:
            assert r["finished_at"] == before[r["case_id"]]


def test_variants_and_shape_validity_are_stored(tiny_bench, tmp_path, monkeypatch):
    """A method that reports a variant (ours and its prior before joint optimization) gets two rows."""

    class TwoOutputs:
        name, version, inputs, regime = "two", "1", ("gt",), "image"

        def label(self):
            return "two"

        def config(self):
            return {"k": np.float64(1.5)}

        def generate(self, case, out_dir):
            return {"folder": case.gt_dir, "variants": {"w/o joint opt.": case.gt_dir},
                    "shape_metrics_valid": False, "prior": "annotation"}

    register_method("two", lambda options: TwoOutputs())
    try:
        summary = run_eval(MethodSpec.create("two"), str(tiny_bench), FAST, db=tmp_path / "r.sqlite", workers=0,
                           runs_root=tmp_path / "runs", progress=False)
    finally:
        unregister_method("two")
    assert summary.metrics["cd"] is None and summary.metrics["axis_err"] == 0.0
    with ResultsStore(tmp_path / "r.sqlite") as store:
        rows = store.rows()
    assert sorted({r["variant"] for r in rows}) == ["", "w/o joint opt."] and len(rows) == 6
    assert all(not r["shape_metrics_valid"] for r in rows)
    assert rows[0]["info"]["prior"] == "annotation" and rows[0]["config"]["method_config"] == {"k": 1.5}


def test_a_case_that_kills_its_worker_fails_alone(tiny_bench, tmp_path):
    class Crasher:
        name, version, inputs, regime = "crasher", "1", ("gt",), "image"

        def label(self):
            return "crasher"

        def config(self):
            return {}

        def generate(self, case, out_dir):
            if case.case_id == "cab1":
                os._exit(3)  # a segfault in native code looks like this to the pool
            return {"folder": case.gt_dir}

    register_method("crasher", lambda options: Crasher())
    try:  # the pool's workers are forked: they see the registration
        summary = run_eval(MethodSpec.create("crasher"), str(tiny_bench), FAST, db=tmp_path / "r.sqlite",
                           workers=2, runs_root=tmp_path / "runs", progress=False)
    finally:
        unregister_method("crasher")
    assert summary.n_failed == 1 and "worker process died" in summary.failures["cab1"]
    assert summary.metrics["axis_err"] == 0.0


def test_generation_cache_marker_and_bad_manifest(tiny_bench, tmp_path):
    """A finished generation is read back from its marker; a damaged marker means generate again; a bad
    manifest is an input error naming the file."""
    from spark_bench.evaluation.runner import CaseTask, generate_cached, resolve_bench, run_identity
    from spark_bench.methods.base import GENERATION_MARKER
    from spark_bench.methods.registry import make_method

    spec = MethodSpec.create("oracle")
    bench = Benchmark(tiny_bench)
    task = CaseTask("cab0", str(bench.case_dir("cab0")), spec, run_identity("tiny", spec, FAST),
                    str(tmp_path / "gen" / "cab0"), FAST)
    method = make_method(spec)
    first, cached = generate_cached(task, method)
    assert not cached and (first.folder / "mobility.urdf").is_file()
    again, cached = generate_cached(task, method)
    assert cached and again == first
    (first.folder / GENERATION_MARKER).write_text('{"folder": ')  # a marker cut short
    _, cached = generate_cached(task, method)
    assert not cached and (first.folder / GENERATION_MARKER).is_file()

    bench.manifest_path.write_text("{")
    with pytest.raises(InputError, match=rf"{bench.manifest_path.name}: malformed JSON"):
        resolve_bench(str(tiny_bench))
    bench.manifest_path.unlink()
    with pytest.raises(InputError, match=rf"{bench.manifest_path.name}: not a benchmark folder"):
        resolve_bench(str(tiny_bench))


@pytest.mark.parametrize("case_id", ["../x", "..", "a/b", ""])
def test_unsafe_case_id_in_the_manifest_is_refused(tiny_bench, tmp_path, case_id):
    """A manifest naming a case outside the cases folder is an input error naming the manifest's cases
    folder and the id; nothing is generated or stored."""
    bench = Benchmark(tiny_bench)
    manifest = bench.manifest()
    bench.write_manifest({**manifest, "cases": [*manifest["cases"], case_id]})
    with pytest.raises(InputError, match=f"unsafe case id {case_id!r}") as info:
        bench.case_dir(case_id)
    assert str(bench.cases_dir) in str(info.value)
    with pytest.raises(InputError, match=f"unsafe case id {case_id!r}"):
        run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, db=tmp_path / "r.sqlite", workers=0,
                 runs_root=tmp_path / "runs", progress=False)
    assert not (tmp_path / "runs").exists() and not (tmp_path / "r.sqlite").exists()


def test_a_case_prepared_again_is_scored_again_and_an_unchanged_one_is_not(tiny_bench, tmp_path):
    """Rows and generations carry the case's fingerprint: a resumed run skips the cases scored on the
    present build, and scores again (from a fresh generation) a case whose images changed since (a
    benchmark prepared again with another render mode), replacing its row instead of keeping a row of
    the other build; moving the benchmark to another folder changes nothing."""
    from spark_bench.evaluation.render import default_camera, render_asset

    kwargs = dict(db=tmp_path / "r.sqlite", workers=0, runs_root=tmp_path / "runs", progress=False)
    first = run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, **kwargs)
    assert first.n_skipped == 0 and first.n_failed == 0
    with ResultsStore(tmp_path / "r.sqlite") as store:
        rows = {r["case_id"]: r for r in store.rows(label="oracle")}
    case = Benchmark(tiny_bench).case("cab1")
    assert rows["cab1"]["info"]["case_fingerprint"] == case.fingerprint()
    assert len({r["info"]["case_fingerprint"] for r in rows.values()}) == 3

    assert run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, **kwargs).n_skipped == 3

    # cab1's input image rendered again at another size: another build of that case
    render_asset(case.load_gt(), default_camera(48), size=48).save(case.input_image)
    again = run_eval(MethodSpec.create("oracle"), str(tiny_bench), FAST, **kwargs)
    assert again.n_skipped == 2
    with ResultsStore(tmp_path / "r.sqlite") as store:
        rows = {r["case_id"]: r for r in store.rows(label="oracle")}
    assert len(rows) == 3  # replaced, not added
    assert rows["cab1"]["info"]["case_fingerprint"] == Benchmark(tiny_bench).case("cab1").fingerprint()
    assert rows["cab1"]["info"]["generation_cached"] is False  # its cached generation was of the other build

    moved = tmp_path / "elsewhere" / "tiny"
    moved.parent.mkdir()
    tiny_bench.rename(moved)
    assert run_eval(MethodSpec.create("oracle"), str(moved), FAST, **kwargs).n_skipped == 3


def test_the_open_and_rl_scores_share_one_pairing(tmp_path, isolated_home, monkeypatch):
    """``eval`` with the opening score and ``--rl``: the prediction and the object the scores act on (a real
    object's source takes seconds to read) are loaded once per case, for both scores."""
    import spark_bench.opening.judge as scoring
    import spark_bench.opening.pairing as pairing
    import spark_bench.rl.transfer as transfer
    from spark_bench.evaluation.runner import EvalOptions

    calls: list[str] = []
    real = pairing.load_pairing

    def counting(pred_folder, gt_folder, metrics, gt_bench=None):
        calls.append(str(pred_folder))
        return real(pred_folder, gt_folder, metrics, gt_bench)

    # every name the pairing goes by: its module's (the runner's), and those the two scores imported
    for module in (pairing, scoring, transfer):
        if hasattr(module, "load_pairing"):
            monkeypatch.setattr(module, "load_pairing", counting)
    bench = make_tiny_bench(tmp_path, n=1)
    summary = run_eval(MethodSpec.create("oracle"), str(bench), EvalOptions(sim=True, rl=True, n_samples=2000,
                       rl_finetune_steps=0), db=tmp_path / "r.sqlite", workers=0, runs_root=tmp_path / "runs",
                       progress=False)
    assert summary.n_failed == 0 and len(calls) == 1
    with ResultsStore(tmp_path / "r.sqlite") as store:
        (row,) = store.rows(status="ok")
    assert row["checks"]["open"]["joints_total"] == row["checks"]["rl"]["joints_total"] == 2
