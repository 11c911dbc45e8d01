"""``benchmarks/`` is a package with an index: its scripts run as ``python -m benchmarks.<name>`` and share code
by importing ``benchmarks.<module>`` (never by editing ``sys.path``), and ``benchmarks/README.md`` names every
script, every shared module, every report in ``benchmarks/results/`` and every config in ``benchmarks/configs/``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = ROOT / "benchmarks"
README = BENCHMARKS / "README.md"


def _sources() -> list[Path]:
    """The scripts and shared modules: the Python files of ``benchmarks/`` itself (``protocols/``, the papers'
    protocol parity checks, loads the papers' own code from their checkouts: it keeps its own rules)."""
    return sorted(BENCHMARKS.glob("*.py"))


def _edits_sys_path(tree: ast.AST) -> list[int]:
    """Lines that change ``sys.path``: a call of one of its methods, or an assignment to it."""
    lines = []
    for node in ast.walk(tree):
        target = None
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            target = node.func.value
        elif isinstance(node, (ast.Assign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            target = next((t for t in targets if isinstance(t, (ast.Attribute, ast.Subscript))), None)
            target = target.value if isinstance(target, ast.Subscript) else target
        if (isinstance(target, ast.Attribute) and target.attr == "path" and isinstance(target.value, ast.Name)
                and target.value.id == "sys"):
            lines.append(node.lineno)
    return lines


def test_the_check_sees_a_sys_path_edit():
    assert _edits_sys_path(ast.parse("import sys\nsys.path.insert(0, 'x')\n")) == [2]
    assert _edits_sys_path(ast.parse("import sys\nsys.path += ['x']\n")) == [2]
    assert _edits_sys_path(ast.parse("import sys\nprint(sys.path)\n")) == []


def test_benchmarks_is_a_package():
    assert (BENCHMARKS / "__init__.py").is_file()


@pytest.mark.parametrize("path", _sources(), ids=lambda p: p.name)
def test_no_script_edits_sys_path(path):
    assert _edits_sys_path(ast.parse(path.read_text())) == [], f"{path.name} edits sys.path"


@pytest.mark.parametrize("path", _sources(), ids=lambda p: p.name)
def test_benchmark_modules_are_imported_through_the_package(path):
    local = {p.stem for p in _sources()}
    for node in ast.walk(ast.parse(path.read_text())):
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
            [node.module] if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 else [])
        for name in names:
            assert name.split(".")[0] not in local, f"{path.name}:{node.lineno} imports {name} (use benchmarks.{name})"


def test_readme_names_every_script_module_report_and_config():
    text = README.read_text()
    # the scripts and shared modules by module name; protocols/ (its owners add to it) as a folder
    wanted = [p.stem for p in BENCHMARKS.glob("*.py") if p.name != "__init__.py"] + ["protocols/"]
    wanted += [p.name for p in (BENCHMARKS / "results").iterdir() if p.suffix in (".md", ".json")]
    wanted += [p.name + "/" for p in (BENCHMARKS / "results").iterdir() if p.is_dir()]
    wanted += [p.name for p in (BENCHMARKS / "configs").iterdir()]
    missing = [w for w in wanted if f"`{w}`" not in text and f"`{w.removesuffix('/')}" not in text]
    assert missing == []
