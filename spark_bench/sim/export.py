"""``convert --to mjcf|urdf|usd`` and ``check --export``: the asset as spark-bench checked it, in one folder
with relative paths.

Every format carries the same model (:func:`spark_bench.sim.mjcf.prepare`): the convex collision hulls
(CoACD through the cache), masses and inertias from the documented rule (:mod:`spark_bench.sim.physical`),
the joints' limits, damping, friction loss and armature, a fixed base.

- ``mjcf``: ``model.xml`` with ``meshes/`` (:func:`spark_bench.sim.convert`), and ``model.urdf`` beside
  it (the PyBullet URDF the ``pybullet_loads`` check loads);
- ``urdf``: the same, plus ``object.urdf`` (:mod:`.export_urdf`: fixed base, loads in PyBullet and MuJoCo);
- ``usd``: the same, plus ``object.usda`` (:mod:`.export_usd`: a UsdPhysics articulation, meshes inline).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.sim.options import ConvertOptions

FORMATS = ("mjcf", "urdf", "usd")


@dataclass
class Exported:
    """What an export wrote.

    :param model: the file of the format asked for
    :param mjcf: ``model.xml`` (always written)
    :param to: the format asked for
    """

    model: Path
    mjcf: Path
    to: str


def export(src: Path | str | ArticulatedAsset, out_dir: Path | str, to: str = "mjcf",
           options: ConvertOptions | None = None, progress: bool = False) -> Exported:
    """Write ``src`` as a sim-ready ``to`` model into ``out_dir`` (see the module docstring).

    :param src: object folder, model file or asset
    :param out_dir: output folder
    :param to: ``mjcf``, ``urdf`` or ``usd``
    :param options: conversion options
    :param progress: show CoACD progress
    :raises InputError: an unknown format, or what :func:`spark_bench.sim.convert` raises
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
    if to == "urdf":
        from spark_bench.sim.export_urdf import write_sim_urdf

        return Exported(write_sim_urdf(prepared, out_dir), xml, to)
    from spark_bench.sim.export_usd import SIM_USD, write_usd

    return Exported(write_usd(prepared, out_dir / SIM_USD), xml, to)
