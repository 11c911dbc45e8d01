"""Mesh files with no surface (#12 item 3): the loader refuses them in one place, naming the file and link.

An empty file, a file with no vertices and one with vertices but no faces are
:class:`~spark_bench.asset.urdf.EmptyMeshError`; a link whose every visual (collision) mesh is such a
file, or missing, is an :class:`~spark_bench.errors.InputError`; one such file among others of a link
with a surface is skipped and recorded (PartNet-Mobility keeps listing part files that had no faces).
"""

from __future__ import annotations

import json
import logging
import re
import struct

import pytest
from helpers_assets import object_with_door_meshes, tiny_cabinet
from helpers_edits import edit_text

from spark_bench.asset.urdf import EmptyMeshError, load_mesh_file, write_object_folder
from spark_bench.cli import main
from spark_bench.data import load_object
from spark_bench.errors import InputError

TRIANGLE_OBJ = b"v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n"


def glb(document: dict) -> bytes:
    """A binary glTF holding only ``document`` (no buffers)."""
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    chunk = struct.pack("<II", len(text), 0x4E4F534A) + text
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunk)) + chunk


def point_cloud_glb() -> bytes:
    import trimesh

    return trimesh.points.PointCloud([[0, 0, 0], [1, 0, 0], [0, 1, 0]]).export(file_type="glb")


#: file name -> (content, what the error says about it)
EMPTY_FILES = {
    "empty.obj": (b"", r"is empty \(0 bytes\)"),
    "empty.glb": (b"", r"is empty \(0 bytes\)"),
    "empty.stl": (b"", r"is empty \(0 bytes\)"),
    "comments.obj": (b"# exported with no geometry\nmtllib comments.mtl\n", "has no vertices"),
    "nofacets.stl": (b"solid x\nendsolid x\n", "has no vertices"),
    "nomeshes.glb": (glb({"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "scene": 0}),
                     "has no vertices"),
    "points.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "has 3 vertices but no faces"),
    "points.glb": (None, "has 3 vertices but no faces"),  # written by trimesh, see content()
}


def content(name: str) -> bytes:
    data = EMPTY_FILES[name][0]
    return point_cloud_glb() if data is None else data


@pytest.mark.parametrize("name", sorted(EMPTY_FILES))
def test_mesh_file_with_no_surface_is_refused_naming_the_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(content(name))
    with pytest.raises(EmptyMeshError, match=EMPTY_FILES[name][1]) as info:
        load_mesh_file(path)
    assert info.value.path == str(path) and isinstance(info.value, InputError)


@pytest.mark.parametrize("name", sorted(EMPTY_FILES))
def test_link_whose_only_visual_has_no_surface_is_an_input_error(tmp_path, name):
    object_with_door_meshes(tmp_path, {name: content(name)})
    with pytest.raises(InputError) as info:
        load_object(tmp_path)
    message = str(info.value)
    assert message.startswith(str((tmp_path / "mobility.urdf").resolve()))
    assert f"link 'door' has no visual mesh with a surface: mesh file 'textured_objs/{name}'" in message
    assert re.search(EMPTY_FILES[name][1], message)


def test_link_whose_every_visual_is_missing_or_empty_names_each_file(tmp_path):
    files = {"gone.obj": None, "empty.obj": b"", "points.obj": content("points.obj")}
    object_with_door_meshes(tmp_path, files)
    with pytest.raises(InputError, match="link 'door' has no visual mesh with a surface") as info:
        load_object(tmp_path)
    message = str(info.value)
    assert "mesh file 'textured_objs/gone.obj' not found" in message
    assert "mesh file 'textured_objs/empty.obj' is empty (0 bytes)" in message
    assert "mesh file 'textured_objs/points.obj' has 3 vertices but no faces" in message
    assert "\n" not in message


def test_one_empty_file_among_visuals_with_a_surface_is_skipped_and_recorded(tmp_path, caplog):
    object_with_door_meshes(tmp_path, {"gone.obj": None, "empty.obj": b"", "part.obj": TRIANGLE_OBJ},
                            collisions=True)
    with caplog.at_level(logging.WARNING, logger="spark_bench.asset.urdf"):
        asset = load_object(tmp_path)
    door = asset.links["door"]
    assert [v.source for v in door.visuals] == ["textured_objs/part.obj"]
    assert [c.source for c in door.collisions] == ["textured_objs/part.obj"]
    assert door.skipped_meshes == [
        "visual: mesh file 'textured_objs/gone.obj' not found",
        "visual: mesh file 'textured_objs/empty.obj' is empty (0 bytes)",
        "collision: mesh file 'textured_objs/gone.obj' not found",
        "collision: mesh file 'textured_objs/empty.obj' is empty (0 bytes)",
    ]
    assert sum("link 'door': skipped a" in r.getMessage() for r in caplog.records) == 4
    assert all(link.skipped_meshes == [] for name, link in asset.links.items() if name != "door")


def test_a_primitive_visual_is_a_surface_too(tmp_path):
    object_with_door_meshes(tmp_path, {"empty.obj": b""})
    urdf = tmp_path / "mobility.urdf"
    box = '<visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual>'
    edit_text(urdf, '<link name="door">', f'<link name="door">{box}', count=-1)
    asset = load_object(tmp_path)
    assert asset.links["door"].has_geometry and len(asset.links["door"].skipped_meshes) == 1


def test_link_whose_every_collision_mesh_is_empty_is_an_input_error(tmp_path):
    object_with_door_meshes(tmp_path, {"part.obj": TRIANGLE_OBJ})
    (tmp_path / "textured_objs" / "hull.obj").write_bytes(b"")
    urdf = tmp_path / "mobility.urdf"
    hull = '<collision><geometry><mesh filename="textured_objs/hull.obj"/></geometry></collision>'
    edit_text(urdf, '<link name="door">', f'<link name="door">{hull}', count=-1)
    with pytest.raises(InputError, match="link 'door' has no collision mesh with a surface: "
                                         r"mesh file 'textured_objs/hull.obj' is empty \(0 bytes\)"):
        load_object(tmp_path)


def test_structure_only_reading_does_not_open_meshes(tmp_path):
    object_with_door_meshes(tmp_path, {"empty.obj": b""})
    asset = load_object(tmp_path, load_meshes=False)
    assert asset.links["door"].visuals == [] and asset.links["door"].skipped_meshes == []


def test_a_broken_file_stays_an_error_even_among_good_ones(tmp_path):
    """Only files with no surface are skipped; a corrupt one is an input error wherever it is."""
    nan_obj = b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    object_with_door_meshes(tmp_path, {"bad.obj": nan_obj, "part.obj": TRIANGLE_OBJ})
    with pytest.raises(InputError, match="bad.obj: mesh has NaN"):
        load_object(tmp_path)


# ----- the metrics command (check, convert: tests/sim; data prepare: tests/data) -----------------
@pytest.mark.parametrize("side", ["--pred", "--gt"])
@pytest.mark.parametrize("name", ["empty.obj", "comments.obj", "points.obj", "nomeshes.glb"])
def test_metrics_command_refuses_an_object_with_an_empty_mesh(tmp_path, capsys, side, name):
    good = tmp_path / "good"
    write_object_folder(tiny_cabinet(), good)
    bad = object_with_door_meshes(tmp_path / "bad", {name: content(name)})
    args = {"--pred": good, "--gt": good, side: bad}
    code = main(["metrics", "--pred", str(args["--pred"]), "--gt", str(args["--gt"]), "--samples", "200",
                 "--match-samples", "100"])
    err = capsys.readouterr().err
    assert code == 2
    urdf = (bad / "mobility.urdf").resolve()
    assert err.startswith(f"spark-bench: error: {urdf}: link 'door' has no visual mesh")
    assert f"mesh file 'textured_objs/{name}'" in err and err.count("\n") == 1


def test_metrics_command_on_a_link_with_every_visual_missing(tmp_path, capsys):
    bad = object_with_door_meshes(tmp_path / "bad", {"gone.obj": None, "also_gone.obj": None})
    code = main(["metrics", "--pred", str(bad), "--gt", str(bad), "--samples", "200"])
    err = capsys.readouterr().err
    assert code == 2 and "link 'door' has no visual mesh with a surface" in err
    assert "'textured_objs/gone.obj' not found" in err and "'textured_objs/also_gone.obj' not found" in err
