"""Do MuJoCo and PhysX agree? ``spark-bench check --engine all`` on real objects and on their broken twins.

For every object (default: ``../shared/partnet_dev``, both halves, and ``../shared/real_objects``; ``--cases BENCH``
adds a prepared benchmark's ground truths; ``--ids`` picks some), this script runs the sim checks in MuJoCo
(:func:`spark_bench.sim.checks.run_checks`) and in PhysX (:func:`spark_bench.sim.physx.engines.physx_report`, on
the same prepared object) on the object as it is (*intact*) and on the broken twins of its drawers, doors and lids
(:mod:`benchmarks.broken_twins`, the joints :func:`benchmarks.measure_check_validity.broken_joints` picks; each
twin judged by :func:`benchmarks.clean_break.judge_break`). It reports how often the two verdicts agree (the whole
verdict, and per check both engines have), every disagreement with both engines' reasons, and the CPU seconds of
each engine (MuJoCo: conversion, CoACD workers included, and its checks; PhysX: loading and its checks on the
prepared object, which MuJoCo's run leaves in the shape cache).

Each object runs in a child process (``--jobs`` at once), its result stored as ``<store>/<set>__<id>.json``: an
interrupted run resumes. The report is ``benchmarks/results/engine_agreement.md`` and ``.json``.

Run: ``nice -n 10 python -m benchmarks.measure_engine_agreement [--half tune|holdout|all|none] [--no-real]
[--cases BENCH] [--ids 45780 ...] [--no-twins] [--jobs 2] [--home DIR]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from benchmarks.child_runs import rate as child_rate
from benchmarks.child_runs import stored_path, stored_rows

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "engine_agreement"
#: The checks both engines have (their verdicts are compared one by one).
SHARED_CHECKS = ("mesh_files", "mass_inertia", "rest_stability", "rest_penetration", "joint_sweep")


# ----- one object (in a child process) ------------------------------------------------------------
def cpu_now() -> float:
    """CPU seconds of this process and its finished children (CoACD workers)."""
    from benchmarks.measure_check_validity import cpu_seconds

    return cpu_seconds()


def _verdict(report, cpu_s: float) -> dict:
    failed = [name for name, check in report.checks.items() if not check.passed]
    sweep = report.checks.get("joint_sweep")
    out = {"passed": report.passed, "failed": failed, "checks": {k: v.passed for k, v in report.checks.items()},
           "reasons": {name: str(report.checks[name].details.get("reason", "")) for name in failed},
           "cpu_s": round(cpu_s, 2)}
    if sweep is not None and "joints" in sweep.details:
        out["sweep"] = {k: [j["reached"], j["returned"]] + ([j["verdict_by"]] if "verdict_by" in j else [])
                        for k, j in sweep.details["joints"].items()}
    loads = report.checks.get("physx_loads")
    if loads is not None:
        out["physx_loads"] = {k: loads.details.get(k) for k in ("split", "cooked_moved", "carriers", "filtered_pairs")}
    return out


def both_engines(asset) -> dict:
    """The MuJoCo verdict and the PhysX verdict of ``asset`` (one CoACD process)."""
    from spark_bench.sim.checks import run_checks
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.options import ConvertOptions
    from spark_bench.sim.physx.engines import physx_report

    options = ConvertOptions(workers=1)
    start = cpu_now()
    mujoco = run_checks(asset, options)
    mujoco_cpu = cpu_now() - start
    start = cpu_now()
    if not mujoco.checks["mesh_files"].passed:
        return {"mujoco": _verdict(mujoco, mujoco_cpu), "physx": None}
    prepared = prepare(asset, options)  # from the shape cache MuJoCo's run filled
    prepare_cpu = cpu_now() - start
    start = cpu_now()
    physx = physx_report(prepared, diagnose=False)  # the PCM-off verdict is this script's own column
    physx.checks = {"mesh_files": mujoco.checks["mesh_files"], **physx.checks}
    out = {"mujoco": _verdict(mujoco, mujoco_cpu), "physx": _verdict(physx, cpu_now() - start)}
    out["physx"]["prepare_cpu_s"] = round(prepare_cpu, 2)
    if not agrees(out):
        out["physx_no_pcm"] = no_pcm_verdict(prepared)
    return out


def no_pcm_verdict(prepared) -> dict:
    """PhysX's verdict with its persistent contact manifolds off (a diagnosis of a disagreement: PCM is the default
    of SAPIEN and ManiSkill3, and the checks')."""
    from spark_bench.sim.physx.engines import physx_report

    start = cpu_now()
    report = physx_report(prepared, pcm=False)
    return _verdict(report, cpu_now() - start)


def redo_physx(rows: dict[str, dict], objects: list[tuple[str, str, Path]], everything: bool) -> None:
    """PhysX's verdicts again on the stored rows, MuJoCo's kept (the objects and twins made again, their hulls from
    the shape cache), in this process: every entry (``everything``), else only the PCM-off verdict of the
    disagreements that lack it."""
    from benchmarks.broken_twins import make_twin
    from spark_bench.data import load_object
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.options import ConvertOptions
    from spark_bench.sim.physx.engines import physx_report

    folders = {stored_path(Path(), s, i).stem: f for s, i, f in objects}
    for key, row in rows.items():
        entries = [("intact", row.get("intact"))] + [(t, t) for t in row.get("twins", [])]
        todo = [(k, e) for k, e in entries if e and "error" not in e and e.get("physx")
                and (everything or (not agrees(e) and "physx_no_pcm" not in e))]
        if not todo or key not in folders:
            continue
        asset = load_object(folders[key])
        for kind, entry in todo:
            target = asset if kind == "intact" else make_twin(asset, entry["joint"], entry["kind"]).asset
            prepared = prepare(target, ConvertOptions(workers=1))
            if everything:
                start = cpu_now()
                report = physx_report(prepared, diagnose=False)
                report.checks = {"mesh_files": _passed_check(), **report.checks}
                entry["physx"] = {**_verdict(report, cpu_now() - start),
                                  "prepare_cpu_s": entry["physx"].get("prepare_cpu_s")}
                entry.pop("physx_no_pcm", None)
            if not agrees(entry):
                entry["physx_no_pcm"] = no_pcm_verdict(prepared)
        print(f"{key}: PhysX verdicts made again", flush=True)


def _passed_check():
    from spark_bench.sim.results import CheckResult

    return CheckResult(True, 0.0)  # the intact object's mesh files loaded: MuJoCo's run checked them


def twin_rows(asset, judge: bool) -> list[dict]:
    """Both engines' verdicts on every broken twin of ``asset`` (a twin that cannot be built is left out)."""
    from benchmarks.broken_twins import applicable_kinds, make_twin
    from benchmarks.clean_break import judge_break, path_crossing
    from benchmarks.measure_check_validity import broken_joints

    rows = []
    for joint in broken_joints(asset):
        intact_path = path_crossing(asset, joint) if judge else None  # shared by the joint's twins
        for kind in applicable_kinds(asset.joints[joint]):
            try:
                twin = make_twin(asset, joint, kind)
            except ValueError:
                continue
            row = {"joint": joint, "kind": kind, "part": twin.part, "description": twin.description}
            if judge:
                row["clean"] = bool(judge_break(asset, twin.asset, joint, intact_path).clean)
            try:
                row.update(both_engines(twin.asset))
            except Exception as exc:  # one twin must not end the object's run
                row["error"] = f"{type(exc).__name__}: {exc}"
            rows.append(row)
    return rows


def measure_object(folder: Path, twins: bool, judge: bool) -> dict:
    from spark_bench.data import load_object

    asset = load_object(folder)
    row = {"object": folder.name, "category": asset.category, "intact": both_engines(asset)}
    row["twins"] = twin_rows(asset, judge) if twins else []
    return row


# ----- the run ------------------------------------------------------------------------------------
def run_all(objects: list[tuple[str, str, Path]], store: Path, args) -> dict[str, dict]:
    """Measure every object in child processes (``args.jobs`` at once), reusing stored results."""
    from benchmarks.child_runs import run_in_children

    child_args = (["--no-twins"] if not args.twins else []) + (["--no-judge"] if not args.judge else [])
    return run_in_children(objects, store, "benchmarks.measure_engine_agreement", child_args, home=args.home,
                           jobs=args.jobs, timeout=args.timeout, fresh=args.fresh, describe=summary_line)


def summary_line(row: dict) -> str:
    if "error" in row:
        return f"error: {row['error']}"
    verdicts = [row["intact"]] + [t for t in row["twins"] if "error" not in t]
    agree = sum(agrees(v) for v in verdicts)
    return f"{agree}/{len(verdicts)} verdicts agree ({len(row['twins'])} twins)"


# ----- the report ---------------------------------------------------------------------------------
def agrees(entry: dict) -> bool:
    """Whether both engines gave the same verdict (an object PhysX was not asked about agrees: mesh files)."""
    if entry.get("physx") is None:
        return True
    return entry["mujoco"]["passed"] == entry["physx"]["passed"]


def differing_checks(entry: dict) -> list[str]:
    if entry.get("physx") is None:
        return []
    m, p = entry["mujoco"]["checks"], entry["physx"]["checks"]
    return [name for name in SHARED_CHECKS if name in m and name in p and m[name] != p[name]]


def tally(entries: list[dict]) -> dict:
    """Counts of a list of verdict pairs: both pass, both fail, only one fails, checks agreeing, CPU seconds."""
    out = {"n": 0, "both_pass": 0, "both_fail": 0, "mujoco_only_fails": 0, "physx_only_fails": 0,
           "checks": 0, "checks_agree": 0, "mujoco_cpu_s": 0.0, "physx_cpu_s": 0.0}
    for entry in entries:
        if entry.get("physx") is None or "error" in entry:
            continue
        m, p = entry["mujoco"]["passed"], entry["physx"]["passed"]
        out["n"] += 1
        key = "both_pass" if m and p else "both_fail" if not m and not p else \
            "mujoco_only_fails" if p else "physx_only_fails"
        out[key] += 1
        shared = [n for n in SHARED_CHECKS if n in entry["mujoco"]["checks"] and n in entry["physx"]["checks"]]
        out["checks"] += len(shared)
        out["checks_agree"] += len(shared) - len(differing_checks(entry))
        out["mujoco_cpu_s"] += entry["mujoco"]["cpu_s"]
        out["physx_cpu_s"] += entry["physx"]["cpu_s"]
    return out


def rate(part: int, whole: int) -> str:
    return child_rate(part, whole, digits=1)


def _rows_by_set(rows: dict[str, dict]) -> dict[str, dict[str, list]]:
    out: dict[str, dict[str, list]] = {}
    for row in rows.values():
        if "error" in row:
            continue
        entry = out.setdefault(row["set"], {"intact": [], "twins": [], "clean twins": []})
        entry["intact"].append(row["intact"])
        entry["twins"] += [t for t in row["twins"] if "error" not in t]
        entry["clean twins"] += [t for t in row["twins"] if "error" not in t and t.get("clean")]
    return out


#: The causes of a disagreement :func:`cause_of` tells apart, in report order.
CAUSES = {
    "pcm": "PhysX's persistent contact manifolds (PCM, its default and ManiSkill3's): with them off PhysX agrees",
    "surfaces": "the part's surface meets the other part's on its path: PhysX's rigid contacts stop it, MuJoCo's "
                "soft contacts let its servo push it through",
    "hulls": "only the hulls meet on the path, by less than the clearance the conversion leaves (a graze, or a "
             "fraction of a millimetre against the motion): PhysX's rigid contact stops the part, MuJoCo's soft "
             "contact lets it pass",
    "rest overlap": "a part that starts inside another part's hulls at rest: the two engines push it out by "
                    "different amounts (the drift tolerance is 2 % of its range)",
    "other": "none of the above (read both reasons)",
}


def cause_of(entry: dict) -> str:
    """The cause (a key of :data:`CAUSES`) of a disagreement, from the two verdicts and the PCM-off one."""
    mujoco, physx = entry["mujoco"], entry["physx"]
    no_pcm = entry.get("physx_no_pcm")
    if no_pcm is not None and no_pcm["passed"] == mujoco["passed"]:
        return "pcm"
    said = " ".join(physx["reasons"].values()) + " " + " ".join(mujoco["reasons"].values())
    if "rest_stability" in set(mujoco["failed"]) ^ set(physx["failed"]):
        return "rest overlap"
    if "the object itself blocks" in said:
        return "surfaces"
    if "only the hulls" in said or "do not meet when" in said:
        return "hulls"
    return "other"


def _disagreement(label: str, entry: dict) -> str:
    """One table row: the checks that differ, what each engine said, the joints either swept short, and PhysX's
    verdict without PCM (where the run diagnosed it)."""
    said = []
    for engine in ("mujoco", "physx"):
        verdict = entry[engine]
        reasons = "; ".join(f"{k}: {v}" for k, v in verdict["reasons"].items()) or "passes every check"
        said.append(f"{engine}: {'pass' if verdict['passed'] else 'FAIL'} ({reasons})")
    sweeps = {e: entry[e].get("sweep", {}) for e in ("mujoco", "physx")}
    short = [j for j in sorted(set(sweeps["mujoco"]) | set(sweeps["physx"]))
             if any(min(sweeps[e].get(j, [1.0, 1.0])[:2]) < 0.9 for e in sweeps)]
    reached = "; ".join(f"{j}: MuJoCo {sweeps['mujoco'].get(j, ['-'])[:2]}, PhysX {sweeps['physx'].get(j, ['-'])[:2]}"
                        for j in short)
    no_pcm = entry.get("physx_no_pcm")
    pcm = "not run" if no_pcm is None else "pass" if no_pcm["passed"] else f"FAIL ({', '.join(no_pcm['failed'])})"
    cause = cause_of(entry) if not agrees(entry) else "a check differs, not the verdict"
    text = (f"| {label} | {', '.join(differing_checks(entry)) or 'verdict'} | {cause} | " + " / ".join(said)
            + (f" / reached, returned: {reached}" if reached else "") + f" | {pcm} |")
    return text.replace("\n", " ")


def causes_count(rows: dict[str, dict]) -> dict[str, int]:
    """How many disagreeing verdicts (intact and twins) each cause explains."""
    out: dict[str, int] = {}
    for row in rows.values():
        for entry in [row.get("intact")] + list(row.get("twins", [])):
            if entry and "error" not in entry and entry.get("physx") and not agrees(entry):
                out[cause_of(entry)] = out.get(cause_of(entry), 0) + 1
    return out


def markdown(rows: dict[str, dict], asked: int) -> str:
    lines = ["# MuJoCo and PhysX: do the sim checks agree? (engine agreement)", "",
             f"Written by `benchmarks/measure_engine_agreement.py` ({time.strftime('%Y-%m-%d')}): the sim checks in "
             "MuJoCo and in PhysX (SAPIEN 3 on the CPU, `spark-bench check --engine all`) on each object as it is and "
             "on the broken twins of its drawers, doors and lids (`benchmarks/broken_twins.py`; *clean*: "
             "`benchmarks/clean_break.py` finds the part passing through the object).", "",
             f"Coverage: {len(rows)} of the {asked} objects asked for were measured"
             + (" (the others were not run: `--report-only` on a partial run)." if len(rows) < asked else "."), "",
             "| set | what | verdicts | agree | both pass | both fail | only MuJoCo fails | only PhysX fails "
             "| checks agreeing | CPU s MuJoCo | CPU s PhysX |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for set_name, groups in sorted(_rows_by_set(rows).items()):
        for what, entries in groups.items():
            t = tally(entries)
            if not t["n"]:
                continue
            lines.append(f"| {set_name} | {what} | {t['n']} | {rate(t['both_pass'] + t['both_fail'], t['n'])} "
                         f"| {t['both_pass']} | {t['both_fail']} | {t['mujoco_only_fails']} | {t['physx_only_fails']} "
                         f"| {rate(t['checks_agree'], t['checks'])} | {t['mujoco_cpu_s']:.0f} | {t['physx_cpu_s']:.0f} |")
    lines += ["", "CPU s MuJoCo: conversion (CoACD workers included, cache as the run found it) and the MuJoCo "
              "checks; CPU s PhysX: loading the prepared object into SAPIEN and the PhysX checks.", "",
              "## Causes of the disagreements", "", "| cause | verdicts | what it is |", "|---|---|---|"]
    counts = causes_count(rows)
    lines += [f"| {key} | {counts.get(key, 0)} | {text} |" for key, text in CAUSES.items()]
    lines += ["", "## Disagreements", "", "PhysX without PCM: PhysX's verdict with its persistent contact manifolds off (on in "
              "SAPIEN, ManiSkill3 and these checks).", "",
              "| object | checks that differ | cause | what each engine said | PhysX without PCM |",
              "|---|---|---|---|---|"]
    for row in sorted(rows.values(), key=lambda r: (r.get("set", ""), r["object"])):
        if "error" in row:
            lines.append(f"| {row['set']} {row['object']} | error | | {row['error']} | |")
            continue
        if not agrees(row["intact"]) or differing_checks(row["intact"]):
            lines.append(_disagreement(f"{row['set']} {row['object']} (intact)", row["intact"]))
        for twin in row["twins"]:
            if "error" in twin:
                lines.append(f"| {row['set']} {row['object']} {twin['joint']} {twin['kind']} | error | | "
                             f"{twin['error']} | |")
            elif not agrees(twin) or differing_checks(twin):
                clean = "clean" if twin.get("clean") else "not clean"
                lines.append(_disagreement(f"{row['set']} {row['object']} {twin['joint']} {twin['kind']} ({clean})",
                                           twin))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    from benchmarks.child_runs import add_run_arguments, object_sets

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(parser, "engine_agreement", RESULTS)
    parser.add_argument("--no-twins", dest="twins", action="store_false", help="the intact objects only")
    parser.add_argument("--no-judge", dest="judge", action="store_false", help="do not judge the twins' breaks")
    parser.add_argument("--report-only", action="store_true", help="write the report of the stored results only")
    parser.add_argument("--diagnose", action="store_true",
                        help="add PhysX's verdict without PCM to the stored disagreements, then report")
    parser.add_argument("--redo-physx", action="store_true",
                        help="make PhysX's verdicts of the stored results again (MuJoCo's kept), then report")
    args = parser.parse_args(argv)
    if args.one is not None:  # the child: one object, its result written to --out
        row = measure_object(args.one, args.twins, args.judge)
        Path(args.out).write_text(json.dumps(row, indent=1))
        return 0
    objects = object_sets(args)
    if not objects:
        print("nothing to measure (shared objects absent?)")
        return 0
    if args.report_only or args.diagnose or args.redo_physx:  # the stored results, MuJoCo not run again
        rows = stored_rows(args.store, objects)
        if args.diagnose or args.redo_physx:
            redo_physx(rows, objects, everything=args.redo_physx)
            for key, row in rows.items():
                (args.store / f"{key}.json").write_text(json.dumps(row, indent=1))
    else:
        rows = run_all(objects, args.store, args)
    text = markdown(rows, asked=len(objects))
    print(text)
    if str(args.out) != "-":
        Path(f"{args.out}.md").write_text(text)
        Path(f"{args.out}.json").write_text(json.dumps({"objects": rows}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
