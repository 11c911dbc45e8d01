"""``spark-bench data prepare`` records an object with a mesh that has no surface as failed (#12 item 3).

The reason in the manifest names the URDF, the link and the mesh file; the other objects are prepared
and the exit code is 1 (some object failed), as for any failing object.
"""

from __future__ import annotations

from helpers_assets import object_with_door_meshes, tiny_cabinet

from spark_bench.asset.urdf import write_object_folder
from spark_bench.cli import main
from spark_bench.data.case import Benchmark

#: object id -> (the door's visual meshes: content, or None for a listed but absent file ; the reason's words)
DEFECTS = {
    "empty_file": ({"empty.obj": b""}, ["mesh file 'textured_objs/empty.obj' is empty (0 bytes)"]),
    "no_vertices": ({"none.obj": b"# nothing here\n"},
                    ["mesh file 'textured_objs/none.obj' has no vertices"]),
    "no_faces": ({"points.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
                 ["mesh file 'textured_objs/points.obj' has 3 vertices but no faces"]),
    "all_missing": ({"gone.obj": None, "empty.glb": b""},
                    ["mesh file 'textured_objs/gone.obj' not found",
                     "mesh file 'textured_objs/empty.glb' is empty (0 bytes)"]),
}


def test_prepare_records_each_object_with_no_surface_and_goes_on(tmp_path, capsys):
    src = tmp_path / "src"
    for object_id, (files, _) in DEFECTS.items():
        object_with_door_meshes(src / object_id, files)
    write_object_folder(tiny_cabinet(), src / "good")
    out = tmp_path / "bench"
    code = main(["data", "prepare", "--src", str(src), "--out", str(out), "--image-size", "64",
                 "--resolution", "16", "--no-progress"])
    printed = capsys.readouterr().out
    assert code == 1  # some objects failed
    manifest = Benchmark(out).manifest()
    assert manifest["cases"] == ["good"] and set(manifest["failed"]) == set(DEFECTS)
    for object_id, (_, problems) in DEFECTS.items():
        reason = manifest["failed"][object_id]
        urdf = (src / object_id / "mobility.urdf").resolve()
        assert reason.startswith(f"{urdf}: link 'door' has no visual mesh with a surface")
        assert all(problem in reason for problem in problems) and "\n" not in reason
        assert f"failed {object_id}: {reason}" in printed
