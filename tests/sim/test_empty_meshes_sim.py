"""``spark-bench check`` and ``convert`` refuse an object with a mesh that has no surface (#12 item 3).

The loader (tests/asset/test_empty_meshes.py) refuses it; here: exit code 2 and one line on stderr
naming the URDF, the link and the mesh file, before any conversion work.
"""

from __future__ import annotations

import pytest
from helpers_assets import object_with_door_meshes

from spark_bench.cli import main

#: the door's visual meshes -> (content or None for a listed but absent file) ; what stderr must say
DEFECTS = {
    "empty file": ({"empty.obj": b""}, ["mesh file 'textured_objs/empty.obj' is empty (0 bytes)"]),
    "no vertices": ({"none.stl": b"solid x\nendsolid x\n"},
                    ["mesh file 'textured_objs/none.stl' has no vertices"]),
    "no faces": ({"points.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
                 ["mesh file 'textured_objs/points.obj' has 3 vertices but no faces"]),
    "every visual missing or empty": ({"gone.obj": None, "empty.glb": b""},
                                      ["mesh file 'textured_objs/gone.obj' not found",
                                       "mesh file 'textured_objs/empty.glb' is empty (0 bytes)"]),
}


@pytest.mark.parametrize("command", ["check", "convert"])
@pytest.mark.parametrize("defect", sorted(DEFECTS))
def test_check_and_convert_refuse_a_link_with_no_surface(tmp_path, capsys, command, defect):
    files, problems = DEFECTS[defect]
    src = object_with_door_meshes(tmp_path / "object", files)
    args = [command, str(src), "--no-progress", "--no-cache"]
    if command == "convert":
        args += ["--out", str(tmp_path / "out")]
    code = main(args)
    captured = capsys.readouterr()
    assert code == 2
    assert captured.err.startswith(f"spark-bench: error: {(src / 'mobility.urdf').resolve()}: "
                                   "link 'door' has no visual mesh with a surface: ")
    assert all(problem in captured.err for problem in problems) and captured.err.count("\n") == 1
    assert captured.out == "" and not (tmp_path / "out" / "model.xml").exists()
