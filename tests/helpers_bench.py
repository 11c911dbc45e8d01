"""A tiny benchmark written by the tests: procedural cabinets as cases in docs/formats.md's layout, and
the eval options the tests run it with."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from spark_bench.asset import normalize_asset, write_object_folder
from spark_bench.data.case import Benchmark
from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.evaluation.runner import EvalOptions
from spark_bench.methods.base import CaseInput

#: Eval options of the tests: no sim stages, few samples (the numbers the tests check are exact or loose).
FAST = EvalOptions(sim=False, n_samples=5000)


def write_case(folder: Path, case_id: str, asset, category: str = "StorageFurniture") -> Path:
    """One case in the format of docs/formats.md (renders from the software renderer); the case record
    is written last, as ``data prepare`` does."""
    from spark_bench.evaluation.render import default_camera, render_asset

    case = Benchmark(folder).case(case_id)
    normalized, center, scale = normalize_asset(asset)
    normalized.category = category
    write_object_folder(normalized, case.gt_dir)
    frames = normalized.joint_frames()
    joints = [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
               "axis": frames[j.name][1].tolist(), "origin": frames[j.name][0].tolist(), "lower": j.lower,
               "upper": j.upper, "label": normalized.links[j.child].label} for j in normalized.movable_joints()]
    record = {"id": case_id, "category": category, "source": "procedural", "links": list(normalized.links),
              "joints": joints, "normalization": {"center": center.tolist(), "scale": scale}, "image_size": 64,
              "view_seed": 0}
    camera = default_camera(64)
    case.camera_path.write_text(json.dumps(camera))
    render_asset(normalized, camera, size=64).save(case.input_image)
    render_asset(normalized, camera, normalized.open_configuration(), size=64).save(case.open_image)
    case.write_record(record)
    return case.folder


def make_tiny_bench(root: Path, n: int = 3, name: str = "tiny") -> Path:
    """A benchmark folder of ``n`` procedural cabinets (a drawer and a door each)."""
    bench = Benchmark(root / name)
    ids = [f"cab{k}" for k in range(n)]
    for k, case_id in enumerate(ids):
        write_case(bench.folder, case_id, procedural_cabinet(seed=k), "StorageFurniture" if k % 2 == 0 else "Table")
    bench.write_manifest({"name": name, "convention": "spark-bench-conv-1", "cases": ids, "failed": {},
                          "created": 0})
    return bench.folder


def case_input(bench: Path, inputs: Iterable[str], case_id: str = "cab0") -> CaseInput:
    """What a method is given of one case of a benchmark: the case, with the inputs ``inputs`` allowed.

    :param bench: the benchmark folder
    :param inputs: the names of the inputs allowed (``image``, ``camera``, ``part_meshes`` ...)
    :param case_id: the case
    """
    return CaseInput(Benchmark(bench).case(case_id), frozenset(inputs))


def copy_object(source: Path, target: Path) -> Path:
    """Copy an object folder so that the copy stands on its own."""
    import shutil

    shutil.copytree(source, target)
    return target
