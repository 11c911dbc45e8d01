"""``convert``: an object folder, URDF or asset -> ``model.xml`` + ``model.urdf`` + ``meshes/``.

``model.xml`` is the MJCF of :func:`spark_bench.sim.build_spec` with meshes as OBJ files under
``meshes/`` (relative paths, so the folder can be moved); ``model.urdf`` is the PyBullet URDF that
references the same hull files; ``conversion.json`` records the options, hull counts, CoACD work,
exclusions (with the phantom blockings of :mod:`.phantom`), hinge-relief cuts and timings.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError
from spark_bench.sim.options import ConvertOptions

MODEL_XML = "model.xml"
MODEL_URDF = "model.urdf"
MESH_DIR = "meshes"
REPORT_JSON = "conversion.json"


def load_source(src: Path | str | ArticulatedAsset) -> ArticulatedAsset:
    """The asset of ``src``: an :class:`ArticulatedAsset` as is, else an object folder or URDF."""
    if isinstance(src, ArticulatedAsset):
        return src
    from spark_bench.data import load_object

    return load_object(Path(src))


def unloadable_mesh_files(asset: ArticulatedAsset) -> list[str]:
    """The mesh files ``asset``'s URDF names that cannot be loaded as written, one line each (``link 'door':
    visual: mesh file 'textured_objs/a.obj' not found``): missing, not a file, empty, or without a surface.

    The loader skips such a file, with a warning, where its link has others (PartNet-Mobility's URDFs keep
    listing parts that were deleted; preparing ground truth and the metrics rely on that); MuJoCo's own URDF
    importer fails on it.

    :param asset: an asset read from a URDF (an asset built in memory has none)
    """
    return [f"link {name!r}: {problem}" for name, link in asset.links.items() for problem in link.skipped_meshes]


def convert(src: Path | str | ArticulatedAsset, out_dir: Path | str, options: ConvertOptions | None = None,
            progress: bool = False) -> Path:
    """Convert ``src`` and write ``model.xml``, ``model.urdf``, ``meshes/`` and ``conversion.json``
    into ``out_dir``; returns the path of ``model.xml``.

    :param src: object folder, URDF file, or asset
    :param out_dir: output folder (created; files of an earlier conversion are overwritten)
    :param options: conversion options
    :param progress: show CoACD progress
    :raises InputError: when ``src`` cannot be read, its URDF names a mesh file that is missing, not a file,
        empty or without a surface (:func:`unloadable_mesh_files`), or MuJoCo
        rejects the model
    """
    from spark_bench.sim.mjcf import build_spec, prepare
    from spark_bench.sim.pybullet_io import write_pybullet_urdf
    from spark_bench.sim.relief import summarize_relief
    from spark_bench.sim.rest_trim import summarize_trim

    start = time.perf_counter()
    asset = load_source(src)
    unloadable = unloadable_mesh_files(asset)
    if unloadable:  # MuJoCo's own importer fails on the URDF as written: no model of it is a model of it
        raise InputError(asset.source or asset.name, "the URDF names mesh files that cannot be loaded: "
                         + "; ".join(unloadable) + " (remove them from the URDF or restore the files)")
    loaded = time.perf_counter()
    options = options or ConvertOptions()
    prepared = prepare(asset, options, progress=progress)
    prepared_at = time.perf_counter()
    out_dir = Path(out_dir)
    mesh_dir = (out_dir / MESH_DIR).resolve()
    if mesh_dir.is_dir():  # stale meshes of an earlier conversion would be mixed in otherwise
        for old in mesh_dir.glob("*.obj"):
            old.unlink()
    spec = build_spec(asset, prepared=prepared, mesh_dir=mesh_dir)
    try:
        spec.compile()
    except ValueError as exc:
        raise InputError(asset.source or asset.name, f"MuJoCo rejects the converted model: {exc}") from None
    spec.meshdir = MESH_DIR  # relative in the file, so the folder can move
    spec.modelfiledir = str(out_dir.resolve())
    xml_path = out_dir / MODEL_XML
    xml_path.write_text(spec.to_xml())
    write_pybullet_urdf(prepared, out_dir, MODEL_URDF)
    done = time.perf_counter()
    report = {
        "object": asset.name, "source": asset.source,
        "hulls": prepared.report.hulls, "hull_methods": prepared.report.methods,
        "coacd": {"calls": prepared.report.coacd.calls, "cache_hits": prepared.report.coacd.cache_hits,
                  "cpu_seconds": round(prepared.report.coacd.coacd_cpu_s, 3),
                  "failed": len(prepared.report.coacd.failed), "failures": prepared.report.coacd_failures,
                  "boxed": len(prepared.report.coacd.boxed)},
        "cached_links": prepared.report.cached_links, "merged_hulls": prepared.report.merged,
        "excluded": {f"{a}|{b}": round(d, 6) for (a, b), d in prepared.excluded.items()},
        "relief": summarize_relief(prepared.relief),
        "rest_trim": summarize_trim(prepared.trim),
        "phantom_blocks": [b.to_dict() for b in prepared.phantom],
        "mass": {name: round(p.mass, 6) for name, p in prepared.mass.items()},
        "seconds": {"load": round(loaded - start, 3), "collision_and_physics": round(prepared_at - loaded, 3),
                    "write": round(done - prepared_at, 3), "total": round(done - start, 3)},
        "options": options.to_dict(),
    }
    (out_dir / REPORT_JSON).write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")
    return xml_path
