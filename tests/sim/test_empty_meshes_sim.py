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


#: A door panel with a surface (a box, so the door keeps a body to simulate).
BOX_OBJ = (b"v 0 0 0\nv 0.02 0 0\nv 0.02 0.3 0\nv 0 0.3 0\nv 0 0 0.4\nv 0.02 0 0.4\nv 0.02 0.3 0.4\nv 0 0.3 0.4\n"
           b"f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\n"
           b"f 4 5 8\n")
#: one faulty visual among the door's (the other has a surface): its file -> what the reason must say
ONE_OF_SEVERAL = {
    "missing": ("gone.obj", "mesh file 'textured_objs/gone.obj' not found"),
    "empty": ("empty.obj", "mesh file 'textured_objs/empty.obj' is empty (0 bytes)"),
    "directory": ("folder.obj", "mesh file 'textured_objs/folder.obj' is a directory, not a file"),
    "no faces": ("points.obj", "mesh file 'textured_objs/points.obj' has 3 vertices but no faces"),
}


def door_with_one_faulty_visual(folder, defect: str):
    name, _ = ONE_OF_SEVERAL[defect]
    content = {"missing": None, "empty": b"", "directory": None, "no faces": b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"}[defect]
    src = object_with_door_meshes(folder, {"panel.obj": BOX_OBJ, name: content})
    if defect == "directory":
        (src / "textured_objs" / name).mkdir()
    return src


@pytest.mark.parametrize("defect", sorted(ONE_OF_SEVERAL))
def test_check_fails_a_urdf_naming_an_unloadable_mesh_among_good_ones(tmp_path, capsys, defect):
    """The loader skips the faulty file (its link has another); MuJoCo's URDF importer would not: ``check``
    fails the ``mesh_files`` check naming the file, runs nothing on a model of another object, and
    ``convert`` refuses it."""
    import json

    src = door_with_one_faulty_visual(tmp_path / "object", defect)
    code = main(["check", str(src), "--json", "--no-progress", "--no-cache"])
    report = json.loads(capsys.readouterr().out)
    assert code == 1 and report["passed"] is False
    files = report["checks"]["mesh_files"]
    assert files["passed"] is False and files["value"] == 1
    assert ONE_OF_SEVERAL[defect][1] in files["reason"] and "link 'door'" in files["reason"]
    assert str((src / "mobility.urdf").resolve()) in files["reason"]
    others = {k: v for k, v in report["checks"].items() if k != "mesh_files"}
    assert len(others) == 6 and all(not v["passed"] and "not converted" in v["reason"] for v in others.values())

    code = main(["convert", str(src), "--out", str(tmp_path / "out"), "--no-progress", "--no-cache"])
    err = capsys.readouterr().err
    assert code == 2 and ONE_OF_SEVERAL[defect][1] in err and err.count("\n") == 1
    assert not (tmp_path / "out" / "model.xml").exists()


def test_the_same_object_is_prepared_and_measured_with_the_file_skipped(tmp_path, capsys):
    """Preparing ground truth and the metrics keep skipping a PartNet-Mobility deleted part, with a warning."""
    import json

    src = door_with_one_faulty_visual(tmp_path / "src" / "obj", "missing")
    assert main(["metrics", "--pred", str(src), "--gt", str(src), "--json", "--samples", "2000",
                 "--match-samples", "500"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["axis_err"] == 0.0 and result["type_err"] == 0.0
    out = tmp_path / "bench"
    assert main(["data", "prepare", "--src", str(tmp_path / "src"), "--out", str(out), "--image-size", "64",
                 "--resolution", "16", "--no-progress"]) == 0
    assert (out / "cases" / "obj" / "gt" / "mobility.urdf").is_file()


def test_a_good_object_passes_the_mesh_files_check(tmp_path):
    from helpers_assets import tiny_cabinet  # noqa: I001

    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.sim.checks import check_mesh_files
    from spark_bench.sim.converter import load_source

    write_object_folder(tiny_cabinet(), tmp_path / "good")
    result = check_mesh_files(load_source(tmp_path / "good"))
    assert result.passed and result.value == 0 and "reason" not in result.details
