"""URDF round trip and the one-line errors for bad input (DESIGN.md "Errors")."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers_assets import tiny_cabinet
from helpers_edits import edit_text

from spark_bench.asset.urdf import write_object_folder
from spark_bench.data import load_object
from spark_bench.errors import InputError

CUBE_OBJ = """v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8
"""


def write_object(folder: Path, joints_xml: str, links=("base", "link_0", "link_1"), extra="") -> Path:
    (folder / "textured_objs").mkdir(parents=True, exist_ok=True)
    (folder / "textured_objs" / "cube.obj").write_text(CUBE_OBJ)
    link_xml = "".join(
        f'<link name="{name}"><visual><geometry><mesh filename="textured_objs/cube.obj"/></geometry></visual></link>'
        if name != "base" else '<link name="base"/>' for name in links)
    (folder / "mobility.urdf").write_text(f'<?xml version="1.0"?>{extra}<robot name="t">{link_xml}{joints_xml}</robot>')
    return folder / "mobility.urdf"


GOOD_JOINTS = (
    '<joint name="joint_1" type="fixed"><origin rpy="1.570796 0 -1.570796" xyz="0 0 0"/>'
    '<parent link="base"/><child link="link_1"/></joint>'
    '<joint name="joint_0" type="revolute"><origin xyz="0.5 0 0"/><axis xyz="0 1 0"/>'
    '<limit lower="0" upper="1.5"/><parent link="link_1"/><child link="link_0"/></joint>'
)


def test_round_trip_preserves_geometry_kinematics_and_semantics(tmp_path):
    asset = tiny_cabinet()
    asset.links["drawer"].semantic_joint = "slider"
    write_object_folder(asset, tmp_path / "obj")
    back = load_object(tmp_path / "obj")
    assert back.category == "StorageFurniture"
    assert list(back.joints) == list(asset.joints)
    assert back.links["drawer"].label == "drawer" and back.links["drawer"].semantic_joint == "slider"
    assert back.links["body"].collisions[0].kind == "box"
    # OBJ coordinates are written with 9 significant digits: ~1e-9 on these sub-metre vertices
    for q in (asset.rest_configuration(), asset.open_configuration(), {"joint_door": 0.7}):
        np.testing.assert_allclose(back.mesh(q).vertices, asset.mesh(q).vertices, atol=1e-7)
    assert back.links["body"].visuals[0].rgba == pytest.approx(asset.links["body"].visuals[0].rgba)


def test_missing_limits_and_continuous(tmp_path):
    joints = GOOD_JOINTS.replace('<limit lower="0" upper="1.5"/>', "")
    asset = load_object(write_object(tmp_path, joints))
    assert asset.joints["joint_0"].upper == pytest.approx(np.pi) and not asset.joints["joint_0"].has_limits
    joints = GOOD_JOINTS.replace('type="revolute"', 'type="continuous"')
    asset = load_object(write_object(tmp_path, joints))
    assert asset.joints["joint_0"].rest_value == 0.0 and asset.joints["joint_0"].open_value == pytest.approx(np.pi / 2)


def test_dynamics_and_limit_attributes_are_numbers_and_convert(tmp_path):
    joints = GOOD_JOINTS.replace('<limit lower="0" upper="1.5"/>', '<limit lower="0" upper="1.5" effort="30" '
                                 'velocity="2"/><dynamics damping="0.5" friction="0.25"/>')
    asset = load_object(write_object(tmp_path, joints))
    joint = asset.joints["joint_0"]
    assert (joint.damping, joint.friction, joint.effort, joint.velocity) == (0.5, 0.25, 30.0, 2.0)
    assert all(isinstance(v, float) for v in (joint.damping, joint.friction, joint.effort, joint.velocity))
    # the converter takes the URDF's own damping and friction for that joint
    from spark_bench.sim import build_spec

    model = build_spec(asset).compile()
    dof = model.jnt_dofadr[model.joint("joint_0").id]
    assert model.dof_damping[dof] == pytest.approx(0.5) and model.dof_frictionloss[dof] >= 0.25


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda j: j.replace("</joint><joint", "</joint oops><joint", 1), "malformed XML"),
        (lambda j: j.replace('xyz="0 1 0"', 'xyz="0 0 0"'), "zero or NaN axis"),
        (lambda j: j.replace('xyz="0 1 0"', 'xyz="nan 1 0"'), "zero or NaN axis"),
        (lambda j: j.replace('name="joint_0"', 'name="joint_1"'), "duplicate joint name"),
        (lambda j: j + '<joint name="joint_2" type="fixed"><parent link="link_0"/><child link="link_1"/></joint>',
         "two parent joints"),
        (lambda j: j.replace('<child link="link_0"/>', '<child link="link_9"/>'), "unknown link"),
        (lambda j: j.replace('upper="1.5"', 'upper="-1.5"'), "below lower"),
        (lambda j: j.replace('<limit lower="0" upper="1.5"/>', '<limit lower="0" upper="1.5"/>'
                             '<dynamics damping="stiff"/>'), "damping is not a number"),
        (lambda j: j.replace('<limit lower="0" upper="1.5"/>', '<limit lower="0" upper="1.5" effort="inf"/>'),
         "effort is not finite"),
    ],
)
def test_bad_joints_give_one_line_errors(tmp_path, mutate, message):
    urdf = write_object(tmp_path, mutate(GOOD_JOINTS))
    with pytest.raises(InputError, match=message) as info:
        load_object(tmp_path)
    text = str(info.value)
    assert "\n" not in text and str(urdf) in text


def test_cycle_is_reported(tmp_path):
    joints = (
        '<joint name="a" type="fixed"><parent link="link_0"/><child link="link_1"/></joint>'
        '<joint name="b" type="fixed"><parent link="link_1"/><child link="link_0"/></joint>'
    )
    write_object(tmp_path, joints)
    with pytest.raises(InputError, match="cycle|root link"):
        load_object(tmp_path)


def test_duplicate_link_name(tmp_path):
    write_object(tmp_path, GOOD_JOINTS, links=("base", "link_0", "link_1", "link_1"))
    with pytest.raises(InputError, match="duplicate link name 'link_1'"):
        load_object(tmp_path)


def test_missing_mesh_and_escaping_path(tmp_path):
    urdf = write_object(tmp_path, GOOD_JOINTS)
    edit_text(urdf, "cube.obj", "gone.obj")
    with pytest.raises(InputError, match="mesh file 'textured_objs/gone.obj' not found"):
        load_object(tmp_path)
    outside = tmp_path.parent / "outside.obj"
    outside.write_text(CUBE_OBJ)
    edit_text(urdf, "textured_objs/gone.obj", "../outside.obj", count=-1)
    with pytest.raises(InputError, match="escapes the object folder"):
        load_object(tmp_path)


def test_xml_entities_are_refused_without_expansion(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET")
    doctype = f'<!DOCTYPE robot [<!ENTITY xxe SYSTEM "file://{secret}">]>'
    urdf = write_object(tmp_path, GOOD_JOINTS.replace('name="joint_0"', 'name="&xxe;"'), extra=doctype)
    with pytest.raises(InputError, match="entities are not allowed") as info:
        load_object(urdf)
    assert "TOP-SECRET" not in str(info.value)


def test_broken_mesh_and_side_files(tmp_path):
    write_object(tmp_path, GOOD_JOINTS)
    (tmp_path / "meta.json").write_text("{not json")
    with pytest.raises(InputError, match="meta.json: malformed JSON"):
        load_object(tmp_path)
    (tmp_path / "meta.json").write_text(json.dumps({"model_cat": "Box"}))
    (tmp_path / "textured_objs" / "cube.obj").write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(InputError, match="NaN"):
        load_object(tmp_path)


def test_not_a_folder(tmp_path):
    with pytest.raises(InputError, match="no such object folder"):
        load_object(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="has no mobility.urdf"):
        load_object(tmp_path / "empty")


def test_obj_lines_are_the_text_of_plain_formatting_on_grid_and_scattered_vertices(tmp_path):
    """The table path (a remesh: few distinct coordinates) and the plain path (distinct coordinates) both
    write exactly ``%.9g`` / ``%d`` text, -0.0 included, and the file reads back to the same mesh."""
    import trimesh

    from spark_bench.asset.obj_text import face_lines, vertex_lines
    from spark_bench.asset.urdf import write_obj

    rng = np.random.default_rng(3)
    grid = np.round(rng.random((5000, 3)) * 40) / 40 * 0.8765 - 0.3   # ~41 values per axis: table path
    grid[0] = [-0.0, 0.0, 1e-12]
    scattered = rng.normal(size=(300, 3)) * 1e3                         # all distinct: plain path
    for vertices in (grid, scattered):
        faces = rng.integers(0, len(vertices), (2 * len(vertices), 3))
        assert vertex_lines(vertices) == (("v %.9g %.9g %.9g\n" * len(vertices))
                                          % tuple(vertices.ravel().tolist())).encode()
        assert face_lines(faces) == (("f %d %d %d\n" * len(faces)) % tuple((faces + 1).ravel().tolist())).encode()
        write_obj(tmp_path / "m.obj", trimesh.Trimesh(vertices, faces, process=False))
        back = trimesh.load(tmp_path / "m.obj", process=False, force="mesh")
        # the triangles' corners (a reader drops vertices no face uses)
        np.testing.assert_allclose(back.vertices[back.faces], vertices[faces], rtol=1e-8, atol=1e-12)
    assert vertex_lines(np.zeros((0, 3))) == b"" and face_lines(np.zeros((0, 3), int)) == b""
    with pytest.raises(ValueError, match="negative"):
        face_lines(np.array([[0, -1, 2]]))
