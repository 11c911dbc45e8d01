"""What the sim-readiness checks read (:class:`CheckInputs`), each made when a check first needs it.

A check's needs (:data:`spark_bench.sim.check_registry.NEEDS`) are met or not by the inputs of the run:

- :class:`SourceInputs` (``run_checks`` on an object folder, URDF, MJCF or USD read as an asset): the source is
  there; the conversion and the MJCF are made only when ``mesh_files`` passed (as ``convert`` refuses an object
  whose mesh files cannot be loaded), the compiled model only when the MJCF compiles. A check whose need is not
  met fails, with the reason of that need.
- :class:`ModelFileInputs` (``run_checks`` on a converted ``model.xml``): no source; the file is the MJCF, and its
  conversion (hulls, joints, size) is read from its compiled model. A check whose need is not met is left out of
  the report (a ``model.xml`` that does not compile reports ``mjcf_compiles`` alone).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.results import CheckResult
from spark_bench.sim.sweep import SweptJoint, swept_joints, swept_joints_of_model

#: The reason of a check that needs the conversion when ``mesh_files`` failed.
NOT_CONVERTED = "not converted: the URDF names mesh files that cannot be loaded (mesh_files)"
#: The reason of a check that needs the compiled model when the MJCF does not compile.
NOT_COMPILED = "the MJCF does not compile"
#: The reason a converted ``model.xml`` has no ``source``.
NO_SOURCE = "a converted model.xml: the files it was converted from are not there"


@dataclass
class Compiled:
    """An MJCF spec and its compilation.

    :param spec: the ``mujoco.MjSpec`` (None: building it failed)
    :param model: the compiled ``MjModel`` (None: it did not compile)
    :param seconds: seconds ``spec.compile()`` took
    :param error: the builder's or compiler's message, on one line (None: it compiled)
    """

    spec: object | None
    model: object | None
    seconds: float = float("nan")
    error: str | None = None


class CheckInputs:
    """The inputs of one run of the checks: what each check may read, made on first use.

    :ivar asset: the object (None: a converted ``model.xml``)
    :ivar xml: the converted ``model.xml`` checked (None: an object converted here)
    :ivar checks: the results so far, in report order (the run's ``CheckReport.checks``)
    :ivar fails_unmet: True: a check whose need is not met fails with its reason; False: it is left out
    """

    asset: ArticulatedAsset | None = None
    xml: Path | None = None
    prepared = None  #: the prepared object (:func:`spark_bench.sim.mjcf.prepare`; None: not converted here)
    convert_seconds = float("nan")  #: the seconds the preparation took
    fails_unmet = True

    def __init__(self, checks: dict[str, CheckResult]) -> None:
        self.checks = checks

    def unmet(self, need: str) -> str | None:
        """Why ``need`` cannot be met (None: it is met, and made if it was not yet).

        :param need: a key of :data:`spark_bench.sim.check_registry.NEEDS`
        """
        raise NotImplementedError

    @cached_property
    def compiled(self) -> Compiled:
        """The MJCF built and compiled."""
        raise NotImplementedError

    @property
    def model(self):
        """The compiled ``MjModel`` (None: it did not compile)."""
        return self.compiled.model

    @cached_property
    def joints(self) -> list[SweptJoint]:
        """The joints the rest and sweep checks move."""
        raise NotImplementedError

    @cached_property
    def size(self) -> float:
        """The object's size (m): every relative tolerance refers to it."""
        raise NotImplementedError

    @property
    def excluded(self) -> dict | None:
        """The body pairs the converter excluded from collision, with their depth at rest (None: not known)."""
        return None if self.prepared is None else self.prepared.excluded


class SourceInputs(CheckInputs):
    """An object read as an asset and converted here (:func:`spark_bench.sim.mjcf.prepare`, on first need).

    :param asset: the object
    :param checks: the run's results so far
    :param seconds: the report's seconds per stage, where the conversion adds its own
    :param options: conversion options
    :param progress: show conversion progress
    """

    def __init__(self, asset: ArticulatedAsset, checks: dict[str, CheckResult], seconds: dict[str, float],
                 options: ConvertOptions | None = None, progress: bool = False) -> None:
        super().__init__(checks)
        self.asset, self.seconds, self.options, self.progress = asset, seconds, options, progress

    def unmet(self, need: str) -> str | None:
        if need == "source":
            return None
        if not self.checks["mesh_files"].passed:  # the object as written cannot be simulated: not converted
            return NOT_CONVERTED
        self.convert()
        if need == "model" and self.model is None:
            return NOT_COMPILED
        return None

    def convert(self) -> None:
        """Prepare the collision shapes, masses and contacts (once), adding their seconds to the report's."""
        if self.prepared is not None:
            return
        from spark_bench.sim.mjcf import prepare

        start = time.perf_counter()
        self.prepared = prepare(self.asset, self.options, progress=self.progress)
        self.convert_seconds = time.perf_counter() - start
        self.seconds.update(self.prepared.report.seconds)
        self.seconds["coacd_cpu"] = self.prepared.report.coacd.coacd_cpu_s

    @cached_property
    def compiled(self) -> Compiled:
        """The object's MJCF spec (visuals included) built from the conversion and compiled; any failure of either
        is the verdict."""
        from spark_bench.sim.mjcf import build_spec

        try:
            spec = build_spec(self.asset, prepared=self.prepared)
            start = time.perf_counter()
            model = spec.compile()
            compile_s = time.perf_counter() - start
        except Exception as exc:  # MuJoCo reports compiler errors as ValueError; any failure is the verdict
            return Compiled(None, None, error=" ".join(str(exc).split()))
        return Compiled(spec, model, compile_s)

    @cached_property
    def joints(self) -> list[SweptJoint]:
        return swept_joints(self.asset)

    @cached_property
    def size(self) -> float:
        return self.prepared.size


class ModelFileInputs(CheckInputs):
    """A converted ``model.xml`` (:func:`spark_bench.sim.convert`'s), checked as it is; PyBullet loads the
    ``model.urdf`` beside it.

    :param xml: the file
    :param spec: its ``mujoco.MjSpec``, read
    :param checks: the run's results so far
    """

    fails_unmet = False

    def __init__(self, xml: Path, spec, checks: dict[str, CheckResult]) -> None:
        super().__init__(checks)
        self.xml, self.spec = Path(xml), spec

    @classmethod
    def read(cls, xml: Path, checks: dict[str, CheckResult]) -> ModelFileInputs:
        """Read ``xml``.

        :raises InputError: when the file is missing or is not MJCF
        """
        from spark_bench.errors import InputError
        from spark_bench.mujoco_gl import mujoco_module

        xml = Path(xml)
        if not xml.is_file():
            raise InputError(xml, "no such model file")
        try:
            spec = mujoco_module().MjSpec.from_file(str(xml))
        except ValueError as exc:
            raise InputError(xml, f"not a readable MJCF file: {exc}") from None
        return cls(xml, spec, checks)

    @property
    def name(self) -> str:
        """The model's name, else its folder's."""
        return self.spec.modelname or self.xml.parent.name

    def unmet(self, need: str) -> str | None:
        if need == "source":
            return NO_SOURCE
        if need in ("conversion", "model") and self.model is None:  # its hulls and joints are its compiled model's
            return NOT_COMPILED
        return None

    @cached_property
    def compiled(self) -> Compiled:
        try:
            start = time.perf_counter()
            model = self.spec.compile()
        except ValueError as exc:
            return Compiled(self.spec, None, error=" ".join(str(exc).split()))
        return Compiled(self.spec, model, time.perf_counter() - start)

    @cached_property
    def joints(self) -> list[SweptJoint]:
        return swept_joints_of_model(self.model)

    @cached_property
    def size(self) -> float:
        """The diagonal of the model's bounds at rest (at least 1 mm)."""
        from spark_bench.mujoco_gl import mujoco_module
        from spark_bench.sim.bounds import model_bounds

        mujoco = mujoco_module()
        data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, data)
        lo, hi = model_bounds(self.model, data)
        return max(float(np.linalg.norm(hi - lo)), 1e-3)
