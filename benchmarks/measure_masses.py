"""Simulated masses against real ones (issue 23, item 2): the thin-wall rule of
:mod:`spark_bench.sim.physical` checked against products whose mass and size are published, and the mass of
every drawer, door and lid of prepared benchmarks under the rule and under the solid rule it replaced.

1. *Cited products*: each is a closed box of the product's outer size, given its category's
   :class:`~spark_bench.sim.options.Material` exactly as the converter gives a link (one solid hull, then
   :func:`~spark_bench.sim.physical.link_mass_properties`); the table puts the rule's mass beside the
   published one with the page it comes from. A whole product (a suitcase with its wheels, a chest with its
   drawers) has more in it than its shell, which the table says per row.
2. *Benchmark parts*: for each case, the object the opening score acts on (its source, in the units the
   harness reads as metres), converted as in ``eval``; the mass of everything each drawer/door/lid joint
   moves, before (solid hulls x the category density the converter used until conv-3) and now.

    python -m benchmarks.measure_masses --bench <bench_partnet> --bench <bench_real> \\
        --out benchmarks/results/masses.md
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks.openable import openable

RESULTS = Path(__file__).resolve().parent / "results"

#: The rule before this change: every link a solid of its category's density (kg/m^3). Kept here only to
#: report what changed.
SOLID_DENSITY_BEFORE = {"wood": 600.0, "metal": 2700.0, "sheet_metal": 800.0, "plastic": 1050.0, "glass": 2500.0,
                        "ceramic": 2300.0, "default": 800.0, "steel_plate": 800.0}


@dataclass(frozen=True)
class CitedProduct:
    """A product whose mass and outer size a page states.

    :param name: the product
    :param category: the PartNet-Mobility category whose material it gets
    :param size: outer size (m), as the page gives it unless ``note`` says otherwise
    :param mass: the published mass, kg (low, high)
    :param url: the page
    :param note: what the published mass holds beyond a closed shell, or what was assumed
    """

    name: str
    category: str
    size: tuple[float, float, float]
    mass: tuple[float, float]
    url: str
    note: str = ""


LB = 0.45359237
CITED = [
    CitedProduct("Samsonite Firelite 75 cm trolley", "Suitcase", (0.75, 0.52, 0.31), (2.8, 2.8),
                 "https://testberichte.de/p/samsonite-tests/firelite-4-rollen-trolley-75-cm-testbericht.html",
                 "whole case: shell, wheels, handle"),
    CitedProduct("Monos Carry-On", "Suitcase", (0.56, 0.40, 0.23), (3.2, 3.2), "https://www.github.com/vektren/carryon",
                 "whole case"),
    CitedProduct("Rimowa Hybrid Cabin S", "Suitcase", (0.55, 0.40, 0.20), (3.7, 3.7),
                 "https://www.github.com/vektren/carryon", "whole case, with an aluminium frame"),
    CitedProduct("Box Cabas L (MDF box with lid)", "Box", (0.40, 0.30, 0.10), (3.0, 3.0),
                 "https://cdn.shopify.com/s/files/1/0315/1617/files/Specification_sheet_110047.pdf", ""),
    CitedProduct("Box Cabas S (MDF box with lid)", "Box", (0.28, 0.21, 0.10), (2.0, 2.0),
                 "https://cdn.shopify.com/s/files/1/0315/1617/files/Specification_sheet_110046.pdf", ""),
    CitedProduct("IKEA MALM chest of 3 drawers", "StorageFurniture", (0.80, 0.78, 0.48), (37.0, 37.0),
                 "http://www.robotics-handbook.net/maktich/homeware/chest.htm",
                 "the rule's closed box is the carcass only; three drawers add to the real one"),
    CitedProduct("Crespi 6-drawer cabinet (MDF, hardwood veneer)", "StorageFurniture", (1.80, 0.46, 0.78),
                 (100.0, 100.0),
                 "https://cdn.shopify.com/s/files/1/0315/1617/files/"
                 "Specification_sheet_109025_3ae681a4-bc85-48f6-b4a7-dca0c7baa194.pdf",
                 "carcass only in the rule; six drawers and hardwood add to the real one"),
    CitedProduct("medium countertop microwave (1.5 cu ft)", "Microwave", (0.61, 0.36, 0.41), (25 * LB, 35 * LB),
                 "https://thekitchenfeast.com/how-much-does-a-microwave-weigh/",
                 "mass range of countertop models; size 24 x 14 x 16 in from askingfact.com (another page); "
                 "the real one holds a transformer and magnetron"),
    CitedProduct("oven door", "Oven", (0.595, 0.50, 0.05), (15 * LB, 30 * LB),
                 "https://engineerfix.com/how-to-remove-and-reinstall-an-oven-door",
                 "size assumed (a 60 cm oven's door); the page gives the mass only"),
    CitedProduct("4 mm float glass, 1 m^2", "Window", (1.0, 1.0, 0.004), (10.0, 10.0),
                 "https://www.hnsaluminium.co.uk/the-weight-of-double-and-triple-glass-units", "a bare pane"),
]


def rule_mass(product: CitedProduct) -> float:
    """The rule's mass of a closed box of the product's size and category (one solid hull, as a converted link)."""
    from spark_bench.sim.options import ConvertOptions
    from spark_bench.sim.physical import link_mass_properties
    from spark_bench.sim.shapes import CollisionShape

    shape = CollisionShape(kind="box", method="given", origin=np.eye(4), size=np.asarray(product.size, float))
    material = ConvertOptions().material_of(product.category, "link", moving=True)
    return link_mass_properties([shape], material.density, material.wall).mass


def part_masses(case_dir: Path) -> list[dict]:
    """Per drawer/door/lid joint of a case: the moved mass now and under the solid rule before."""
    from spark_bench.data.case import BenchmarkCase, ground_truth_in_metres
    from spark_bench.opening.pairing import object_acted_on, opening_joints
    from spark_bench.sim.mjcf import prepare, subtree_mass
    from spark_bench.sim.options import CATEGORY_MATERIAL, ConvertOptions

    case = BenchmarkCase(case_dir)
    gt_bench, gt_metres, _ = ground_truth_in_metres(case.gt_dir)
    labels = openable(gt_bench)
    if not labels:
        return []
    obj, _ = object_acted_on(case.gt_dir, gt_metres)
    prepared = prepare(obj, ConvertOptions())
    material = CATEGORY_MATERIAL.get(obj.category.lower().replace(" ", ""), "default")
    rows = []
    for joint in opening_joints(obj):
        if joint.name not in labels:
            continue
        moved = subtree_mass(prepared, joint.name)
        size = np.sort(np.ptp(obj.bounds(), axis=0))[::-1]
        rows.append({"case": case.id, "category": obj.category, "part": labels[joint.name], "joint": joint.name,
                     "material": material, "mass": moved.mass, "before": moved.volume * SOLID_DENSITY_BEFORE[material],
                     "object_size": size})
    return rows


def markdown(rows: list[dict], seconds: float, benches: list[Path]) -> str:
    """The report: cited products, then every benchmark part."""
    from spark_bench.sim.options import MATERIALS

    lines = ["# Simulated masses against real ones (issue 23, item 2)", "",
             f"Written by `benchmarks/measure_masses.py` ({time.strftime('%Y-%m-%d %H:%M')}, {seconds:.0f} s). "
             "Rule (`spark_bench.sim.physical`): a link's mass is `density x min(solid volume, convex-hull area "
             "x wall)` with its category's material; materials: "
             + ", ".join(f"{k} {m.density:.0f} kg/m^3" + (f" / {1000 * m.wall:g} mm walls" if m.wall else " solid")
                         for k, m in MATERIALS.items()) + ".", "",
             "## 1. Cited products", "",
             "Each product as a closed box of its outer size with its category's material: the rule's mass "
             "beside the published one.", "",
             "| product | category | size (m) | published kg | rule kg | rule / published | source | what else the real one holds |",
             "|---|---|---|---|---|---|---|---|"]
    ratios = []
    for product in CITED:
        mass = rule_mass(product)
        low, high = product.mass
        ratio = mass / low if mass < low else (mass / high if mass > high else 1.0)
        ratios.append(ratio)
        published = f"{low:.1f}" if low == high else f"{low:.1f}-{high:.1f}"
        lines.append(f"| {product.name} | {product.category} | {' x '.join(f'{s:g}' for s in product.size)} | "
                     f"{published} | {mass:.1f} | {ratio:.2f} | {product.url} | {product.note} |")
    lines += ["", f"Rule / published (1.00 inside a published range): from {min(ratios):.2f} to {max(ratios):.2f}.",
              "", "## 2. Drawers, doors and lids of the benchmarks", "",
              f"Benchmarks: {', '.join(f'`<{Path(b).name}>`' for b in benches)} (see benchmarks/README.md). The object the opening score acts on (the "
              "case's source at its real size, `spark_bench.data.real_size`, as `eval` does); *moved kg* is everything the joint "
              "moves; *before*: solid hulls x the category density used until `spark-bench-conv-3` (sheet "
              "metal and safes 800 kg/m^3 effective).", "",
              "| case | category | part | joint | object size (m) | material | moved kg before | moved kg now |",
              "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| {row['case']} | {row['category']} | {row['part']} | {row['joint']} | "
                     f"{' x '.join(f'{s:.2f}' for s in row['object_size'])} | {row['material']} | "
                     f"{row['before']:.1f} | {row['mass']:.1f} |")
    heavy_before = sum(r["before"] > 20 for r in rows)
    heavy_now = sum(r["mass"] > 20 for r in rows)
    lines += ["", f"Parts of more than 20 kg: {heavy_before} before, {heavy_now} now, of {len(rows)}; the heaviest now "
              f"{max(r['mass'] for r in rows):.1f} kg (before {max(r['before'] for r in rows):.1f} kg)." if rows else ""]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bench", type=Path, action="append", default=[], help="a prepared benchmark folder")
    parser.add_argument("--out", type=Path, default=RESULTS / "masses.md")
    args = parser.parse_args(argv)
    from tqdm import tqdm

    start = time.perf_counter()
    cases = [case for bench in args.bench for case in sorted((bench / "cases").iterdir()) if case.is_dir()]
    rows = [row for case in tqdm(cases, desc="cases") for row in part_masses(case)]
    text = markdown(rows, time.perf_counter() - start, args.bench)
    args.out.write_text(text)
    print(text.split("## 2.")[0])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
