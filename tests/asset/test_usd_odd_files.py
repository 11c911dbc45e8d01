"""Every odd USD file answered (issue 43, item 3): a ``metersPerUnit`` (or ``kilogramsPerUnit``) that is not a
positive, finite number is refused naming the file and the value; a sublayer, reference or payload that cannot
be composed (missing, not a USD layer, a cycle, the file as its own sublayer) is named in a warning where the
articulation does not need what it held, and in the error where it does (today's reader dropped it silently).

The stages are written here as text: a door hinged on a carcass, each a rigid body with one box mesh.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from spark_bench.data.readers import load_object
from spark_bench.errors import InputError

pytest.importorskip("pxr")
from helpers_formats import refused  # noqa: E402

BOX = """        def Mesh "{name}"
        {{
            int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
            int[] faceVertexIndices = [0, 1, 3, 2, 2, 3, 7, 6, 6, 7, 5, 4, 4, 5, 1, 0, 2, 6, 4, 0, 7, 3, 1, 5]
            point3f[] points = [({x0}, {y0}, {z0}), ({x0}, {y0}, {z1}), ({x0}, {y1}, {z0}), ({x0}, {y1}, {z1}),
                                ({x1}, {y0}, {z0}), ({x1}, {y0}, {z1}), ({x1}, {y1}, {z0}), ({x1}, {y1}, {z1})]
        }}
"""


def box(name: str, low, high) -> str:
    return BOX.format(name=name, x0=low[0], y0=low[1], z0=low[2], x1=high[0], y1=high[1], z1=high[2])


def door_stage(header: str = "", carcass_arcs: str = "", extra: str = "", door_mesh_arcs: str = "") -> str:
    """A carcass and a door on a hinge; ``header`` goes into the layer's metadata, ``carcass_arcs`` into the
    carcass's, ``door_mesh_arcs`` into the door mesh's, ``extra`` at the end of ``/Cabinet``."""
    return f"""#usda 1.0
(
    defaultPrim = "Cabinet"
    metersPerUnit = 1
    upAxis = "Z"
    {header}
)

def Xform "Cabinet"
{{
    def Xform "carcass" (
        prepend apiSchemas = ["PhysicsRigidBodyAPI", "PhysicsArticulationRootAPI"]
        {carcass_arcs}
    )
    {{
{box("shell", (0.0, -0.3, 0.0), (0.4, 0.3, 0.8))}
    }}

    def Xform "door" (
        prepend apiSchemas = ["PhysicsRigidBodyAPI"]
    )
    {{
        def Mesh "panel" (
            {door_mesh_arcs}
        )
        {{
            int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
            int[] faceVertexIndices = [0, 1, 3, 2, 2, 3, 7, 6, 6, 7, 5, 4, 4, 5, 1, 0, 2, 6, 4, 0, 7, 3, 1, 5]
            point3f[] points = [(-0.02, -0.3, 0), (-0.02, -0.3, 0.8), (-0.02, 0.3, 0), (-0.02, 0.3, 0.8),
                                (0, -0.3, 0), (0, -0.3, 0.8), (0, 0.3, 0), (0, 0.3, 0.8)]
        }}
    }}

    def PhysicsFixedJoint "root_joint"
    {{
        rel physics:body1 = </Cabinet/carcass>
    }}

    def PhysicsRevoluteJoint "hinge"
    {{
        rel physics:body0 = </Cabinet/carcass>
        rel physics:body1 = </Cabinet/door>
        uniform token physics:axis = "Z"
        point3f physics:localPos0 = (0, -0.3, 0)
        point3f physics:localPos1 = (0, -0.3, 0)
        float physics:lowerLimit = 0
        float physics:upperLimit = 90
    }}
{extra}
}}
"""


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_the_plain_door_reads(tmp_path):
    asset = load_object(write(tmp_path / "door.usda", door_stage()))
    assert asset.joints["hinge"].upper == pytest.approx(1.5707963, abs=1e-6) and not asset.warnings


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf"])
def test_meters_per_unit_that_is_no_length_is_refused(tmp_path, value):
    path = write(tmp_path / "door.usda", door_stage().replace("metersPerUnit = 1", f"metersPerUnit = {value}"))
    refused(load_object, path, "metersPerUnit", "positive, finite", str(path))


def test_kilograms_per_unit_zero_is_refused(tmp_path):
    path = write(tmp_path / "door.usda", door_stage(header="kilogramsPerUnit = 0"))
    refused(load_object, path, "kilogramsPerUnit is 0.0", str(path))


@pytest.mark.parametrize("sublayer, why", [("missing.usda", "not found"), ("garbage.usda", "not a USD layer"),
                                           ("door.usda", "a cycle")])
def test_a_sublayer_that_cannot_be_composed_is_a_warning(tmp_path, sublayer, why):
    (tmp_path / "garbage.usda").write_text("this is not a USD layer\n")
    path = write(tmp_path / "door.usda", door_stage(header=f"subLayers = [@{sublayer}@]"))
    asset = load_object(path)
    assert asset.joints["hinge"].type == "revolute"
    assert len(asset.warnings) == 1 and asset.warnings[0].startswith("sublayer @") and why in asset.warnings[0]
    assert Path(sublayer).name in asset.warnings[0]


def test_a_sublayer_whose_content_is_needed_is_named_in_the_error(tmp_path):
    """The bodies live in a sublayer that is missing: no rigid body is left, and the error says why."""
    text = door_stage(header="subLayers = [@parts.usda@]").replace(
        'prepend apiSchemas = ["PhysicsRigidBodyAPI", "PhysicsArticulationRootAPI"]', "").replace(
        'prepend apiSchemas = ["PhysicsRigidBodyAPI"]', "")
    path = write(tmp_path / "door.usda", text)
    refused(load_object, path, "no rigid body", "sublayer @parts.usda@", "not found", str(path))


def test_a_reference_holding_a_bodys_geometry_is_an_error_naming_it(tmp_path):
    path = write(tmp_path / "door.usda", door_stage(door_mesh_arcs="prepend references = @panel.usda@</Panel>"))
    refused(load_object, path, "reference @panel.usda@", "/Cabinet/door/panel", "rigid body /Cabinet/door",
            str(path))


def test_a_payload_holding_a_body_a_joint_names_is_an_error(tmp_path):
    extra = '''    def Xform "lid" (prepend payload = @lid.usda@) {}
    def PhysicsRevoluteJoint "lid_hinge"
    {
        rel physics:body0 = </Cabinet/carcass>
        rel physics:body1 = </Cabinet/lid/body>
        uniform token physics:axis = "Y"
    }
'''
    path = write(tmp_path / "door.usda", door_stage(extra=extra))
    refused(load_object, path, "payload @lid.usda@", "/Cabinet/lid", "the body /Cabinet/lid/body", str(path))


def test_a_reference_outside_the_articulation_is_a_warning(tmp_path):
    extra = '    def Xform "room" (prepend references = @kitchen.usda@) {}\n'
    path = write(tmp_path / "door.usda", door_stage(extra=extra))
    asset = load_object(path)
    assert asset.warnings == [f"reference @kitchen.usda@ on prim /Cabinet/room (layer {path}): not found: what it "
                              "holds is not read"]


def test_a_reference_cycle_is_named(tmp_path):
    extra = '    def Xform "loop" (prepend references = </Cabinet>) {}\n'
    path = write(tmp_path / "door.usda", door_stage(extra=extra))
    asset = load_object(path)
    assert asset.warnings == [f"reference @{path}@ on prim /Cabinet/loop (layer {path}): a cycle (it leads back to "
                              "</Cabinet>): what it holds is not read"]


def test_nothing_dropped_silently_on_a_good_reference(tmp_path):
    (tmp_path / "panel.usda").write_text(f"""#usda 1.0
(
    defaultPrim = "Panel"
)
def Xform "Panel"
{{
{box("board", (-0.02, -0.3, 0.0), (0.0, 0.3, 0.8))}
}}
""")
    text = door_stage(door_mesh_arcs="").replace('        def Mesh "panel" (\n            \n        )',
                                                 '        def Xform "panel" (prepend references = @panel.usda@)')
    asset = load_object(write(tmp_path / "door.usda", text))
    assert not asset.warnings and asset.links["door"].has_geometry


def test_an_error_elsewhere_names_the_arcs_that_could_not_be_composed(tmp_path):
    """A stage refused for another reason (a D6 joint) while a sublayer is missing: the error says both."""
    extra = '''    def PhysicsJoint "d6"
    {
        rel physics:body0 = </Cabinet/carcass>
        rel physics:body1 = </Cabinet/door>
    }
'''
    path = write(tmp_path / "door.usda", door_stage(header="subLayers = [@physics.usda@]", extra=extra))
    with pytest.raises(InputError) as caught:
        load_object(path)
    message = str(caught.value)
    assert "D6" in message and "sublayer @physics.usda@" in message and "\n" not in message


def test_a_run_whose_sublayer_is_not_usd_imports_with_the_warning(tmp_path):
    """``import usd`` reads a run as ``check`` does: the sublayer that is not USD is a warning, not a refusal."""
    from spark_bench.formats.usd import read_run

    run = tmp_path / "run"
    run.mkdir()
    (run / "garbage.usda").write_text("this is not a USD layer\n")
    write(run / "door.usda", door_stage(header="subLayers = [@garbage.usda@]"))
    read = read_run(run)
    assert any("garbage.usda" in w and "not a USD layer" in w for w in read.asset.warnings)


def test_a_run_file_that_is_not_usd_is_refused_in_one_line(tmp_path):
    from spark_bench.formats.usd import read_run

    run = tmp_path / "run"
    run.mkdir()
    (run / "door.usda").write_text("this is not a USD layer\n")
    with pytest.raises(InputError) as error:
        read_run(run)
    assert str(run / "door.usda") in str(error.value) and "\n" not in str(error.value)
