"""A tiny benchmark written by the tests: procedural cabinets as cases in docs/formats.md's layout."""

from __future__ import annotations

import json
from pathlib import Path

from spark_bench.asset import normalize_asset, write_object_folder
from spark_bench.envs.cabinet import procedural_cabinet


def write_case(folder: Path, case_id: str, asset, category: str = "StorageFurniture") -> Path:
    """One case in the format of docs/formats.md (renders from the software renderer)."""
    from spark_bench.evaluation.render import default_camera, render_asset

    case_dir = folder / "cases" / case_id
    normalized, center, scale = normalize_asset(asset)
    normalized.category = category
    write_object_folder(normalized, case_dir / "gt")
    frames = normalized.joint_frames()
    joints = [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
               "axis": frames[j.name][1].tolist(), "origin": frames[j.name][0].tolist(), "lower": j.lower,
               "upper": j.upper, "label": normalized.links[j.child].label} for j in normalized.movable_joints()]
    case = {"id": case_id, "category": category, "source": "procedural", "links": list(normalized.links),
            "joints": joints, "normalization": {"center": center.tolist(), "scale": scale}, "image_size": 64,
            "view_seed": 0}
    (case_dir / "case.json").write_text(json.dumps(case))
    camera = default_camera(64)
    (case_dir / "camera.json").write_text(json.dumps(camera))
    render_asset(normalized, camera, size=64).save(case_dir / "input.png")
    render_asset(normalized, camera, normalized.open_configuration(), size=64).save(case_dir / "open.png")
    return case_dir


def make_tiny_bench(root: Path, n: int = 3, name: str = "tiny") -> Path:
    """A benchmark folder of ``n`` procedural cabinets (a drawer and a door each)."""
    folder = root / name
    ids = [f"cab{k}" for k in range(n)]
    for k, case_id in enumerate(ids):
        write_case(folder, case_id, procedural_cabinet(seed=k), "StorageFurniture" if k % 2 == 0 else "Table")
    (folder / "manifest.json").write_text(json.dumps({"name": name, "convention": "spark-bench-conv-1",
                                                      "cases": ids, "failed": {}, "created": 0}))
    return folder


def copy_object(source: Path, target: Path) -> Path:
    """Copy an object folder so that the copy stands on its own."""
    import shutil

    shutil.copytree(source, target)
    return target
