"""The package layout: the top-level packages of ``spark_bench`` form one order, and the README states it.

Every import counts, deferred ones (inside functions), ``TYPE_CHECKING`` ones and module names written as
strings (lazy exports, entry points, the CLI's command modules) included: a package may import only the
packages of the layers below its own (:data:`LAYERS`, lowest first); two packages of one layer never import
each other. One sub-package is a unit of its own (:data:`SUB_UNITS`): ``opening.planning`` (the grasp planner,
the end-effectors, the opening task's scene) sits below ``envs``, which simulates its scenes, and the rest of
``opening`` (the scripted opener and the judge, which run the environments) above it.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "spark_bench"
#: The order, lowest first; the README's architecture section states it (``ORDER_LINE``).
LAYERS = (
    ("errors", "jsonio", "paths", "lazy", "timing", "kernels", "mujoco_gl"),
    ("versions",),
    ("asset",),
    ("data",),
    ("metrics", "sim", "formats"),
    ("opening.planning",),
    ("envs",),
    ("opening",),
    ("rl", "methods"),
    ("evaluation",),
    ("cli",),
)
ORDER_LINE = " <- ".join(", ".join(layer) for layer in LAYERS)
#: Sub-packages that are units of their own, in another layer than their parent package.
SUB_UNITS = ("opening.planning",)
MODULE_NAME = re.compile(r"^spark_bench(\.\w+)+(:\w+)?$")


def top_level_units() -> set[str]:
    """The top-level packages and modules of ``spark_bench`` (its ``__init__`` aside)."""
    units = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    units |= {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    return units | set(SUB_UNITS)


def _unit_of_parts(parts: list[str]) -> str:
    """The unit of a dotted path below ``spark_bench`` (its parts, ``spark_bench`` left out)."""
    for sub in SUB_UNITS:
        if parts[:len(sub.split("."))] == sub.split("."):
            return sub
    return parts[0]


def unit_of(path: Path) -> str | None:
    """The top-level unit a source file belongs to (None for ``spark_bench/__init__.py``)."""
    parts = path.relative_to(PACKAGE).parts
    if len(parts) == 1:
        return None if parts[0] == "__init__.py" else Path(parts[0]).stem
    return _unit_of_parts(list(parts))


def imported_units(tree: ast.AST, units: set[str]) -> list[tuple[str, int]]:
    """``(unit, line)`` of every ``spark_bench.<unit>`` a module imports, in any way."""
    out = []
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and MODULE_NAME.match(node.value):
            names = [node.value.split(":")[0]]
        for name in names:
            parts = name.split(".")
            if parts[0] == "spark_bench" and len(parts) > 1 and parts[1] in units:
                out.append((_unit_of_parts(parts[1:]), node.lineno))
    return out


def import_edges() -> dict[tuple[str, str], str]:
    """``{(importer, imported): "file:line"}`` between distinct top-level units."""
    units = top_level_units()
    edges: dict[tuple[str, str], str] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        source = unit_of(path)
        if source is None:
            continue
        for target, line in imported_units(ast.parse(path.read_text(), str(path)), units):
            if target != source:
                edges.setdefault((source, target), f"{path.relative_to(ROOT)}:{line}")
    return edges


def test_every_top_level_package_has_a_place_in_the_order():
    placed = [unit for layer in LAYERS for unit in layer]
    assert len(placed) == len(set(placed))
    assert top_level_units() == set(placed), "add the new package to LAYERS and the README's order"


def test_imports_run_down_the_order_only():
    layer_of = {unit: k for k, layer in enumerate(LAYERS) for unit in layer}
    wrong = [f"{a} -> {b} ({where})" for (a, b), where in import_edges().items() if layer_of[b] >= layer_of[a]]
    assert not wrong, "imports against the order:\n" + "\n".join(wrong)


def test_the_order_checker_sees_deferred_and_string_imports():
    """The checker is not blind: it finds an import inside a function and a lazily exported module name."""
    units = top_level_units()
    tree = ast.parse("def f():\n    from spark_bench.evaluation import runner\n"
                     "EXPORTS = {'x': 'spark_bench.methods.ours.config'}\n")
    assert sorted({u for u, _ in imported_units(tree, units)}) == ["evaluation", "methods"]


def test_the_readme_states_the_order_and_every_package():
    readme = (ROOT / "README.md").read_text()
    assert ORDER_LINE in readme, f"README must state the import order: {ORDER_LINE}"
    architecture = readme.split("## Architecture", 1)[1].split("\n## ", 1)[0]
    for unit in top_level_units() - set(SUB_UNITS):
        name = unit if (PACKAGE / unit).is_dir() else f"{unit}.py"
        shown = f"`{name}/`" if (PACKAGE / unit).is_dir() else f"`{name}`"
        assert shown in architecture, f"README's module map lacks {shown}"
