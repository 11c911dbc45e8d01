"""The package layout: the top-level packages of ``spark_bench`` form one order, ``docs/architecture.md``
states it, no module imports itself back (no cycle), no private name is taken across modules, and no function
or module grows past the sizes a reader holds in mind.

Every import counts, deferred ones (inside functions), ``TYPE_CHECKING`` ones and module names written as
strings (lazy exports, entry points, the CLI's command modules) included: a package may import only the
packages of the layers below its own (:data:`LAYERS`, lowest first); two packages of one layer never import
each other. A unit is a top-level package or module: no sub-package has a layer of its own.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "spark_bench"
#: The order, lowest first; ``docs/architecture.md`` states it (``ORDER_LINE``).
LAYERS = (
    ("errors", "jsonio", "paths", "lazy", "timing", "kernels", "mujoco_gl", "convention"),
    ("versions", "ray_executor"),
    ("asset",),
    ("data",),
    ("metrics", "sim", "formats"),
    ("manipulation",),
    ("envs",),
    ("opening",),
    ("rl", "methods"),
    ("evaluation",),
    ("cli",),
)
ORDER_LINE = " <- ".join(", ".join(layer) for layer in LAYERS)
MODULE_NAME = re.compile(r"^spark_bench(\.\w+)+(:\w+)?$")


def top_level_units() -> set[str]:
    """The top-level packages and modules of ``spark_bench`` (its ``__init__`` aside)."""
    units = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    return units | {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}


def unit_of(path: Path) -> str | None:
    """The top-level unit a source file belongs to (None for ``spark_bench/__init__.py``)."""
    parts = path.relative_to(PACKAGE).parts
    if len(parts) == 1:
        return None if parts[0] == "__init__.py" else Path(parts[0]).stem
    return parts[0]


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
                out.append((parts[1], node.lineno))
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
    assert top_level_units() == set(placed), "add the new package to LAYERS and docs/architecture.md's order"


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


def test_the_architecture_document_states_the_order_and_every_package():
    architecture = (ROOT / "docs" / "architecture.md").read_text()
    assert ORDER_LINE in architecture, f"docs/architecture.md must state the import order: {ORDER_LINE}"
    missing = []
    for unit in sorted(top_level_units()):
        shown = f"`{unit}/`" if (PACKAGE / unit).is_dir() else f"`{unit}.py`"
        if shown not in architecture:
            missing.append(shown)
    assert not missing, "docs/architecture.md's module map lacks " + ", ".join(missing)


# -- module graph, private names, sizes ---------------------------------------------------------------------

#: The folders whose files may not take each other's private names.
PROJECT_FOLDERS = ("spark_bench", "tests", "benchmarks")
#: The longest function and the longest module (in lines) ``spark_bench`` holds.
MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 500


def module_name(path: Path) -> str:
    """The dotted name of a source file below :data:`ROOT` (a package is named by its ``__init__``)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_modules() -> dict[str, Path]:
    """``{dotted name: file}`` of every module of ``spark_bench``."""
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def resolve_from(node: ast.ImportFrom, importer: str, is_package: bool) -> str:
    """The absolute module an ``from ... import`` names (relative ones resolved against ``importer``)."""
    if not node.level:
        return node.module or ""
    base = importer.split(".") if is_package else importer.split(".")[:-1]
    base = base[:len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def imported_modules(tree: ast.AST, importer: str, is_package: bool, modules: set[str]) -> list[tuple[str, int]]:
    """``(module, line)`` of every module of ``modules`` a module imports, anywhere in it (inside functions
    and ``TYPE_CHECKING`` blocks too): ``import a.b.c`` and ``from a.b import c`` (``c`` a module) import
    ``a.b.c``, not its parents; ``from a.b import name`` imports ``a.b``."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name in modules]
        elif isinstance(node, ast.ImportFrom):
            source = resolve_from(node, importer, is_package)
            for alias in node.names:
                target = f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source
                if target in modules:
                    out.append((target, node.lineno))
    return out


def module_graph() -> dict[str, dict[str, int]]:
    """``{importer: {imported: line}}`` between the modules of ``spark_bench``."""
    modules = package_modules()
    graph: dict[str, dict[str, int]] = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), str(path))
        edges = graph.setdefault(name, {})
        for target, line in imported_modules(tree, name, path.name == "__init__.py", set(modules)):
            if target != name:
                edges.setdefault(target, line)
    return graph


def cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, {}))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, {})))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def describe_cycle(component: list[str], graph: dict[str, dict[str, int]]) -> str:
    """A cycle's modules and the imports that bind them, each as ``file:line``."""
    modules = package_modules()
    members = set(component)
    edges = [f"    {a} -> {b} ({modules[a].relative_to(ROOT)}:{line})"
             for a in component for b, line in sorted(graph[a].items()) if b in members]
    return " <-> ".join(component) + "\n" + "\n".join(edges)


def test_no_import_cycle_between_modules():
    graph = module_graph()
    found = cycles(graph)
    assert not found, "import cycles:\n" + "\n".join(describe_cycle(c, graph) for c in found)


def test_the_cycle_finder_sees_a_deferred_import_and_not_a_parent():
    """A cycle closed by an import inside a function is one; importing ``a.b.c`` is no import of ``a.b``."""
    modules = {"p", "p.a", "p.b", "p.c"}
    a = ast.parse("import p.b\n")
    b = ast.parse("def f():\n    from p import a\n")
    c = ast.parse("from p.a import thing\n")
    graph = {"p": {}, "p.a": dict(imported_modules(a, "p.a", False, modules)),
             "p.b": dict(imported_modules(b, "p.b", False, modules)),
             "p.c": dict(imported_modules(c, "p.c", False, modules))}
    assert graph["p.a"] == {"p.b": 1} and graph["p.c"] == {"p.a": 1}
    assert cycles(graph) == [["p.a", "p.b"]]


def project_module_names() -> set[str]:
    """The dotted names of the project's own modules, and the bare names scripts and tests import their
    siblings by (``helpers_toy``, ``dev_split``: the folder is on ``sys.path``)."""
    names: set[str] = set()
    for folder in PROJECT_FOLDERS:
        for path in (ROOT / folder).rglob("*.py"):
            names.add(module_name(path))
            names.add(path.stem)
    return names


def is_private(name: str) -> bool:
    """``_x`` is private; ``__x__`` (dunder) is not."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_reaches(tree: ast.AST, importer: str, is_package: bool, project: set[str]) -> list[tuple[int, str]]:
    """``(line, what)`` of every private name a module takes from another module of the project: imported
    (``from m import _x``, ``import m._x``) or reached through a name imported from the project
    (``m._x`` after ``import m``, ``Class._x`` after ``from m import Class``)."""
    out: list[tuple[int, str]] = []
    bound: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in project or alias.name in project:
                    bound.add(alias.asname or alias.name.split(".")[0])
                    out += [(node.lineno, alias.name) for part in alias.name.split(".") if is_private(part)]
        elif isinstance(node, ast.ImportFrom):
            source = resolve_from(node, importer, is_package)
            if node.level or source in project or source.split(".")[0] in ("spark_bench", "tests", "benchmarks"):
                for alias in node.names:
                    bound.add(alias.asname or alias.name)
                    if is_private(alias.name):
                        out.append((node.lineno, f"{source}.{alias.name}"))
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and is_private(node.attr) and isinstance(node.value, ast.Name)
                and node.value.id in bound):
            out.append((node.lineno, f"{node.value.id}.{node.attr}"))
    return out


def test_no_private_name_is_taken_across_modules():
    project = project_module_names()
    found = []
    for folder in PROJECT_FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            for line, what in private_reaches(tree, module_name(path), path.name == "__init__.py", project):
                found.append(f"{path.relative_to(ROOT)}:{line} {what}")
    assert not found, "private names taken from another module (make them public or keep them home):\n" + \
        "\n".join(found)


def test_the_private_name_finder_sees_imports_attributes_and_test_helpers():
    project = {"spark_bench", "spark_bench.m", "helpers_toy"}
    tree = ast.parse("from spark_bench.m import _a, b as _b\nimport spark_bench.m as m\nfrom helpers_toy import _box\n"
                     "from os import _exit\nfrom spark_bench.m import K\nm._c\nK._d\nK.__init__\n")
    assert sorted(w for _, w in private_reaches(tree, "tests.t", False, project)) == [
        "K._d", "helpers_toy._box", "m._c", "spark_bench.m._a"]


def test_no_function_or_module_too_long():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        source = path.read_text()
        where = path.relative_to(ROOT)
        if (lines := len(source.splitlines())) > MAX_MODULE_LINES:
            found.append(f"{where}: {lines} lines (module; at most {MAX_MODULE_LINES})")
        for node in ast.walk(ast.parse(source, str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if (lines := node.end_lineno - node.lineno + 1) > MAX_FUNCTION_LINES:
                    found.append(f"{where}:{node.lineno} {node.name}: {lines} lines (at most {MAX_FUNCTION_LINES})")
    assert not found, "too long:\n" + "\n".join(found)
