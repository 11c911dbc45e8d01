"""The field's own articulated assets as they ship (issue 43): every asset of fetched snapshots of Meta-World,
LIBERO, IsaacGymEnvs, GenSim2 and Newton read and checked as a user would (``load_object``, then the sim checks
of ``spark-bench check``), each given a verdict or one error naming the file and the cause; GenSim2's USD + URDF
pairs scored against each other (``spark-bench metrics --pred <obj>/mobility/mobility.usd --gt <obj>``); the
drawers and the door issue 43 names opened with the scripted policy (``spark-bench rollout``).

    python -m benchmarks.measure_field_assets --root DIR [--commit GenSim2=SHA ...] \\
        [--out benchmarks/results/field_assets.md]

``DIR`` holds one snapshot per repository, named as the repository (the folder ``$SPARK_BENCH_FIELD_ASSETS`` names
for the tests): ``GenSim2`` (``GenSim2/GenSim2``), ``Metaworld`` (``Farama-Foundation/Metaworld``), ``LIBERO``
(``Lifelong-Robot-Learning/LIBERO``), ``IsaacGymEnvs`` (``isaac-sim/IsaacGymEnvs``), ``newton``
(``newton-physics/newton``); a missing one is said so in the report. The report names each snapshot by its
placeholder (``<GenSim2>``...), never this machine's path.
"""

from __future__ import annotations

import argparse
import os
import re
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
NOTES = "<!-- notes: kept when the script rewrites the file -->"
#: The repositories read, by snapshot name.
REPOSITORIES = {"Metaworld": "Farama-Foundation/Metaworld", "LIBERO": "Lifelong-Robot-Learning/LIBERO",
                "IsaacGymEnvs": "isaac-sim/IsaacGymEnvs", "GenSim2": "GenSim2/GenSim2",
                "newton": "newton-physics/newton"}
#: GenSim2's objects read as USD + URDF pairs: the three issue 43 requires to score as themselves, and a door whose
#: USD and URDF are not one object (its USD makes joint_2 a hinge its URDF comments out).
GENSIM2 = ("dishwasher/11700", "drawer/29921", "refrigerator/11178", "door/8877")
#: The parts opened with the scripted policy: (snapshot, asset, joint, environment).
ROLLOUTS = (("Metaworld", "metaworld/assets/objects/drawer.xml", "goal_slidey", "SparkDrawer-v0"),
            ("LIBERO", "libero/libero/assets/articulated_objects/white_cabinet.xml", "top_level", "SparkDrawer-v0"),
            ("LIBERO", "libero/libero/assets/articulated_objects/microwave.xml", "microjoint", "SparkDoor-v0"))
#: An MJCF ``<joint>`` that moves a part: a hinge or slide (a joint without ``type`` is a hinge).
MOVING_JOINT = re.compile(r"<joint\b(?![^>]*type=\"(?:free|ball)\")[^>]*>")
INCLUDE = re.compile(r"<include\s+file=\"([^\"]+)\"")
#: An innermost ``<default>`` block (its ``<joint>`` sets a class's attributes, it adds no joint), or an empty one.
DEFAULT_BLOCK = re.compile(r"<default\b[^>]*/>|<default\b[^>]*>(?:(?!<default\b).)*?</default>", re.DOTALL)


@dataclass
class Row:
    """One asset: how it read and what the checks said.

    :param snapshot: the snapshot's name
    :param asset: its path inside the snapshot
    :param format: ``MJCF``, ``URDF`` or ``USD``
    :param verdict: ``passed``, ``failed`` or ``error`` (it could not be read) or ``crash`` (spark-bench raised
        something other than an input error: a bug)
    :param detail: the failed checks with their reasons, or the error
    :param joints: the movable joints, ``name (type)``
    :param opening: the joints read as opening toward their written lower limit, with the rule
    :param warnings: what reading left out
    :param smallest_mass: ``mass_inertia``'s value (kg), None where not checked
    :param size: the object's rest bounding-box diagonal (m) as read
    :param seconds: wall seconds to read and check
    """

    snapshot: str
    asset: str
    format: str
    verdict: str = ""
    detail: str = ""
    joints: list[str] = field(default_factory=list)
    opening: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    smallest_mass: float | None = None
    size: float | None = None
    seconds: float = 0.0


def placeholder(text: str, roots: dict[str, Path]) -> str:
    """``text`` with every snapshot's path written as its placeholder (``<GenSim2>``...), on one line."""
    for name, root in roots.items():
        text = text.replace(str(root.resolve()), f"<{name}>").replace(str(root), f"<{name}>")
    return " ".join(text.split())


def moves(xml: Path, seen: set[Path] | None = None) -> bool:
    """Whether an MJCF file or a file it includes writes a hinge or slide joint (read as text: the selection does
    not depend on the reader being measured)."""
    seen = seen if seen is not None else set()
    if xml in seen or not xml.is_file():
        return False
    seen.add(xml)
    text = xml.read_text(errors="replace")
    bare = None
    while bare != text:  # the default classes out, innermost first
        bare, text = text, DEFAULT_BLOCK.sub("", text)
    return bool(MOVING_JOINT.search(text)) or any(moves((xml.parent / f).resolve(), seen) for f in INCLUDE.findall(text))


def assets_of(name: str, root: Path) -> list[tuple[str, str]]:
    """``(path inside the snapshot, format)`` of every asset read from snapshot ``name``."""
    if name == "Metaworld":
        files = sorted((root / "metaworld/assets/objects").glob("*.xml"))
        return [(str(f.relative_to(root)), "MJCF") for f in files if moves(f.resolve())]
    if name == "LIBERO":
        return [(str(f.relative_to(root)), "MJCF")
                for f in sorted((root / "libero/libero/assets/articulated_objects").glob("*.xml"))]
    if name == "IsaacGymEnvs":
        return [(str(f.relative_to(root)), "URDF")
                for f in sorted((root / "assets/urdf/sektion_cabinet_model").rglob("*.urdf"))]
    if name == "GenSim2":
        out = []
        for obj in GENSIM2:
            out += [(f"assets/articulated_objs/{obj}/mobility/mobility.usd", "USD"),
                    (f"assets/articulated_objs/{obj}", "URDF")]
        return out
    if name == "newton":
        scenes = root / "newton/_src/solvers/kamino/_src/models/assets/testing/joints"
        return [(str(f.relative_to(root)), "USD") for f in sorted(scenes.glob("test_*/test_*.usda"))]
    return []


def check_asset(row: Row, path: Path, roots: dict[str, Path], workers: int):
    """Read ``path`` and run the sim checks on it, filling ``row``; returns the asset read (None where it failed)."""
    import numpy as np

    from spark_bench.data.readers import load_object
    from spark_bench.errors import InputError
    from spark_bench.sim.checks import run_checks
    from spark_bench.sim.options import ConvertOptions

    start = time.perf_counter()
    asset = None
    try:
        asset = load_object(path)
        row.joints = [f"{j.name} ({j.type})" for j in asset.movable_joints()]
        row.opening = [f"{o['joint']} ({o['rule']})" for o in asset.meta.get("opening_direction", [])
                       if o["opens_toward"] == "lower"]
        row.warnings = [placeholder(w, roots) for w in asset.warnings]
        row.size = float(np.linalg.norm(np.ptp(asset.bounds(), axis=0)))
        report = run_checks(asset, ConvertOptions(workers=workers))
        row.verdict = "passed" if report.passed else "failed"
        row.detail = "; ".join(placeholder(line, roots)[:220] for line in report.failures())
        mass = report.checks.get("mass_inertia")
        row.smallest_mass = float(mass.value) if mass is not None and np.isfinite(mass.value) else None
    except InputError as exc:
        row.verdict, row.detail = "error", placeholder(str(exc), roots)
    except Exception as exc:  # a bug of spark-bench's: said so, the run goes on
        row.verdict = "crash"
        row.detail = placeholder(f"{type(exc).__name__}: {exc} ({traceback.extract_tb(exc.__traceback__)[-1].name})",
                                 roots)
    row.seconds = time.perf_counter() - start
    return asset if row.verdict in ("passed", "failed") else None


def pair_scores(usd, urdf) -> dict:
    """``spark-bench metrics --pred USD --gt URDF``'s numbers (100000 samples, seed 0)."""
    from spark_bench.metrics.evaluate import compute_metrics

    scores = compute_metrics(usd, urdf).to_dict()
    return {k: scores[k] for k in ("axis_err", "pivot_err", "type_err", "cd", "extra_joints", "missing_joints")}


def why_they_differ(usd_row: Row, urdf_row: Row, usd, urdf) -> str:
    """What differs between an object's USD and its URDF as read: joints, size, category, masses, verdicts."""
    notes = []
    usd_joints = {j.name: j.type for j in usd.movable_joints()}
    urdf_joints = {j.name: j.type for j in urdf.joints.values()}
    for name, kind in usd_joints.items():
        if urdf_joints.get(name) != kind:
            written = urdf_joints.get(name, "absent (commented out)")
            notes.append(f"the USD makes {name} {kind}, the URDF {written}")
    for found in usd.meta.get("opening_direction", []):
        joint = urdf.joints.get(found["joint"])
        if found["opens_toward"] == "lower" and joint is not None and joint.is_movable and joint.lower < -1e-9:
            notes.append(f"{found['joint']} rests where Isaac drew it in the USD ({found['drawn_at']:.3f}, the upper "
                         f"end of its written range), at its lower limit in the URDF ({joint.lower:.3g}, spark-bench's "
                         "URDF convention): the two rest poses differ")
    if usd_row.size and urdf_row.size:
        notes.append(f"size {usd_row.size:.2f} m (USD, file units as Isaac wrote them) vs {urdf_row.size:.2f} m "
                     "(URDF folder at its real size, info.json)")
    if usd.category != urdf.category:
        notes.append(f"category {usd.category or 'none'} vs {urdf.category}: the density rule differs")
    if usd_row.smallest_mass is not None and urdf_row.smallest_mass is not None:
        authored = [link.annotations["mass"] for link in usd.links.values() if "mass" in link.annotations]
        notes.append(f"smallest moving mass {usd_row.smallest_mass:.3g} vs {urdf_row.smallest_mass:.3g} kg (the "
                     f"checks' rule; Isaac's importer wrote {'no mass' if not authored else authored})")
    if usd_row.verdict != urdf_row.verdict:
        notes.append(f"verdict {usd_row.verdict} vs {urdf_row.verdict}")
    return "; ".join(notes)


def gensim2_sweep(root: Path, roots: dict[str, Path]) -> list[list[str]]:
    """Every ``mobility.usd`` of the GenSim2 snapshot read (no checks): rows of ``object, joints, read as continuous
    (the importer's drive), read as opening toward the written lower limit, error``."""
    from spark_bench.data.readers import load_object
    from spark_bench.errors import InputError

    rows = []
    for path in sorted(root.glob("assets/articulated_objs/*/*/mobility/mobility.usd")):
        name = str(path.parents[1].relative_to(root / "assets/articulated_objs"))
        try:
            asset = load_object(path)
        except InputError as exc:
            rows.append([name, "-", "-", "-", placeholder(str(exc), roots)])
            continue
        except Exception as exc:  # a bug of spark-bench's: said so
            rows.append([name, "-", "-", "-", f"crash: {type(exc).__name__}: {placeholder(str(exc), roots)}"])
            continue
        lower = [o["joint"] for o in asset.meta.get("opening_direction", []) if o["opens_toward"] == "lower"]
        rows.append([name, ", ".join(f"{j.name} ({j.type})" for j in asset.movable_joints()) or "-",
                     ", ".join(asset.meta["usd"].get("continuous", {})) or "-", ", ".join(lower) or "-", "-"])
    return rows


def run_rollouts(roots: dict[str, Path]) -> list[list[str]]:
    """The scripted opener on :data:`ROLLOUTS` (2 episodes each): rows of the report's rollout table."""
    from spark_bench.errors import InputError
    from spark_bench.rl.rollout import rollout

    rows = []
    for snapshot, asset, joint, env in ROLLOUTS:
        if snapshot not in roots:
            continue
        try:
            stats = rollout(env, asset=str(roots[snapshot] / asset), joint=joint, episodes=2)
            outcome = (f"{stats.success_rate:.2f} over {stats.episodes}" if stats.reason is None
                       else f"declined: {placeholder(stats.reason, roots)}")
        except InputError as exc:
            outcome = f"error: {placeholder(str(exc), roots)}"
        rows.append([f"`<{snapshot}>/{asset}`", joint, env, outcome])
    return rows


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table (cells with ``|`` escaped)."""
    def cell(value) -> str:
        return str(value).replace("|", "\\|")
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(cell(v) for v in row) + " |" for row in rows)]


def main() -> None:
    """Read and check every asset of every snapshot given, score GenSim2's pairs, run the rollouts, write the
    report (its notes kept)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, default=os.environ.get("SPARK_BENCH_FIELD_ASSETS"),
                        help="folder holding the snapshots by repository name (default: $SPARK_BENCH_FIELD_ASSETS)")
    parser.add_argument("--commit", action="append", default=[], metavar="NAME=SHA",
                        help="the commit a snapshot was taken at, for the report (repeatable)")
    parser.add_argument("--workers", type=int, default=1, help="CoACD processes for the checks")
    parser.add_argument("--out", type=Path, default=RESULTS / "field_assets.md")
    args = parser.parse_args()
    if args.root is None:
        parser.error("give --root (or set $SPARK_BENCH_FIELD_ASSETS)")
    commits = dict(item.split("=", 1) for item in args.commit)
    roots = {name: args.root / name for name in REPOSITORIES if (args.root / name).is_dir()}

    clock = time.perf_counter()
    rows: list[Row] = []
    read: dict[tuple[str, str], object] = {}
    for name, root in roots.items():
        for asset, kind in assets_of(name, root):
            row = Row(name, asset, kind)
            read[(name, asset)] = check_asset(row, root / asset, roots, args.workers)
            rows.append(row)
            print(f"{row.verdict:7s} {row.seconds:6.1f} s  <{name}>/{asset}  {row.detail[:120]}", flush=True)

    pairs = []
    if "GenSim2" in roots:
        for obj in GENSIM2:
            usd_key, urdf_key = ("GenSim2", f"assets/articulated_objs/{obj}/mobility/mobility.usd"), \
                ("GenSim2", f"assets/articulated_objs/{obj}")
            usd, urdf = read.get(usd_key), read.get(urdf_key)
            by_key = {(r.snapshot, r.asset): r for r in rows}
            if usd is None or urdf is None:
                pairs.append([obj, by_key[usd_key].verdict, by_key[urdf_key].verdict, "-", "-", "-", "-", "not read"])
                continue
            s = pair_scores(usd, urdf)
            fmt = ["-" if s[k] is None else f"{s[k]:.4f}" for k in ("axis_err", "pivot_err", "type_err", "cd")]
            extra = f" (extra in the USD: {', '.join(s['extra_joints'])})" if s["extra_joints"] else ""
            pairs.append([obj, by_key[usd_key].verdict, by_key[urdf_key].verdict, *fmt,
                          why_they_differ(by_key[usd_key], by_key[urdf_key], usd, urdf) + extra])
    sweep = gensim2_sweep(roots["GenSim2"], roots) if "GenSim2" in roots else []
    rollouts = run_rollouts(roots)
    total = time.perf_counter() - clock

    counts = {v: sum(r.verdict == v for r in rows) for v in ("passed", "failed", "error", "crash")}
    snapshots = [f"`<{n}>`: `{REPOSITORIES[n]}`" + (f" at {commits[n]}" if n in commits else "") for n in roots]
    missing = [f"`{REPOSITORIES[n]}` (no `{n}/`)" for n in REPOSITORIES if n not in roots]
    lines = [
        "# The field's own assets as they ship (issue 43)", "",
        f"Written by `benchmarks/measure_field_assets.py` ({time.strftime('%Y-%m-%d %H:%M')}, {total:.0f} s on 2 "
        f"shared cores). Snapshots: {'; '.join(snapshots)}." + (f" Not given: {', '.join(missing)}." if missing else ""),
        "Each asset is read as `spark-bench check ASSET` reads it (`load_object`: a file as it lies, a GenSim2 object "
        "folder as a PartNet-Mobility folder, at its real size) and given every sim check; *error* is a file "
        "spark-bench cannot read, with its one-line reason; *crash* would be a bug (a traceback), none is the "
        "target.", "",
        f"**{len(rows)} assets: {counts['passed']} passed, {counts['failed']} failed, {counts['error']} errors "
        f"naming the file and the cause, {counts['crash']} crashes.**", "",
        "## Every asset", "",
        *table(["asset", "format", "verdict", "failed checks / error", "movable joints (as named in the file)",
                "read as opening toward the written lower limit", "warnings"],
               [[f"`<{r.snapshot}>/{r.asset}`", r.format, r.verdict, r.detail or "-", ", ".join(r.joints) or "-",
                 ", ".join(r.opening) or "-", "; ".join(r.warnings) or "-"] for r in rows]),
        "", "## GenSim2: each USD (Isaac Sim's URDF importer) against its own URDF", "",
        "`spark-bench metrics --pred <GenSim2>/assets/articulated_objs/OBJ/mobility/mobility.usd --gt "
        "<GenSim2>/assets/articulated_objs/OBJ` (100000 samples, seed 0; each normalized into its own benchmark "
        "frame, so the sizes do not matter). Issue 43's bar for the first three: AxisErr <= 0.01 rad, PivotErr <= "
        "0.01, TypeErr 0, CD <= 0.02. `door/8877` is not one object in two files: the difference is the data's.", "",
        *table(["object", "USD check", "URDF check", "AxisErr", "PivotErr", "TypeErr", "CD",
                "what differs between the two as read"], pairs),
        "", "## Every GenSim2 USD, read", "",
        f"Each `<GenSim2>/assets/articulated_objs/*/*/mobility/mobility.usd` the snapshot holds, read as `load_object` "
        f"reads it (no checks): {sum(r[4] == '-' for r in sweep)} of {len(sweep)} read. *Continuous*: unlimited "
        "revolute joints whose only drive is the importer's default (a URDF `continuous` joint, as Isaac's importer "
        "writes it).", "",
        *table(["object", "movable joints", "continuous (the importer's drive)",
                "read as opening toward the written lower limit", "error"], sweep),
        "", "## The scripted opener on the parts issue 43 names", "",
        "`spark-bench rollout --env ENV --asset ASSET --joint JOINT --episodes 2` (before issue 43 the two drawers "
        "were declined: \"the joint opens into the object: is its axis reversed?\").", "",
        *table(["asset", "joint", "environment", "success rate"], rollouts), ""]
    old = args.out.read_text() if args.out.is_file() else ""
    notes = old[old.index(NOTES):] if NOTES in old else f"{NOTES}\n"
    args.out.write_text("\n".join(lines) + "\n" + notes)
    print(f"wrote {args.out}: {counts}")


if __name__ == "__main__":
    main()
