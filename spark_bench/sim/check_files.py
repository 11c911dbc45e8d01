"""The ``mesh_files`` check: every mesh file the URDF names can be loaded as written."""

from __future__ import annotations

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.sim.check_inputs import CheckInputs
from spark_bench.sim.converter import unloadable_mesh_files
from spark_bench.sim.results import CheckResult


def check_mesh_files(asset: ArticulatedAsset) -> CheckResult:
    """Every mesh file the URDF names can be loaded as written (:func:`unloadable_mesh_files`)."""
    bad = unloadable_mesh_files(asset)
    details = {"unloadable": bad} if bad else {}
    if bad:
        details["reason"] = (f"{asset.source or asset.name}: {len(bad)} mesh file(s) the URDF names cannot be "
                             f"loaded as written (MuJoCo's URDF importer fails on them): " + "; ".join(bad[:3])
                             + ("; ..." if len(bad) > 3 else ""))
    return CheckResult(not bad, float(len(bad)), details)


def mesh_files(inputs: CheckInputs) -> CheckResult:
    """The ``mesh_files`` check of a run (:func:`check_mesh_files` on its asset)."""
    return check_mesh_files(inputs.asset)
