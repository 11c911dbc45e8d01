"""Infinigen-Sim's rest-force check on real objects: how many pass it, and why those that fail do.

For every object folder (default: the 75 of ``../shared/partnet_dev``) this script converts the object as
``spark-bench check`` does (CoACD hulls from the cache of ``$SPARK_BENCH_HOME``, one CoACD worker), compiles
its MJCF without the visual meshes (they carry no mass and no contacts: the physics is the same) and runs

- Infinigen-Sim's rest-force check (:func:`spark_bench.sim.rest_force.check_rest_force`): one ``mj_forward``
  at rest, the signed sum of ``qfrc_constraint`` within ±1e-3, with what carries the force (which joints,
  which contacts, limits or friction losses);
- two of spark-bench's own rest checks on the same model, to set the two side by side:
  ``rest_penetration`` and ``rest_stability`` (:mod:`spark_bench.sim.checks`);

then writes ``benchmarks/results/rest_force_partnet_dev.md``: the pass count, the failures grouped by what
carries the force, and one row per failing object.

Run (from the repository root): ``SPARK_BENCH_HOME=/work/home_base nice -n 5 python -m
benchmarks.measure_rest_force [--ids 100247 7310] [--source DIR] [--out FILE] [--json FILE [--resume]] [--cached-only]``
(an object whose hulls are not cached runs CoACD first: a minute or more on a busy machine).
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "partnet_dev"
OUT = ROOT / "benchmarks" / "results" / "rest_force_partnet_dev.md"


class NotCached(Exception):
    """``--cached-only``: the object's hulls are not all in the CoACD cache."""


def refuse_coacd() -> None:
    """Make every conversion whose meshes the CoACD cache cannot all answer raise :class:`NotCached` with the
    number of meshes missing (``--cached-only``: a quick pass over the objects whose hulls are cached; the
    others are listed as not measured). The cache is asked as :func:`spark_bench.sim.decompose.decompose_many`
    asks it (each mesh in its planes' frame)."""
    import numpy as np

    import spark_bench.sim.hulls as hulls
    from spark_bench.sim.decompose import flat_frame, load_cached, mesh_key

    run = hulls.decompose_many

    def cached_only(meshes, params, cache=None, **kwargs):
        missing = 0
        for vertices, faces in meshes:
            vertices = np.asarray(vertices, np.float64)
            turn = flat_frame(vertices, faces)
            turned = vertices if turn is None else vertices @ turn.T
            missing += cache is None or load_cached(mesh_key(turned, faces, params), cache) is None
        if missing:
            raise NotCached(int(missing))
        return run(meshes, params, cache=cache, **kwargs)

    hulls.decompose_many = cached_only


def category_of(folder: Path) -> str:
    """The object's PartNet-Mobility category (``meta.json``'s ``model_cat``), else ``?``."""
    meta = folder / "meta.json"
    return json.loads(meta.read_text()).get("model_cat", "?") if meta.is_file() else "?"


def measure_one(folder: Path) -> dict:
    """Convert one object and run the rest-force check and spark-bench's two rest checks on its model.

    :param folder: a PartNet-Mobility object folder
    """
    from spark_bench.sim.checks import check_mesh_files, check_rest_penetration, check_rest_stability
    from spark_bench.sim.converter import load_source
    from spark_bench.sim.mjcf import build_spec, prepare
    from spark_bench.sim.options import ConvertOptions
    from spark_bench.sim.rest_force import check_rest_force
    from spark_bench.sim.sweep import swept_joints

    start = time.perf_counter()
    row: dict = {"id": folder.name, "category": category_of(folder)}
    asset = load_source(folder)
    row["joints"] = {j.name: j.type for j in asset.movable_joints()}
    if not check_mesh_files(asset).passed:
        return {**row, "error": "mesh files the URDF names cannot be loaded"}
    prepared = prepare(asset, ConvertOptions(workers=1))
    try:
        model = build_spec(asset, prepared=prepared, visuals=False).compile()
    except ValueError as exc:
        return {**row, "error": f"does not compile: {' '.join(str(exc).split())}"}
    row["rest_force"] = check_rest_force(model).to_dict()
    row["rest_penetration"] = check_rest_penetration(model, prepared.size, prepared.excluded).passed
    row["rest_stability"] = check_rest_stability(model, swept_joints(asset), prepared.size).passed
    row["seconds"] = round(time.perf_counter() - start, 2)
    return row


def cause_of(row: dict) -> str:
    """What carries most of a failing object's force: the kind of its largest carrier (``contact``, ``limit``,
    ``friction_loss``...), a friction loss told apart by whether it is at its maximum (gravity pulls the part
    harder than its friction holds: into its rest stop, which MuJoCo's limit resists only once passed) or
    holding the part still against gravity."""
    force = row["rest_force"]
    carriers = force.get("carriers") or []
    if not carriers:
        return "none"
    kind = carriers[0]["kind"]
    dof = next((d for d in force["dofs"] if d["joint"] == carriers[0]["what"]), None)
    if kind != "friction_loss" or dof is None or "friction_loss" not in dof:
        return kind
    saturated = abs(abs(dof["force"]) - dof["friction_loss"]) <= 1e-6 * max(dof["friction_loss"], 1e-12)
    return "friction_loss at its maximum (gravity pulls harder)" if saturated else "friction_loss holding against gravity"


def _calls(row: dict) -> int:
    """The CoACD calls a not-measured row's object lacks (an int, or the count at the head of a message)."""
    return int(str(row["not_measured"]).split()[0])


def _carrier_text(carrier: dict) -> str:
    return f"{carrier['kind']} {carrier['what']} ({carrier['largest']:+.3g})"


def report(rows: list[dict], source: Path, started: str, seconds: float) -> str:
    """The Markdown report of the measured rows."""
    import mujoco

    checked = [r for r in rows if "rest_force" in r]
    passed = [r for r in checked if r["rest_force"]["passed"]]
    failed = sorted((r for r in checked if not r["rest_force"]["passed"]), key=lambda r: -abs(r["rest_force"]["value"]))
    spark_rest = [r for r in checked if r["rest_penetration"] and r["rest_stability"]]
    lines = [
        "# Infinigen-Sim's rest-force check on real objects",
        "",
        f"Written by `benchmarks/measure_rest_force.py` ({started}, {seconds / 60:.1f} min, MuJoCo "
        f"{mujoco.__version__}): each object of `{source.name}` converted as `spark-bench check` converts it "
        "(cached CoACD hulls, one worker), its MJCF compiled without visual meshes, then one `mj_forward` at rest "
        "and the **signed** sum of `qfrc_constraint` (N on slide dofs, N·m on hinge dofs, added as they come), "
        "passing inside ±1e-3 (Infinigen-Sim `tests/sim/test_sim_export.py` @ 198eada1; "
        "`spark_bench/sim/rest_force.py`). Reported beside spark-bench's checks, never in `sim_pass`.",
        "",
        "## Counts",
        "",
        f"- objects: {len(rows)}; measured (converted and compiled): {len(checked)}",
        f"- pass Infinigen's rest-force check: **{len(passed)}/{len(checked)}**",
        f"- pass spark-bench's two rest checks (`rest_penetration` and `rest_stability`) on the same model: "
        f"{len(spark_rest)}/{len(checked)}",
        f"- both pass: {sum(1 for r in passed if r in spark_rest)}; Infinigen fails where spark-bench's rest "
        f"checks pass: {sum(1 for r in failed if r in spark_rest)}; Infinigen passes where they fail: "
        f"{sum(1 for r in passed if r not in spark_rest)}",
        "",
        "What carries most of the force in the failing objects (the constraint with the largest share on one dof):",
        "",
        "| carried by | objects |",
        "|---|---|",
        *[f"| {kind} | {count} |" for kind, count in Counter(cause_of(r) for r in failed).most_common()],
        "",
        f"Failing objects with active contacts at rest: {sum(1 for r in failed if r['rest_force']['contacts'])} "
        "(the converter leaves a clearance between neighbouring hulls; a contact at rest is an overlap it could "
        "not clear). How to read the causes:",
        "",
        "- *friction_loss at its maximum*: gravity pulls the part into its rest stop (a lid lying shut, a part "
        "hanging at its lower limit) harder than the joint's friction loss holds. MuJoCo's joint limit acts only "
        "once the joint is past it (margin 0), so at exactly the rest value the friction loss alone resists, at its "
        "maximum: the sum is the joint's friction loss (the converter gives every joint one, "
        "`ConvertOptions.joint_frictionloss` = 2 % of the part's weight, times its lever on a hinge). A step later "
        "the limit takes the load; nothing moves.",
        "- *friction_loss holding against gravity*: gravity pulls the part away from its rest into its range (a "
        "handle that would fall over, a drop-down door) and the friction loss holds it still, raised by the "
        "converter to 1.5 times that pull on purpose (`HOLD_FACTOR`, as a real latch or spring holds it). "
        "Infinigen's check counts the holding force.",
        "- *contact*: hulls of two parts overlap at rest and push each other (what the check is after); *limit*: "
        "a joint at rest outside its range.",
        "",
        "So the check fails every object with a part that gravity loads along its joint at rest by more than "
        "1e-3 N·m (or N), whether or not anything would move; it passes objects whose joints gravity does not "
        "load (vertical hinges, level slides: sum 0) and light parts (the bucket handles below 1e-3).",
        "",
        "Per category (pass / objects):",
        "",
        "| category | pass | objects |",
        "|---|---|---|",
        *[f"| {cat} | {sum(1 for r in passed if r['category'] == cat)} | {n} |"
          for cat, n in sorted(Counter(r["category"] for r in checked).items())],
        "",
        "## Failures",
        "",
        "| object | category | sum (signed) | sum of magnitudes | dof with most force (its gravity, its friction loss) "
        "| largest carriers (share on one dof) | spark rest_penetration / rest_stability |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in failed:
        force = r["rest_force"]
        dof = force["dofs"][0] if force["dofs"] else None
        dof_text = "-"
        if dof:
            dof_text = f"{dof['joint']} ({dof['type']}, {dof['force']:+.3g}"
            if "gravity" in dof:
                dof_text += f"; gravity {dof['gravity']:+.3g}, friction loss {dof['friction_loss']:.3g}"
            dof_text += ")"
        carriers = "; ".join(_carrier_text(c) for c in force["carriers"][:3]) or "-"
        spark = f"{'pass' if r['rest_penetration'] else 'FAIL'} / {'pass' if r['rest_stability'] else 'FAIL'}"
        lines.append(f"| {r['id']} | {r['category']} | {force['value']:+.4g} | {force['abs_sum']:.4g} | {dof_text} | "
                     f"{carriers} | {spark} |")
    errors = [r for r in rows if "error" in r]
    if errors:
        lines += ["", "## Not checked", "", *[f"- {r['id']} ({r['category']}): {r['error']}" for r in errors]]
    missing = [r for r in rows if "not_measured" in r]
    if missing:
        lines += ["", f"## Not measured ({len(missing)}: CoACD hulls not cached, the sweep stopped before them)", "",
                  ", ".join(f"{r['id']} ({r['category']}, {_calls(r)} CoACD calls)" for r in missing)]
    return "\n".join(lines) + "\n"


def round_robin(folders: list[Path]) -> list[Path]:
    """The folders one category at a time in turn (each category's in id order): a sweep stopped part-way
    (uncached CoACD takes minutes per object) has covered every category, not the first few."""
    by_category: dict[str, list[Path]] = {}
    for folder in folders:
        by_category.setdefault(category_of(folder), []).append(folder)
    queues = [by_category[c] for c in sorted(by_category)]
    return [q[k] for k in range(max(map(len, queues), default=0)) for q in queues if k < len(q)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=SOURCE, help="folder of object folders")
    parser.add_argument("--ids", nargs="*", help="only these object ids")
    parser.add_argument("--out", type=Path, default=OUT, help="the Markdown report to write")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here (after every object)")
    parser.add_argument("--resume", action="store_true", help="keep the rows already in --json, measure the rest")
    parser.add_argument("--cached-only", action="store_true",
                        help="measure only the objects whose CoACD hulls are all cached (the others: not measured)")
    args = parser.parse_args(argv)
    if args.cached_only:
        refuse_coacd()
    folders = sorted(p for p in args.source.iterdir() if (p / "mobility.urdf").is_file())
    if args.ids:
        folders = [p for p in folders if p.name in set(args.ids)]
    folders = round_robin(folders)
    started, clock = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), time.perf_counter()
    rows = json.loads(args.json.read_text()) if args.resume and args.json and args.json.is_file() else []
    # a resumed sweep measures the objects a --cached-only pass left out, fewest CoACD calls first
    missing = {row["id"]: _calls(row) for row in rows if "not_measured" in row}
    rows = [row for row in rows if "not_measured" not in row]
    folders.sort(key=lambda folder: missing.get(folder.name, 0))
    done = {row["id"] for row in rows}
    for k, folder in enumerate(folders, 1):
        if folder.name in done:
            continue
        try:
            row = measure_one(folder)
        except NotCached as exc:
            row = {"id": folder.name, "category": category_of(folder), "not_measured": int(exc.args[0])}
        except Exception as exc:  # one object's failure is a row of the report, not the end of the sweep
            row = {"id": folder.name, "category": category_of(folder), "error": " ".join(str(exc).split())[:200]}
        rows.append(row)
        verdict = row["rest_force"]["passed"] if "rest_force" in row else row.get("error", row.get("not_measured"))
        value = row["rest_force"]["value"] if "rest_force" in row else float("nan")
        print(f"[{k}/{len(folders)}] {folder.name}: {verdict} {value:.4g} ({row.get('seconds', '-')} s)", flush=True)
        if args.json:
            args.json.write_text(json.dumps(rows, indent=1))
        # after every object: a sweep stopped part-way still leaves its report (the count says how many)
        args.out.write_text(report(rows, args.source, started, time.perf_counter() - clock))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
