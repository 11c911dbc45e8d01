"""The real size PartNet-Mobility objects are read at (:mod:`spark_bench.data.real_size`), per category: the
``info.json`` scales, the median that :data:`~spark_bench.data.real_size.CATEGORY_SCALE` holds, and each
object's largest side as its files give it and at its real size.

    python -m benchmarks.measure_real_size --src ../shared/partnet_dev --src ../shared/real_objects \\
        --out benchmarks/results/real_size.md
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
NOTES = "<!-- notes: kept when the script rewrites the file -->"


def largest_side(folder: Path) -> float:
    """The largest side (file units) of the object's world box at rest, from its URDF as the files give it."""
    from spark_bench.asset.urdf import load_urdf
    from spark_bench.data.readers import find_urdf

    urdf = find_urdf(folder)
    low, high = load_urdf(urdf, folder=folder).bounds()
    return float((high - low).max())


def main() -> None:
    """Read every object of every ``--src`` and write the table (notes below it kept)."""
    from spark_bench.data.readers import read_json
    from spark_bench.data.real_size import CATEGORY_SCALE, source_scale

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--src", type=Path, action="append", required=True, help="a folder of object folders")
    parser.add_argument("--out", type=Path, default=RESULTS / "real_size.md")
    args = parser.parse_args()

    rows: dict[tuple[str, str], list[tuple[str, float, str, float]]] = {}
    for src in args.src:
        for folder in sorted(p for p in src.iterdir() if p.is_dir() and not p.name.startswith(".")):
            category = str(read_json(folder / "meta.json", {}).get("model_cat", ""))
            scale = source_scale(folder, category)
            rows.setdefault((src.name, category), []).append(
                (folder.name, scale.factor, scale.rule, largest_side(folder)))

    lines = [
        "# The real size of PartNet-Mobility objects (issue 23, items 2 and 5)", "",
        f"Written by `benchmarks/measure_real_size.py` ({time.strftime('%Y-%m-%d %H:%M')}). Rule: "
        "`spark_bench.data.real_size` (an object's `info.json` scale, else its category's median of them, "
        "else as read). *Largest side*: of the object's box at rest, min-max over the category's objects.", "",
        "| set | category | objects | scale (rule) | median scale | table | largest side as read (units) "
        "| largest side read (m) |",
        "|---|---|---|---|---|---|---|---|"]
    for (set_name, category), objects in sorted(rows.items()):
        scales = [o[1] for o in objects]
        rules = sorted({o[2] for o in objects})
        sides = [o[3] for o in objects]
        real = [o[1] * o[3] for o in objects]
        lines.append(
            f"| {set_name} | {category} | {len(objects)} | {min(scales):g}-{max(scales):g} ({', '.join(rules)}) "
            f"| {statistics.median(scales):g} | {CATEGORY_SCALE.get(category, '-')} "
            f"| {min(sides):.2f}-{max(sides):.2f} | {min(real):.2f}-{max(real):.2f} |")
    old = args.out.read_text() if args.out.is_file() else ""
    notes = old[old.index(NOTES):] if NOTES in old else f"{NOTES}\n"
    args.out.write_text("\n".join(lines) + "\n\n" + notes)
    print(args.out.read_text())


if __name__ == "__main__":
    main()
