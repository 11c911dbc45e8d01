"""Scale, measured (issue 37, item 3): CPU seconds per real object of ``data prepare`` and oracle ``eval``.

For a sample of real PartNet-Mobility objects (default: 12 of partnet_dev's ``holdout`` half, stratified by
category, fixed seed), each object on its own in a fresh empty ``$SPARK_BENCH_HOME`` (cold: no CoACD,
link-shape or contact cache): ``spark-bench data prepare --src SRC --ids ID --out <home>/bench``, then
``spark-bench eval --method oracle --bench <home>/bench --workers 1 --no-progress --json`` (sim checks and
opening score on, their defaults), then the same eval warm (every cache filled, a fresh results store).
Per command: wall and CPU seconds (user + sys of the child and its CoACD workers: ``RUSAGE_CHILDREN``);
per object, from the stored row: verdicts, stage timings, CoACD calls. A failing object is a row with its
error. Then the projection to PartNet-Mobility's 2,346 objects (mean CPU seconds with a bootstrap 90 %
interval, in CPU hours) against the target of 10 CPU hours, and the wall time on K nodes x C cores.
``--json`` and the report are written after every object (a stopped run leaves a report of what finished).

Run: ``nice -n 10 python -m benchmarks.measure_scale [--src DIR] [--ids ...] [--sample N] [--seed S]
[--json FILE] [--resume] [--results FILE] [--stop-after-min M] [--report-only]``.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import resource
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT.parent / "shared" / "partnet_dev"
SPLIT = ROOT / "benchmarks" / "results" / "partnet_dev_split.json"
RESULTS, JSON_OUT = (ROOT / "benchmarks" / "results" / f"scale.{ext}" for ext in ("md", "json"))
#: Objects of PartNet-Mobility (its 46 categories), the projection's population.
PARTNET_MOBILITY_OBJECTS = 2346
#: Issue 37's target for ``data prepare`` + the oracle's ``eval`` with sim over all of them.
TARGET_CPU_H = 10.0
#: Clusters the wall time is projected on: (nodes, cores per node).
CLUSTERS = ((1, 2), (4, 16), (16, 16))
DEFAULT_SAMPLE, DEFAULT_SEED = 12, 0
NOTES = "<!-- notes: kept when the script rewrites the file -->"


# ----- the sample ---------------------------------------------------------------------------------
def apportion(counts: dict[str, int], n: int) -> dict[str, int]:
    """How many of ``n`` draws each category gets: proportional to its count (largest remainder), at least
    one per category while ``n`` allows, never more than its count.

    :param counts: objects per category
    :param n: draws in all (capped at the total count)
    :returns: draws per category, summing to ``min(n, sum(counts))``
    """
    n = min(n, sum(counts.values()))
    names = sorted(counts, key=lambda c: (-counts[c], c))
    quota = {c: n * counts[c] / sum(counts.values()) for c in names}
    floor_one = n >= len(names)
    take = {c: min(counts[c], max(int(quota[c]), 1 if floor_one else 0)) for c in names}
    while sum(take.values()) > n:  # the minimum of one overshot: take back from the largest share
        c = max((c for c in names if take[c] > 1), key=lambda c: (take[c] - quota[c], c))
        take[c] -= 1
    while sum(take.values()) < n:  # largest remainder first; ties by size then name
        c = max((c for c in names if take[c] < counts[c]), key=lambda c: (quota[c] - take[c], counts[c], c))
        take[c] += 1
    return take


def select_sample(ids_by_category: dict[str, list[str]], n: int, seed: int = DEFAULT_SEED) -> list[str]:
    """A stratified random sample of object ids, in round-robin order over the categories (so that a run
    stopped early still covers the categories).

    :param ids_by_category: object ids per category
    :param n: sample size
    :param seed: seed of the draw within each category
    :returns: the chosen ids, deterministic for the same input and seed
    """
    take = apportion({c: len(ids) for c, ids in ids_by_category.items()}, n)
    rng = random.Random(seed)
    drawn = {c: rng.sample(sorted(ids_by_category[c]), take[c]) for c in sorted(ids_by_category)}
    order = sorted(drawn, key=lambda c: (-len(drawn[c]), c))
    out = []
    for rank in range(max((len(v) for v in drawn.values()), default=0)):
        out += [drawn[c][rank] for c in order if rank < len(drawn[c])]
    return out


def category_of(folder: Path) -> str:
    """The PartNet-Mobility category of an object folder (``meta.json``'s ``model_cat``; ``?`` if absent)."""
    meta = folder / "meta.json"
    return str(json.loads(meta.read_text()).get("model_cat", "?")) if meta.is_file() else "?"


# ----- the statistics -----------------------------------------------------------------------------
def bootstrap_mean(values: list[float], level: float = 0.9, resamples: int = 10000,
                   seed: int = DEFAULT_SEED) -> tuple[float, float, float]:
    """The mean of ``values`` and its bootstrap percentile interval.

    :param values: one value per sampled object
    :param level: coverage of the interval (0.9: the 5th and 95th percentiles of the resampled means)
    :param resamples: bootstrap resamples
    :param seed: seed of the resampling
    :returns: ``(mean, low, high)``
    """
    data = np.asarray(values, dtype=float)
    if data.size == 0:
        raise ValueError("no values to bootstrap")
    rng = np.random.default_rng(seed)
    means = data[rng.integers(0, data.size, size=(resamples, data.size))].mean(axis=1)
    tail = (1.0 - level) / 2.0 * 100.0
    return float(data.mean()), float(np.percentile(means, tail)), float(np.percentile(means, 100.0 - tail))


def ok_rows(rows: list[dict]) -> list[dict]:
    """The rows whose two commands both finished (a number for each command's CPU seconds)."""
    return [r for r in rows if r.get("prepare", {}).get("cpu_s") is not None
            and r.get("eval", {}).get("cpu_s") is not None and "error" not in r]


def projection(rows: list[dict], objects: int = PARTNET_MOBILITY_OBJECTS, level: float = 0.9,
               seed: int = DEFAULT_SEED) -> dict:
    """Mean CPU seconds per object of each stage with its bootstrap interval, and the same times ``objects``
    in CPU hours.

    :param rows: measured rows (``ok_rows`` are used)
    :param objects: the population projected to
    :returns: ``{"n", "objects", "stages": {stage: {"mean_s", "low_s", "high_s", "cpu_h", "low_h", "high_h"}},
        "target_cpu_h", "over_target"}``; ``stages`` empty when no row finished
    """
    good = ok_rows(rows)
    out = {"n": len(good), "objects": objects, "level": level, "target_cpu_h": TARGET_CPU_H, "stages": {}}
    if not good:
        return out
    per_stage = {"prepare": [r["prepare"]["cpu_s"] for r in good], "eval": [r["eval"]["cpu_s"] for r in good]}
    per_stage["total"] = [a + b for a, b in zip(per_stage["prepare"], per_stage["eval"])]
    for stage, values in per_stage.items():
        mean, low, high = bootstrap_mean(values, level=level, seed=seed)
        out["stages"][stage] = {"mean_s": mean, "low_s": low, "high_s": high, "cpu_h": mean * objects / 3600,
                                "low_h": low * objects / 3600, "high_h": high * objects / 3600}
    out["over_target"] = out["stages"]["total"]["cpu_h"] / TARGET_CPU_H
    return out


def cluster_wall_h(total_cpu_h: float, longest_s: float, nodes: int, cores: int) -> float:
    """Wall hours of a run spread over ``nodes`` x ``cores``: the CPU hours shared evenly, but never less
    than the longest single object (one object is one task, it cannot be split).

    :param total_cpu_h: CPU hours of the whole run
    :param longest_s: wall seconds of the longest single object
    """
    return max(total_cpu_h / (nodes * cores), longest_s / 3600)


def category_means(rows: list[dict]) -> dict[str, dict]:
    """Per category: objects measured and their mean prepare, eval and total CPU seconds."""
    groups: dict[str, list[dict]] = defaultdict(list)
    for row in ok_rows(rows):
        groups[row["category"]].append(row)
    return {c: {"n": len(g), "prepare_s": float(np.mean([r["prepare"]["cpu_s"] for r in g])),
                "eval_s": float(np.mean([r["eval"]["cpu_s"] for r in g])),
                "total_s": float(np.mean([r["prepare"]["cpu_s"] + r["eval"]["cpu_s"] for r in g]))}
            for c, g in sorted(groups.items())}


def stage_shares(rows: list[dict]) -> dict[str, float]:
    """Where the CPU goes, summed over the finished rows: prepare and eval CPU seconds, the sim checks'
    CoACD CPU seconds (inside eval) and eval's stage wall seconds (the row's ``timings``)."""
    good = ok_rows(rows)
    out = {"prepare_cpu_s": sum(r["prepare"]["cpu_s"] for r in good),
           "eval_cpu_s": sum(r["eval"]["cpu_s"] for r in good),
           "sim_coacd_cpu_s": sum(r.get("sim_coacd_cpu_s") or 0.0 for r in good)}
    for row in good:
        for stage, seconds in (row.get("timings") or {}).items():
            out[f"eval_{stage}_wall_s"] = out.get(f"eval_{stage}_wall_s", 0.0) + float(seconds)
    warm = [r for r in good if (r.get("eval_warm") or {}).get("exit") == 0]
    out.update(warm_n=len(warm), warm_prepare_cpu_s=sum(r["prepare"]["cpu_s"] for r in warm),
               warm_cold_eval_cpu_s=sum(r["eval"]["cpu_s"] for r in warm),
               warm_eval_cpu_s=sum(r["eval_warm"]["cpu_s"] for r in warm))
    return out


def conversion_lines(shares: dict) -> list[str]:
    """What the caches save, over the objects whose eval also ran warm: cold less warm eval CPU is the
    conversion (CoACD calls, link shapes, contacts) of the sim checks and the opener together."""
    if not shares.get("warm_n"):
        return []
    total = shares["warm_prepare_cpu_s"] + shares["warm_cold_eval_cpu_s"]
    conversion = shares["warm_cold_eval_cpu_s"] - shares["warm_eval_cpu_s"]
    return [f"Over the {shares['warm_n']} objects whose eval also ran warm (the same home again, every cache "
            f"filled, a fresh results store): eval {shares['warm_cold_eval_cpu_s']:.0f} CPU s cold, "
            f"{shares['warm_eval_cpu_s']:.0f} warm. **The conversion the caches hold (CoACD calls, link "
            f"shapes, contacts; the sim checks' and the opener's) is {conversion:.0f} CPU s, "
            f"{conversion / total:.0%} of those objects' prepare + eval CPU**; prepare "
            f"{shares['warm_prepare_cpu_s'] / total:.0%}, the rest of eval "
            f"{shares['warm_eval_cpu_s'] / total:.0%}.", ""]


# ----- one object ---------------------------------------------------------------------------------
def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed_run(command: list[str], env: dict, cwd: Path, timeout: float) -> dict:
    """Run ``command``; its exit code, wall and CPU seconds (children included) and its last stderr line."""
    cpu, start = _children_cpu(), time.perf_counter()
    try:
        proc = subprocess.run(command, env=env, cwd=cwd, capture_output=True, text=True, timeout=timeout)
        code, err = proc.returncode, proc.stderr
    except subprocess.TimeoutExpired:
        code, err = None, f"ran over {timeout:g} s"
    result = {"exit": code, "wall_s": round(time.perf_counter() - start, 2),
              "cpu_s": round(_children_cpu() - cpu, 2)}
    if code != 0:
        result["error"] = (err.strip().splitlines() or [f"exit {code}"])[-1][:300]
    return result


def _coacd_results(home: Path) -> int:
    """CoACD results in a home's cache (``coacd/<key[:2]>/<key>.npz``): the distinct CoACD calls run there."""
    return len(list((home / "coacd").glob("??/*.npz")))


def stored_row(db: Path) -> dict:
    """The oracle's stored row of a one-case run: status, verdicts, CoACD calls and timings."""
    with sqlite3.connect(db) as con:
        con.row_factory = sqlite3.Row
        row = con.execute("SELECT * FROM results WHERE method = 'oracle' ORDER BY id DESC LIMIT 1").fetchone()
    if row is None:
        return {"error": "eval stored no row"}
    checks = json.loads(row["checks"] or "{}")
    sim = checks.get("sim", {})
    compiled = sim.get("checks", {}).get("mjcf_compiles", {})
    opened = checks.get("open", {})
    out = {"status": row["status"], "sim_pass": None if row["sim_pass"] is None else bool(row["sim_pass"]),
           "open_success": row["open_success"], "open_scored": opened.get("joints_scored"),
           "open_total": opened.get("joints_total"), "coacd_calls": compiled.get("coacd_calls"),
           "coacd_cache_hits": compiled.get("coacd_cache_hits"),
           "sim_coacd_cpu_s": (sim.get("seconds") or {}).get("coacd_cpu"),
           "sim_seconds": sim.get("seconds", {}),
           "timings": {k: round(float(v), 2) for k, v in json.loads(row["timings"] or "{}").items()}}
    if row["status"] != "ok":
        out["error"] = f"{row['stage']}: {row['reason']}"[:300]
    return out


def warm_eval(cli: list[str], bench: Path, env: dict, home: Path, timeout: float) -> dict:
    """The oracle's ``eval`` of the case again, in the same home (every cache filled by the cold run), into
    a fresh results store: its CPU and wall seconds and stage timings (an eval without conversion)."""
    db = home / "warm.sqlite"
    warm = timed_run(cli + ["eval", "--method", "oracle", "--bench", str(bench), "--workers", "1",
                            "--no-progress", "--json", "--db", str(db)], env, home, timeout)
    return dict(warm, timings=stored_row(db).get("timings", {}) if db.is_file() else {})


def measure_object(src: Path, object_id: str, timeout: float) -> dict:
    """``data prepare`` then the oracle's ``eval`` of one object, cold, in a fresh ``$SPARK_BENCH_HOME``."""
    row: dict = {"id": object_id, "category": category_of(src / object_id),
                 "load_before": [round(x, 2) for x in os.getloadavg()]}
    with tempfile.TemporaryDirectory(prefix="spark_scale_") as tmp:
        home = Path(tmp)
        env = dict(os.environ, SPARK_BENCH_HOME=str(home))
        cli = [sys.executable, "-m", "spark_bench.cli"]
        bench = home / "bench"
        prepare = timed_run(cli + ["data", "prepare", "--src", str(Path(src).resolve()), "--ids", object_id,
                                   "--out", str(bench), "--workers", "1", "--no-progress"],
                            env, home, timeout)
        prepare["coacd_results"] = _coacd_results(home)
        row["prepare"] = prepare
        manifest = bench / "manifest.json"
        failed = json.loads(manifest.read_text()).get("failed", {}) if manifest.is_file() else {}
        if prepare["exit"] != 0 or object_id in failed or not (bench / "cases" / object_id).is_dir():
            why = failed.get(object_id) or prepare.get("error") or "no case written"
            row["error"] = f"prepare: {why}"[:300]
        else:
            evaluated = timed_run(cli + ["eval", "--method", "oracle", "--bench", str(bench),
                                         "--workers", "1", "--no-progress", "--json"], env, home, timeout)
            evaluated["coacd_results"] = _coacd_results(home) - prepare["coacd_results"]
            row["eval"] = evaluated
            db = home / "results.sqlite"
            row.update(stored_row(db) if db.is_file()
                       else {"error": evaluated.get("error", "no results store")})
            if evaluated["exit"] != 0 and "error" not in row:
                row["error"] = f"eval: {evaluated.get('error')}"
            if "error" not in row:  # again, warm: what the CoACD, link-shape and contact caches save
                row["eval_warm"] = warm_eval(cli, bench, env, home, timeout)
    row["load_after"] = [round(x, 2) for x in os.getloadavg()]
    return row


# ----- the report ---------------------------------------------------------------------------------
def _fmt(value, digits: int = 1) -> str:
    return "" if value is None else (f"{value:.{digits}f}" if isinstance(value, float) else str(value))


def row_line(row: dict) -> str:
    """One object's line of the report's table."""
    prep, ev = row.get("prepare", {}), row.get("eval", {})
    total = (prep["cpu_s"] + ev["cpu_s"]) if row in ok_rows([row]) else None
    timings = row.get("timings") or {}
    stages = ", ".join(f"{k} {v:.1f}" for k, v in timings.items() if v >= 0.05)
    verdict = "error: " + row["error"] if "error" in row else (
        f"sim {'pass' if row.get('sim_pass') else 'FAIL'}; open "
        + ("n/a" if row.get("open_success") is None else f"{row['open_success']:.2f}")
        + f" ({row.get('open_scored')}/{row.get('open_total')} joints scored)")
    return (f"| {row['id']} | {row['category']} | {_fmt(prep.get('cpu_s'))} | {_fmt(prep.get('wall_s'))} | "
            f"{_fmt(ev.get('cpu_s'))} | {_fmt(ev.get('wall_s'))} | {_fmt(total)} | "
            f"{_fmt((row.get('eval_warm') or {}).get('cpu_s'))} | {_fmt(row.get('coacd_calls'))} / "
            f"{_fmt(ev.get('coacd_results'))} | {_fmt(row.get('sim_coacd_cpu_s'))} | {stages} | "
            f"{row['load_before'][0]} / {row['load_after'][0]} | {verdict} |")


def projection_lines(document: dict, clusters) -> list[str]:
    """The projection's section: CPU hours per stage with their interval, the target, the clusters."""
    proj, good = document["projection"], ok_rows(document["rows"])
    if not proj["stages"]:
        return ["No object finished: no projection."]
    lines = [f"Mean CPU seconds per object over the {proj['n']} finished objects, with a bootstrap "
             f"{proj['level']:.0%} interval (10,000 resamples, seed "
             f"{document['meta'].get('seed', DEFAULT_SEED)}), "
             f"and times {proj['objects']:,} objects (PartNet-Mobility) in CPU hours:", "",
             "| stage | mean CPU s / object | interval | CPU h for all | interval |", "|---|---|---|---|---|"]
    for stage, s in proj["stages"].items():
        lines.append(f"| {stage} | {s['mean_s']:.1f} | {s['low_s']:.1f} - {s['high_s']:.1f} | "
                     f"{s['cpu_h']:.1f} | {s['low_h']:.1f} - {s['high_h']:.1f} |")
    total = proj["stages"]["total"]
    verdict = ("met" if total["high_h"] <= proj["target_cpu_h"] else
               "met at the mean, not at the interval's top" if total["cpu_h"] <= proj["target_cpu_h"] else
               f"NOT met: {proj['over_target']:.1f}x the target "
               f"({total['cpu_h'] - proj['target_cpu_h']:.1f} CPU h over)")
    lines += ["", f"**Target: <= {proj['target_cpu_h']:g} CPU hours for prepare + the oracle's eval with "
                  f"sim: {verdict}.**", ""]
    longest = max(r["prepare"]["wall_s"] + r["eval"]["wall_s"] for r in good)
    longest_id = max(good, key=lambda r: r["prepare"]["wall_s"] + r["eval"]["wall_s"])["id"]
    lines += ["Wall time over a cluster of K nodes x C cores: the CPU hours shared evenly "
              "(total CPU / (K x C)), never less than the longest single object, "
              f"{longest:.0f} s wall ({longest_id}; one object is one task):", "",
              "| nodes x cores | wall h (mean) | interval |", "|---|---|---|"]
    for nodes, cores in clusters:
        lines.append(f"| {nodes} x {cores} | {cluster_wall_h(total['cpu_h'], longest, nodes, cores):.2f} | "
                     f"{cluster_wall_h(total['low_h'], longest, nodes, cores):.2f} - "
                     f"{cluster_wall_h(total['high_h'], longest, nodes, cores):.2f} |")
    return lines


def shares_lines(document: dict) -> list[str]:
    """Where the CPU goes (the stages summed over the finished objects) and the per-category means."""
    shares = document["shares"]
    total = shares["prepare_cpu_s"] + shares["eval_cpu_s"]
    if total <= 0:
        return []
    walls = {k.removeprefix("eval_").removesuffix("_wall_s"): v
             for k, v in shares.items() if k.endswith("_wall_s")}
    candidates = {"prepare (CPU s)": shares["prepare_cpu_s"]}
    candidates.update({f"eval's `{k}` ({v:.0f} wall s summed)": v for k, v in walls.items()})
    largest = max(candidates, key=candidates.get)
    lines = [f"Largest of prepare and eval's stages: {largest}, {candidates[largest] / total:.0%} of the CPU "
             "seconds.", ""] + conversion_lines(shares) + [
             f"Where the CPU goes (summed over the finished objects, {total:.0f} CPU s): prepare "
             f"{shares['prepare_cpu_s'] / total:.0%}, eval {shares['eval_cpu_s'] / total:.0%}; inside eval, "
             f"the sim checks' CoACD calls alone {shares['sim_coacd_cpu_s'] / total:.0%} of all CPU "
             f"({shares['sim_coacd_cpu_s']:.0f} CPU s; the opener's own conversion of the source object, "
             "whose CoACD calls are in the table's second count, is inside `open` and not split out). "
             "Eval's stages, wall s summed: "
             + ", ".join(f"{k} {v:.0f}" for k, v in sorted(walls.items(), key=lambda kv: -kv[1])) + ".",
             "", "Per category (the sample's mix is partnet_dev's holdout half, not PartNet-Mobility's 46 "
             "categories: the projection weights the categories as the sample does):", "",
             "| category | objects | prepare CPU s | eval CPU s | total CPU s |", "|---|---|---|---|---|"]
    for category, m in document["categories"].items():
        lines.append(f"| {category} | {m['n']} | {m['prepare_s']:.1f} | {m['eval_s']:.1f} | "
                     f"{m['total_s']:.1f} |")
    return lines


def markdown(document: dict, clusters=CLUSTERS) -> str:
    """The report: how it was run, the per-object table, the projection, the shares, the cluster commands."""
    meta, rows = document["meta"], document["rows"]
    lines = ["# Scale: CPU seconds per real object, `data prepare` + the oracle's `eval` with sim", "",
             "Written by `benchmarks/measure_scale.py` (issue 37, item 3). Each object on its own, cold: a "
             "fresh, empty `$SPARK_BENCH_HOME` (`<run_home>`: no CoACD, link-shape or contact cache), "
             "`spark-bench data prepare --src <partnet_dev> --ids ID --out <run_home>/bench --workers 1`, "
             "then "
             "`spark-bench eval --method oracle --bench <run_home>/bench --workers 1 --no-progress --json` "
             "(sim checks and opening score on, their defaults). CPU s: user + sys of the command and its "
             "CoACD worker processes (`RUSAGE_CHILDREN`).", "",
             f"- command: `{meta['command']}` (started {meta['started']})",
             f"- code: commit {meta['commit']}",
             *[f"- earlier pass: {e}; rows kept from it: {kept}" for e in meta.get("earlier", [])[-1:]
               if (kept := sum(r.get("measured_in") != meta["started"] for r in rows))],
             f"- machine: {meta['cores']} cores, shared (another long job at nice 10 beside it; this run at "
             f"nice 10, one object at a time); load average (1/5/15 min) at the start {meta['load_start']}, "
             f"at the last write {meta['load_now']}",
             f"- objects measured: {len(rows)} of {len(meta['planned'])} planned ({len(ok_rows(rows))} "
             f"finished both commands); planned: {', '.join(meta['planned'])}", "",
             "| object | category | prepare CPU s | prepare wall s | eval CPU s | eval wall s | total CPU s "
             "| eval warm CPU s | CoACD calls (sim checks / all of eval) | sim CoACD CPU s "
             "| eval stages, wall s | load before / after | verdicts |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += [row_line(r) for r in rows]
    lines += ["", "## Projection to PartNet-Mobility's 2,346 objects", ""]
    lines += projection_lines(document, clusters)
    lines += [""] + shares_lines(document)
    lines += ["", "## Over a cluster: one flag", "",
              "The same two commands with `--executor ray` run one Ray task per object (`data prepare`) and "
              "per case (`eval`) on every node of a Ray cluster ([docs/cluster.md](../../docs/cluster.md)); "
              "every node must see `--src`, `--out` and `$SPARK_BENCH_HOME` at the same path:", "", "```bash",
              "spark-bench data prepare --src /shared/partnet --out /shared/benchmarks/partnet-v1 "
              "--executor ray --ray-address HEAD:6379",
              "spark-bench eval --method oracle --bench /shared/benchmarks/partnet-v1 --executor ray "
              "--ray-address HEAD:6379", "```"]
    return "\n".join(lines) + "\n"


# ----- the run ------------------------------------------------------------------------------------
def planned_ids(args) -> list[str]:
    """The objects to measure: ``--ids``, else a stratified sample of ``--sample`` holdout objects."""
    if args.ids:
        return list(args.ids)
    groups: dict[str, list[str]] = defaultdict(list)
    for object_id in json.loads(SPLIT.read_text())["holdout"]:
        if (args.src / object_id).is_dir():
            groups[category_of(args.src / object_id)].append(object_id)
    return select_sample(groups, args.sample, args.seed)


def _commit() -> str:
    proc = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    status = ["git", "status", "--porcelain", "--untracked-files=no"]
    dirty = subprocess.run(status, cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return proc.stdout.strip() + (" (with uncommitted changes)" if dirty else "")


def write(args, meta: dict, rows: list[dict], load_now: list[float] | None = None) -> None:
    """The JSON and the Markdown report of the rows so far (``load_now``: the load average to record, default
    the machine's now)."""
    meta = dict(meta, load_now=load_now or [round(x, 2) for x in os.getloadavg()])
    proj = projection(rows, seed=args.seed)
    document = {"meta": meta, "rows": rows, "projection": proj, "categories": category_means(rows),
                "shares": stage_shares(rows)}
    args.json.write_text(json.dumps(document, indent=1, default=float) + "\n")
    if str(args.results) != "-":  # the notes a person wrote below NOTES are kept
        old = args.results.read_text() if args.results.is_file() else ""
        args.results.write_text(markdown(document) + (old[old.index(NOTES):] if NOTES in old else ""))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", type=Path, default=SRC, help="a folder of PartNet-Mobility object folders")
    parser.add_argument("--ids", nargs="*", default=None, help="these objects (default: a holdout sample)")
    parser.add_argument("--sample", type=int, default=DEFAULT_SAMPLE, help="holdout objects, by category")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help="seed of the sample and the bootstrap")
    parser.add_argument("--json", type=Path, default=JSON_OUT, help="rows + projection (written per object)")
    parser.add_argument("--resume", action="store_true", help="keep the finished rows of --json")
    parser.add_argument("--redo-incomplete", action="store_true", help="with --resume: measure again the "
                        "rows with an error or no warm eval (each replaced when its new measurement ends)")
    parser.add_argument("--results", type=Path, default=RESULTS, help="Markdown report ('-': none)")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds one command may take")
    parser.add_argument("--stop-after-min", type=float, default=None,
                        help="start no new object after this many minutes (the report covers what finished)")
    parser.add_argument("--report-only", action="store_true",
                        help="rewrite the report of --json's rows, measure nothing")
    args = parser.parse_args(argv)
    if args.report_only:
        meta = json.loads(args.json.read_text())["meta"]
        write(args, meta, json.loads(args.json.read_text())["rows"], load_now=meta.get("load_now"))
        return 0
    planned = planned_ids(args)
    rows, earlier = [], []
    if args.resume and args.json.is_file():
        old = json.loads(args.json.read_text())
        rows = [r for r in old["rows"] if r["id"] in planned]
        earlier = old["meta"].get("earlier", []) + [f"`{old['meta']['command']}` ({old['meta']['started']})"]
    given = sys.argv[1:] if argv is None else argv
    meta = {"command": " ".join(["python -m benchmarks.measure_scale", *given]), "commit": _commit(),
            "cores": os.cpu_count(), "load_start": [round(x, 2) for x in os.getloadavg()],
            "planned": planned, "seed": args.seed, "earlier": earlier,
            "started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())}
    start = time.monotonic()
    for object_id in planned:
        kept = next((r for r in rows if r["id"] == object_id), None)
        if kept is not None and not (args.redo_incomplete and ("error" in kept or "eval_warm" not in kept)):
            continue
        if args.stop_after_min is not None and time.monotonic() - start > args.stop_after_min * 60:
            print(f"stopped after {args.stop_after_min:g} min: {len(rows)} of {len(planned)} objects",
                  flush=True)
            break
        row = dict(measure_object(args.src, object_id, args.timeout), measured_in=meta["started"])
        rows = sorted([r for r in rows if r["id"] != object_id] + [row], key=lambda r: planned.index(r["id"]))
        print(f"{object_id} ({row['category']}): prepare {row.get('prepare')}, eval {row.get('eval')}, "
              f"warm {row.get('eval_warm')}, error {row.get('error')}", flush=True)
        write(args, meta, rows)
    write(args, meta, rows)
    print(f"wrote {args.json}" + ("" if str(args.results) == "-" else f" and {args.results}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
