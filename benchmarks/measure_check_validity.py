"""Do the sim checks catch a wrong joint? Broken twins of real and synth objects, checked like any asset.

For every object (default: the 75 of ``../shared/partnet_dev``, its halves from ``partnet_dev_split.json``, the 7
of ``../shared/real_objects``; ``--cases BENCH`` adds a prepared benchmark's ground truths, e.g. synth-v1's), this
script runs ``spark-bench check`` on the object as it is (the *intact* object) and on broken twins of each of its
drawers, doors and lids (a part labelled ``drawer``, ``door`` or ``lid`` in ``semantics.txt``, as ``sim_real``
counts them), one per kind of break (:mod:`benchmarks.broken_twins`): the axis reversed, the pivot moved to the
part's far edge, a slide turned 90 degrees about the up axis, the joint type swapped.

A twin counts only where it is a clean break (:mod:`benchmarks.clean_break`: its part passes through the object's
own surfaces before 90 % of its range, and the intact part's path does not) and its intact object passes every
check (else a failure says nothing of the break). Every twin left out is listed with its reason. A clean twin is
*caught* when its check fails, and caught *on its part* when the failure names the broken joint or its part.

Each object runs in a child process (``--jobs`` at once) and its result is stored as
``<store>/<label>/<set>__<id>.json``: an interrupted run resumes, and ``--compare LABEL`` adds an earlier run's catch rates
and every verdict that differs from it. The report is ``benchmarks/results/check_validity.md`` and ``.json``.

Run: ``nice -n 10 python -m benchmarks.measure_check_validity [--half tune|holdout|all] [--cases BENCH]
[--ids 7310 ...] [--jobs 2] [--label after] [--compare before] [--home DIR]``.
"""

from __future__ import annotations

import argparse
import json
import re
import resource
import sys
import time
from collections import Counter
from pathlib import Path

from benchmarks.child_runs import rate, stored_rows

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "check_validity"
#: Parts whose joints are broken: drawers, doors and lids, as ``sim_real`` counts them (``semantics.txt``).
OPENABLE = re.compile(r"(^|_)(drawer|door|lid)$")
#: The sets of objects, in report order.
SETS = ("partnet_dev tune", "partnet_dev holdout", "real_objects", "synth-v1")


# ----- one object (in a child process) ------------------------------------------------------------
def broken_joints(asset) -> list[str]:
    """The revolute and prismatic joints of ``asset`` whose own part is a drawer, door or lid."""
    from benchmarks.broken_twins import applicable_kinds

    out = []
    for joint in asset.movable_joints():
        labels = [asset.links[name].label for name in asset.part_of_joint(joint.name)]
        if applicable_kinds(joint) and any(OPENABLE.search(label or "") for label in labels):
            out.append(joint.name)
    return out


def verdict_of(asset) -> dict:
    """``spark-bench check`` of ``asset`` (in memory, one CoACD process): passed, failed checks, their reasons."""
    from spark_bench.sim.checks import run_checks
    from spark_bench.sim.options import ConvertOptions

    start = time.process_time()
    report = run_checks(asset, ConvertOptions(workers=1))
    failed = [name for name, check in report.checks.items() if not check.passed]
    sweep = report.checks.get("joint_sweep")
    return {"passed": not failed, "failed": failed,
            "reasons": {name: str(report.checks[name].details.get("reason", "")) for name in failed},
            "sweep_failed": list(sweep.details.get("failed", [])) if sweep is not None else [],
            "cpu_s": round(time.process_time() - start, 2)}


def names_part(verdict: dict, joint: str, part: str) -> bool:
    """Whether a failing verdict names the broken joint or its part."""
    if joint in verdict["sweep_failed"]:
        return True
    pattern = re.compile(rf"\b({re.escape(joint)}|{re.escape(part)})\b")
    return any(pattern.search(reason) for reason in verdict["reasons"].values())


#: How a sweep's reason says what stopped a part: ``link_0 runs into link_1 at 12 deg`` (or ``at 4 mm``).
RUNS_INTO = re.compile(r"\b(\S+) runs into (\S+) at -?[\d.]+ (deg|mm)\b")


def says_what_it_caught(verdict: dict, joint: str, part: str) -> bool:
    """Whether a failing verdict says what it caught (issue #42): it names the broken joint or its part, the body
    a part ran into and the angle or distance where it stopped."""
    if verdict["passed"] or not names_part(verdict, joint, part):
        return False
    return any(RUNS_INTO.search(reason) for reason in verdict["reasons"].values())


def twin_entry(asset, joint: str, kind: str, intact_passed: bool, intact_path=None) -> dict:
    """One twin: how it was made, whether it is a clean break, and (clean, intact passing) its verdict.

    :param intact_path: the intact joint's :func:`~benchmarks.clean_break.path_crossing`, shared by its twins
    """
    from benchmarks.broken_twins import make_twin
    from benchmarks.clean_break import judge_break

    entry: dict = {"joint": joint, "kind": kind}
    signs = (1, -1) if kind == "slide_turned" else (1,)
    for sign in signs:
        try:
            twin = make_twin(asset, joint, kind, sign)
        except ValueError as exc:
            entry.update(status="not applicable", reason=str(exc))
            return entry
        judgement = judge_break(asset, twin.asset, joint, intact_path)
        entry.update(part=twin.part, description=twin.description, judgement=judgement.to_dict())
        if judgement.clean:
            break
    if not entry["judgement"]["clean"]:
        entry.update(status="not clean", reason=entry["judgement"]["reason"])
        return entry
    if not intact_passed:
        entry.update(status="intact fails", reason="the intact object fails a check: a failure says nothing")
        return entry
    try:
        verdict = verdict_of(twin.asset)
    except Exception as exc:  # one twin must not end the object's run
        entry.update(status="error", reason=f"{type(exc).__name__}: {exc}")
        return entry
    entry.update(status="caught" if not verdict["passed"] else "missed", verdict=verdict)
    return entry


def measure_object(folder: Path, kinds: tuple[str, ...]) -> dict:
    """The intact verdict and every twin of one object folder."""
    from benchmarks.broken_twins import applicable_kinds
    from benchmarks.clean_break import path_crossing
    from spark_bench.data import load_object

    asset = load_object(folder)
    joints = broken_joints(asset)
    if not joints:  # nothing to break: not an object of this benchmark
        return {"object": folder.name, "category": asset.category, "intact": None, "twins": []}
    intact = verdict_of(asset)
    twins = []
    for joint in joints:
        wanted = [kind for kind in applicable_kinds(asset.joints[joint]) if kind in kinds]
        intact_path = path_crossing(asset, joint) if wanted else None  # the control every twin of it is judged by
        for kind in wanted:
            twins.append(twin_entry(asset, joint, kind, intact["passed"], intact_path))
    return {"object": folder.name, "category": asset.category, "intact": intact, "twins": twins}


# ----- the run ------------------------------------------------------------------------------------
def cpu_seconds() -> float:
    """CPU seconds of this process and its finished children (CoACD workers)."""
    return sum(u.ru_utime + u.ru_stime for u in (resource.getrusage(resource.RUSAGE_SELF),
                                                  resource.getrusage(resource.RUSAGE_CHILDREN)))


def run_all(objects: list[tuple[str, str, Path]], store: Path, args) -> dict[str, dict]:
    """Measure every object in child processes (``args.jobs`` at once), reusing stored results."""
    from benchmarks.child_runs import run_in_children

    return run_in_children(objects, store, "benchmarks.measure_check_validity", ["--kinds", *args.kinds],
                           home=args.home, jobs=args.jobs, timeout=args.timeout, fresh=args.fresh,
                           describe=describe_row)


def describe_row(row: dict) -> str:
    """One line on a measured object: its intact verdict and its twins' statuses."""
    if "error" in row:
        return f"error: {row['error']}"
    intact = row.get("intact")
    said = "no drawer, door or lid" if intact is None else "pass" if intact["passed"] else "FAIL"
    return f"intact {said}  {dict(Counter(t['status'] for t in row.get('twins', [])))}"


# ----- the report ---------------------------------------------------------------------------------
def summarize(rows: dict[str, dict], kinds: tuple[str, ...]) -> dict:
    """Per set: intact objects passing, and per kind the twins built, left out (by why), clean, caught."""
    out: dict[str, dict] = {}
    for row in rows.values():
        entry = out.setdefault(row["set"], {"asked": 0, "objects": 0, "intact_passed": 0, "errors": 0,
                                            "cpu_s": 0.0, "kinds": {k: Counter() for k in kinds}})
        entry["asked"] += 1
        if row.get("intact", 0) is None:  # no drawer, door or lid
            continue
        entry["objects"] += 1
        if "error" in row:
            entry["errors"] += 1
            continue
        entry["intact_passed"] += bool(row["intact"]["passed"])
        entry["cpu_s"] += row.get("cpu_s", 0.0)
        for twin in row["twins"]:
            counts = entry["kinds"].setdefault(twin["kind"], Counter())
            counts["built" if twin["status"] != "not applicable" else "not applicable"] += 1
            counts[twin["status"]] += 1
            if twin["status"] in ("caught", "missed"):
                counts["clean"] += 1
            if twin["status"] == "caught" and says_what_it_caught(twin["verdict"], twin["joint"], twin["part"]):
                counts["named"] += 1
    return out


def markdown(summary: dict, rows: dict[str, dict], args) -> str:
    lines = ["# Sim checks against broken twins (check validity)", "",
             f"Written by `benchmarks/measure_check_validity.py` ({time.strftime('%Y-%m-%d')}, label `{args.label}`): "
             "`spark-bench check` on each object as it is and on its broken twins "
             "(`benchmarks/broken_twins.py`); a twin counts where it is a clean break "
             "(`benchmarks/clean_break.py`) and its intact object passes every check.", "",
             "## Catch rate per kind of break", "",
             "Caught: the check fails; said: the failure names the broken joint or its part, the body a part ran "
             "into and the angle or distance where it stopped. Coverage: the "
             "objects with a drawer, door or lid out of those asked (the others have nothing to break), and the "
             "clean twins of objects whose intact form passes, out of the twins built.", "",
             "| set | objects with a drawer, door or lid / asked (errors) | intact objects passing | kind | twins built "
             "| left out (not clean / intact fails / error) | clean twins | caught | caught, saying part, body and where |",
             "|---|---|---|---|---|---|---|---|---|"]
    for set_name in [s for s in SETS if s in summary] + sorted(set(summary) - set(SETS)):
        entry = summary[set_name]
        intact = rate(entry["intact_passed"], entry["objects"] - entry["errors"])
        for kind, counts in entry["kinds"].items():
            if not counts.get("built"):
                continue
            left = f"{counts['not clean']} / {counts['intact fails']} / {counts['error']}"
            lines.append(f"| {set_name} | {entry['objects']}/{entry['asked']} ({entry['errors']}) | {intact} | {kind} "
                         f"| {counts['built']} | {left} | {counts['clean']} "
                         f"| {rate(counts['caught'], counts['clean'])} | {rate(counts['named'], counts['clean'])} |")
    lines += ["", "## Intact objects that fail a check", "",
              "Their twins are left out (`intact fails`).", "", "| set | object | category | failed checks |",
              "|---|---|---|---|"]
    for row in sorted(rows.values(), key=lambda r: (r["set"], r["object"])):
        if "error" in row:
            lines.append(f"| {row['set']} | {row['object']} | | error: {row['error']} |")
        elif row["intact"] is not None and not row["intact"]["passed"]:
            lines.append(f"| {row['set']} | {row['object']} | {row['category']} | {', '.join(row['intact']['failed'])} |")
    lines += ["", "## Missed twins", "", "| set | object | joint | kind | twin | clean break |", "|---|---|---|---|---|---|"]
    for row in sorted(rows.values(), key=lambda r: (r["set"], r["object"])):
        for twin in row.get("twins", []):
            if twin["status"] == "missed":
                lines.append(f"| {row['set']} | {row['object']} | {twin['joint']} | {twin['kind']} | "
                             f"{twin['description']} | {twin['judgement']['reason']} |")
    lines += ["", "## Every twin", "",
              "| set | object | joint | kind | status | why / what the check said |", "|---|---|---|---|---|---|"]
    for row in sorted(rows.values(), key=lambda r: (r["set"], r["object"])):
        for twin in row.get("twins", []):
            if twin["status"] in ("caught", "missed"):
                verdict = twin["verdict"]
                said = "; ".join(f"{k}: {v}" for k, v in verdict["reasons"].items()) or "passes every check"
            else:
                said = twin.get("reason", "")
            said = said.replace("|", "/")
            lines.append(f"| {row['set']} | {row['object']} | {twin['joint']} | {twin['kind']} | {twin['status']} "
                         f"| {said[:400]} |")
    return "\n".join(lines) + "\n"


def verdict_changes(rows: dict[str, dict], before_dir: Path) -> list[str]:
    """Twins and intact objects whose verdict differs from the run stored in ``before_dir``."""
    out = []
    for key, row in sorted(rows.items()):
        path = before_dir / f"{key}.json"
        if not path.is_file() or "error" in row:
            continue
        old = json.loads(path.read_text())
        if "error" in old or old["intact"] is None or row["intact"] is None:
            continue
        if old["intact"]["passed"] != row["intact"]["passed"]:
            out.append(f"{key} intact: {'pass' if old['intact']['passed'] else 'FAIL'} -> "
                       f"{'pass' if row['intact']['passed'] else 'FAIL'} {row['intact']['failed']}")
        previous = {(t["joint"], t["kind"]): t["status"] for t in old["twins"]}
        for twin in row["twins"]:
            was = previous.get((twin["joint"], twin["kind"]))
            if was is not None and was != twin["status"]:
                out.append(f"{key} {twin['joint']} {twin['kind']}: {was} -> {twin['status']}")
    return out


def comparison(rows: dict[str, dict], summary: dict, args) -> str:
    """Catch rates of the run labelled ``args.compare`` beside this run's, and every verdict that differs."""
    objects = [(row["set"], row["object"], None) for row in rows.values()]
    before = summarize(stored_rows(args.store / args.compare, objects), tuple(args.kinds))
    lines = ["", f"## Compared with `{args.compare}`", "",
             f"The same objects and twins as stored by the run labelled `{args.compare}`.", "",
             f"| set | kind | caught ({args.compare}) | caught ({args.label}) |", "|---|---|---|---|"]
    for set_name in [s for s in SETS if s in summary]:
        for kind, counts in summary[set_name]["kinds"].items():
            old = before.get(set_name, {}).get("kinds", {}).get(kind, Counter())
            if counts.get("built"):
                lines.append(f"| {set_name} | {kind} | {rate(old['caught'], old['clean'])} "
                             f"| {rate(counts['caught'], counts['clean'])} |")
    lines += ["", "Verdicts that differ:", ""]
    lines += [f"- {line}" for line in verdict_changes(rows, args.store / args.compare) or ["none"]]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    from benchmarks.broken_twins import KINDS
    from benchmarks.child_runs import add_run_arguments, object_sets

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(parser, "check_validity", RESULTS)
    parser.add_argument("--kinds", nargs="*", default=list(KINDS), choices=KINDS, help="kinds of break")
    parser.add_argument("--label", default="current", help="name of this run's results (under STORE/LABEL/)")
    parser.add_argument("--compare", default=None,
                        help="report this label's catch rates and changed verdicts beside this run's")
    args = parser.parse_args(argv)
    if args.one is not None:  # the child: one object, its result written to --out
        row = measure_object(args.one, tuple(args.kinds))
        row["cpu_s"] = round(cpu_seconds(), 1)
        Path(args.out).write_text(json.dumps(row, indent=1))
        return 0
    objects = object_sets(args)
    if not objects:
        print("nothing to measure (shared objects absent?)")
        return 0
    rows = run_all(objects, args.store / args.label, args)
    summary = summarize(rows, tuple(args.kinds))
    text = markdown(summary, rows, args)
    if args.compare:
        text += comparison(rows, summary, args)
    print(text.split("## Intact objects")[0])
    if str(args.out) != "-":
        Path(f"{args.out}.md").write_text(text)
        plain = {name: {**entry, "kinds": {k: dict(c) for k, c in entry["kinds"].items()}}
                 for name, entry in summary.items()}
        Path(f"{args.out}.json").write_text(json.dumps({"label": args.label, "summary": plain,
                                                        "objects": rows}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
