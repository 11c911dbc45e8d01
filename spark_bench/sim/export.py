"""``convert --to mjcf|urdf|usd`` and ``check --export``: the asset as spark-bench checked it, in one folder
with relative paths.

Every format carries the same model (:func:`spark_bench.sim.mjcf.prepare`): the convex collision hulls
(CoACD through the cache), masses and inertias from the documented rule (:mod:`spark_bench.sim.physical`),
the joints' limits, damping, friction loss and armature, a fixed base.

- ``mjcf``: ``model.xml`` with ``meshes/`` (:func:`spark_bench.sim.convert`), and ``model.urdf`` beside
  it (the PyBullet URDF the ``pybullet_loads`` check loads);
- ``urdf``: the same, plus ``object.urdf`` (:mod:`.export_urdf`: fixed base, loads in PyBullet, MuJoCo and
  SAPIEN);
- ``usd``: the same, plus ``object.usda`` (:mod:`.export_usd`: a UsdPhysics articulation, meshes inline).

The URDF and the USD are for PhysX too (SAPIEN, ManiSkill3, Isaac): their hulls are within PhysX's cooking limits
(255 vertices, 255 polygons), a hull over them written as the pieces that cover it exactly
(:mod:`spark_bench.sim.physx.hulls`, which needs no SAPIEN), and ``conversion.json`` says so under ``"export"``
(:func:`export_record`). ``model.xml`` and ``model.urdf`` keep the hulls MuJoCo's checks judged.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.physx.hulls import MAX_POLYGONS, MAX_VERTICES, HullLimits, physx_shapes

FORMATS = ("mjcf", "urdf", "usd")
#: The key of ``conversion.json`` that records a URDF or USD export (:func:`export_record`).
EXPORT_KEY = "export"


@dataclass
class Exported:
    """What an export wrote.

    :param model: the file of the format asked for
    :param mjcf: ``model.xml`` (always written)
    :param to: the format asked for
    :param physx_hulls: what PhysX's hull limits did to the URDF's or USD's hulls (None for ``mjcf``)
    """

    model: Path
    mjcf: Path
    to: str
    physx_hulls: HullLimits | None = None


def export_record(model: Path, to: str, hulls: HullLimits) -> dict:
    """What ``conversion.json`` records of a URDF or USD export: the file, the format, and its hulls against
    PhysX's limits (``split_hulls``: how many hulls were over them and written as pieces; ``split``: which, per
    link; ``hulls``: the hulls written; the largest vertex and polygon counts of any).

    :param model: the file written
    :param to: ``urdf`` or ``usd``
    :param hulls: :func:`spark_bench.sim.physx.hulls.physx_shapes`' report
    """
    return {"to": to, "file": model.name,
            "physx_hulls": {**hulls.to_dict(), "split_hulls": hulls.n_split, "vertex_limit": MAX_VERTICES,
                            "polygon_limit": MAX_POLYGONS}}


def _record_export(out_dir: Path, record: dict) -> None:
    """Add ``record`` to the ``conversion.json`` that :func:`spark_bench.sim.convert` wrote into ``out_dir``."""
    from spark_bench.sim.converter import REPORT_JSON

    path = out_dir / REPORT_JSON
    report = json.loads(path.read_text())
    report[EXPORT_KEY] = record
    path.write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")


def export(src: Path | str | ArticulatedAsset, out_dir: Path | str, to: str = "mjcf",
           options: ConvertOptions | None = None, progress: bool = False) -> Exported:
    """Write ``src`` as a sim-ready ``to`` model into ``out_dir`` (see the module docstring).

    :param src: object folder, model file or asset
    :param out_dir: output folder
    :param to: ``mjcf``, ``urdf`` or ``usd``
    :param options: conversion options
    :param progress: show CoACD progress
    :raises InputError: an unknown format, what :func:`spark_bench.sim.convert` raises, or (``urdf``, ``usd``) a
        hull that cannot be split within PhysX's limits
    """
    from spark_bench.sim.converter import convert, load_source
    from spark_bench.sim.mjcf import prepare

    if to not in FORMATS:
        raise InputError(out_dir, f"unknown export format {to!r} (choose from {', '.join(FORMATS)})")
    options = options or ConvertOptions()
    asset = load_source(src)
    out_dir = Path(out_dir)
    xml = convert(asset, out_dir, options, progress=progress)
    if to == "mjcf":
        return Exported(xml, xml, to)
    # the same preparation again: its CoACD hulls and contact decisions come from the cache convert filled
    prepared = prepare(asset, options)
    try:
        pieces, hulls = physx_shapes(prepared.shapes)
    except ValueError as exc:  # a hull no eight splits bring within PhysX's limits
        raise InputError(asset.source or asset.name, f"cannot write hulls PhysX takes: {exc}") from None
    if to == "urdf":
        from spark_bench.sim.export_urdf import write_sim_urdf

        model = write_sim_urdf(prepared, out_dir, pieces=pieces)
    else:
        from spark_bench.sim.export_usd import SIM_USD, write_usd

        model = write_usd(prepared, out_dir / SIM_USD, pieces=pieces)
    _record_export(out_dir, export_record(model, to, hulls))
    return Exported(model, xml, to, hulls)
