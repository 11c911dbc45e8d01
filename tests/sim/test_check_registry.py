"""The sim-readiness checks are declared once (issue #45, item 2): ``spark_bench.sim.check_registry.CHECKS`` makes
the report's order, what ``run_checks`` and ``run_model_checks`` run, PhysX's names and the docs table."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from helpers_assets import tiny_cabinet

from spark_bench.sim.check_inputs import NOT_COMPILED, CheckInputs
from spark_bench.sim.check_registry import (
    CHECK_NAMES,
    CHECKS,
    NEEDS,
    PHYSX_CHECKS,
    PHYSX_OWN,
    CheckSpec,
    docs_table,
)
from spark_bench.sim.checks import run_model_checks, run_registered
from spark_bench.sim.results import CheckResult

CONVENTIONS = Path(__file__).resolve().parents[2] / "docs" / "conventions.md"


def docs_rows() -> list[str]:
    """The table of checks in conventions.md's *Sim-readiness* section, one line per row, header included."""
    text = CONVENTIONS.read_text()
    section = text[text.index("\n## Sim-readiness"):]
    section = section[:section.index("\n## ", 1)]
    start = section.index("| check | value | passes when |")
    lines = section[start:].splitlines()
    return lines[:next((i for i, line in enumerate(lines) if not line.startswith("|")), len(lines))]


def test_the_docs_table_is_the_registry():
    rows = docs_rows()
    names = [re.match(r"\| `(\w+)` \|", row).group(1) for row in rows[2:]]
    assert names == list(CHECK_NAMES), "docs/conventions.md's checks differ from CHECKS in name or order"
    assert "\n".join(rows) == docs_table(), "docs/conventions.md's table of checks is not check_registry.docs_table()"


def test_the_table_finder_and_renderer_see_a_changed_registry():
    """A check added to (or moved in) the registry is not in the docs' table."""
    extra = CheckSpec("new_check", ("model",), CHECKS[-1].run, None, "v", "p")
    assert extra.row() not in docs_rows()
    assert docs_rows()[2:] == [c.row() for c in CHECKS]
    with pytest.raises(ValueError, match="unknown needs"):
        CheckSpec("odd", ("hulls",), CHECKS[-1].run, None, "v", "p")


def test_every_check_is_declared_once_with_known_needs():
    assert len(set(CHECK_NAMES)) == len(CHECKS) == 7
    assert all(set(c.needs) <= set(NEEDS) and c.needs for c in CHECKS)
    assert CHECK_NAMES[0] == "mesh_files" and CHECKS[0].needs == ("source",)


def test_physx_lists_the_shared_checks_by_the_registry_names_in_its_order():
    from spark_bench.sim.physx import engines

    assert engines.PHYSX_CHECKS is PHYSX_CHECKS
    shared = [n for n in PHYSX_CHECKS if n not in PHYSX_OWN]
    assert shared == [n for n in CHECK_NAMES if n in shared] and set(PHYSX_OWN) <= set(PHYSX_CHECKS)


class Unmet(CheckInputs):
    """Inputs none of whose needs but ``source`` is met."""

    def __init__(self, fails: bool) -> None:
        super().__init__({})
        self.fails_unmet = fails
        self.asset = tiny_cabinet()

    def unmet(self, need: str) -> str | None:
        return None if need == "source" else f"no {need}"


def test_a_check_whose_need_is_not_met_fails_with_its_reason_or_is_left_out():
    inputs = Unmet(fails=True)
    run_registered(inputs)
    assert list(inputs.checks) == list(CHECK_NAMES)
    assert inputs.checks["mesh_files"].passed
    for spec in CHECKS[1:]:
        result = inputs.checks[spec.name]
        assert not result.passed and result.details == {"reason": f"no {spec.needs[0]}"}
    left_out = Unmet(fails=False)
    run_registered(left_out)
    assert list(left_out.checks) == ["mesh_files"] and isinstance(left_out.checks["mesh_files"], CheckResult)


def test_a_model_file_that_does_not_compile_reports_that_alone(tmp_path):
    xml = tmp_path / "model.xml"
    xml.write_text('<mujoco model="m"><asset><mesh name="gone" file="gone.obj"/></asset>'
                   '<worldbody><geom type="mesh" mesh="gone"/></worldbody></mujoco>')
    report = run_model_checks(xml)
    assert list(report.checks) == ["mjcf_compiles"] and not report.passed
    assert report.checks["mjcf_compiles"].details["reason"] != NOT_COMPILED
