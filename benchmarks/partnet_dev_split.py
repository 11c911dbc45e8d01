"""Two fixed halves of ``../shared/partnet_dev``: rules are tuned on ``tune`` and reported on ``holdout``.

The objects are split per category (``meta.json``'s ``model_cat``), each category's ids ordered by the SHA-1
of the id and dealt alternately (the turn carried across categories), so both halves hold every category with two or more objects and no one
chooses which object lands where. ``python -m benchmarks.partnet_dev_split [ROOT]`` prints the halves and
writes ``benchmarks/results/partnet_dev_split.json``; the measuring scripts read that file
(:func:`read_halves`, their ``--half tune|holdout``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DEV = ROOT.parent / "shared" / "partnet_dev"
SPLIT_FILE = ROOT / "benchmarks" / "results" / "partnet_dev_split.json"


def category_of(folder: Path) -> str:
    """The object's PartNet-Mobility category (``meta.json``), ``unknown`` without one."""
    try:
        return str(json.loads((folder / "meta.json").read_text()).get("model_cat") or "unknown")
    except (OSError, ValueError):
        return "unknown"


def split_halves(categories: dict[str, str]) -> dict[str, list[str]]:
    """``{"tune": ids, "holdout": ids}``: per category, ids ordered by SHA-1 and dealt alternately, the turn
    carried from one category to the next (the very first to ``tune``).

    :param categories: object id -> category
    """
    halves: dict[str, list[str]] = {"tune": [], "holdout": []}
    dealt = 0  # carried across categories, so odd-sized ones do not all give their extra object to one half
    for category in sorted(set(categories.values())):
        ids = sorted((i for i, c in categories.items() if c == category),
                     key=lambda i: hashlib.sha1(i.encode()).hexdigest())
        for object_id in ids:
            halves["tune" if dealt % 2 == 0 else "holdout"].append(object_id)
            dealt += 1
    return {name: sorted(ids) for name, ids in halves.items()}


def read_halves(path: Path = SPLIT_FILE) -> dict[str, list[str]]:
    """The halves written by this script."""
    data = json.loads(path.read_text())
    return {"tune": list(data["tune"]), "holdout": list(data["holdout"])}


def main(argv: list[str] | None = None) -> int:
    """Split the objects of ``ROOT`` (default ``../shared/partnet_dev``) and write the split file."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path, nargs="?", default=DEFAULT_DEV, help="a folder of PartNet-Mobility objects")
    root = parser.parse_args(argv).root
    folders = sorted(p for p in root.iterdir() if (p / "mobility.urdf").is_file())
    categories = {p.name: category_of(p) for p in folders}
    halves = split_halves(categories)
    SPLIT_FILE.write_text(json.dumps({"source": str(root.name), "rule": "per category, ids by SHA-1, dealt "
                                      "alternately (first to tune)", **halves,
                                      "categories": dict(sorted(categories.items()))}, indent=1) + "\n")
    for name, ids in halves.items():
        print(f"{name}: {len(ids)} objects")
    return 0


if __name__ == "__main__":
    sys.exit(main())
