"""Sim-readiness checks: each a number and a pass/fail.

The checks are declared in :data:`spark_bench.sim.check_registry.CHECKS` (name, needs, function, docs row), in report
order; :func:`run_checks` and :func:`run_model_checks` run that registry on what they read
(:mod:`spark_bench.sim.check_inputs`). Each check's function is in its own module: ``mesh_files``
(:mod:`.check_files`), ``mjcf_compiles`` and ``pybullet_loads`` (:mod:`.check_load`), ``mass_inertia``
(:mod:`.check_mass`), ``rest_stability`` and ``rest_penetration`` (:mod:`.check_rest`), ``joint_sweep``
(:mod:`.check_sweep`, the sweep itself in :mod:`spark_bench.sim.sweep`); the result types are in
:mod:`spark_bench.sim.results`. The names these modules had here are kept importable from this one.
"""

from __future__ import annotations

import time
from pathlib import Path

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.check_files import check_mesh_files
from spark_bench.sim.check_inputs import CheckInputs, ModelFileInputs, SourceInputs
from spark_bench.sim.check_mass import check_mass_inertia
from spark_bench.sim.check_registry import CHECKS
from spark_bench.sim.check_rest import (
    PENETRATION_TOLERANCE,
    REST_DRIFT_FLOOR,
    REST_DRIFT_TOLERANCE,
    REST_SECONDS,
    RestContact,
    check_rest_penetration,
    check_rest_stability,
    rest_contacts,
)
from spark_bench.sim.converter import load_source
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.results import CheckReport, CheckResult


def run_registered(inputs: CheckInputs, seconds: dict[str, float] | None = None) -> None:
    """Run every check of :data:`~spark_bench.sim.check_registry.CHECKS`, in order, into ``inputs.checks``.

    A check whose need is not met (:meth:`CheckInputs.unmet`, asked in the order of its needs) is not run: it fails
    with that need's reason (value NaN), or is left out where ``inputs.fails_unmet`` is False.

    :param inputs: what the checks read
    :param seconds: add each check's wall time to its stage's key here (None: not timed)
    """
    for spec in CHECKS:
        reason = next((r for r in map(inputs.unmet, spec.needs) if r is not None), None)
        if reason is not None:
            if inputs.fails_unmet:
                inputs.checks[spec.name] = CheckResult(False, float("nan"), {"reason": reason})
            continue
        start = time.perf_counter()
        inputs.checks[spec.name] = spec.run(inputs)
        if seconds is not None and spec.stage is not None:
            seconds[spec.stage] = seconds.get(spec.stage, 0.0) + time.perf_counter() - start


def run_checks(src, options: ConvertOptions | None = None, render: Path | None = None,
               progress: bool = False) -> CheckReport:
    """Convert ``src`` (object folder, URDF or :class:`ArticulatedAsset`) and run every check; a
    ``model.xml`` written by :func:`spark_bench.sim.convert` is checked as it is.

    :param src: the object
    :param options: conversion options
    :param render: write the check strip (PNG) here
    :param progress: show conversion progress
    :raises InputError: when ``src`` cannot be read at all
    """
    if not isinstance(src, ArticulatedAsset) and Path(src).suffix.lower() == ".xml":
        return run_model_checks(Path(src), render)
    clock = time.perf_counter()
    asset = load_source(src)
    report = CheckReport(asset.name, warnings=list(getattr(asset, "warnings", [])))
    report.seconds["load"] = time.perf_counter() - clock
    inputs = SourceInputs(asset, report.checks, report.seconds, options, progress)
    run_registered(inputs, report.seconds)
    if inputs.unmet("model") is not None:  # not converted, or no model to render
        return report
    if render is not None:
        from spark_bench.sim.render import render_check_strip

        start = time.perf_counter()
        render_check_strip(inputs.compiled.spec, Path(render))
        report.seconds["render"] = time.perf_counter() - start
    report.seconds["total"] = time.perf_counter() - clock
    return report


def run_model_checks(xml: Path, render: Path | None = None) -> CheckReport:
    """The checks of an already converted ``model.xml`` (PyBullet: the ``model.urdf`` beside it); ``mesh_files``
    is left out (its source is not there), and so is every check after ``mjcf_compiles`` where it does not compile.

    :raises InputError: when the file is missing or is not MJCF
    """
    inputs = ModelFileInputs.read(xml, {})
    report = CheckReport(inputs.name, inputs.checks)
    run_registered(inputs)
    if render is not None and inputs.model is not None:
        from spark_bench.sim.render import render_check_strip

        render_check_strip(inputs.compiled.spec, Path(render))
    return report


__all__ = ["PENETRATION_TOLERANCE", "REST_DRIFT_FLOOR", "REST_DRIFT_TOLERANCE", "REST_SECONDS", "RestContact",
           "check_mass_inertia", "check_mesh_files", "check_rest_penetration", "check_rest_stability", "rest_contacts",
           "run_checks", "run_model_checks", "run_registered"]
