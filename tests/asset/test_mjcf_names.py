"""An MJCF model's names reach every report (issue 43, item 2): a hinge named ``microwave`` is ``microwave`` in the
asset, in ``check``'s joint sweep, in the metrics' matching, in an exported folder; a body keeps its name; an
unnamed body, joint or geom is named after its place (``<body>:body<k>``, ``<body>:hinge<k>``, ``<body>:geom<k>``),
the same on every read.

The model is written here (nothing copied): a microwave like LIBERO's ``microwave.xml`` (a named hinge on a named
door body), plus an unnamed body holding an unnamed hinge and an unnamed geom.
"""

from __future__ import annotations

import numpy as np
import pytest

from spark_bench.asset.mjcf_names import safe
from spark_bench.asset.urdf import write_object_folder
from spark_bench.data.readers import load_object

MICROWAVE_XML = """<mujoco model="microwave">
  <compiler angle="radian"/>
  <worldbody>
    <body>
      <body name="object">
        <geom name="oven_shell" type="box" size="0.2 0.15 0.12" pos="0 0 0.12"/>
        <body name="microdoorroot" pos="0.2 -0.15 0.12">
          <joint name="microwave" type="hinge" axis="0 0 1" range="0 1.6" damping="0.1"/>
          <geom type="box" size="0.01 0.15 0.11" pos="0.01 0.15 0"/>
        </body>
        <body pos="-0.1 0.0 0.25">
          <joint type="hinge" axis="1 0 0" range="0 0.8"/>
          <geom type="box" size="0.05 0.05 0.01" pos="0 0.05 0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def microwave(tmp_path):
    path = tmp_path / "microwave.xml"
    path.write_text(MICROWAVE_XML)
    return path


def test_bodies_joints_and_geoms_keep_the_authors_names(microwave):
    asset = load_object(microwave)
    assert list(asset.links) == ["worldbody", "worldbody:body0", "object", "microdoorroot", "object:body1"]
    door = asset.joints["microwave"]
    assert (door.type, door.parent, door.child) == ("revolute", "object", "microdoorroot")
    assert door.damping == pytest.approx(0.1)
    lid = asset.joints["object:body1:hinge0"]  # the unnamed hinge of the unnamed body, by their places
    assert (lid.parent, lid.child, lid.upper) == ("object", "object:body1", pytest.approx(0.8))
    # the shell's name is kept as its collision's source; the door's unnamed geom is named by its body
    assert [c.source for c in asset.links["object"].collisions] == ["oven_shell"]
    assert asset.links["microdoorroot"].collisions[0].kind == "box"
    again = load_object(microwave)
    assert list(again.links) == list(asset.links) and list(again.joints) == list(asset.joints)  # stable


def test_the_names_reach_metrics_exports_and_check(microwave, tmp_path):
    from spark_bench.metrics.evaluate import compute_metrics
    from spark_bench.sim.checks import run_checks
    from spark_bench.sim.options import ConvertOptions

    asset = load_object(microwave)
    result = compute_metrics(asset, asset, n_samples=2_000, n_match_samples=1_000)
    assert sorted(m.gt_joint for m in result.matches) == ["microwave", "object:body1:hinge0"]
    assert sorted(m.pred_joint for m in result.matches) == ["microwave", "object:body1:hinge0"]
    folder = tmp_path / "exported"
    write_object_folder(asset, folder)
    back = load_object(folder)
    assert {"microwave", "object:body1:hinge0"} <= set(back.joints) and "microdoorroot" in back.links
    report = run_checks(asset, ConvertOptions(workers=1, use_cache=False))
    assert set(report.checks["joint_sweep"].details["joints"]) == {"microwave", "object:body1:hinge0"}


def test_a_name_with_white_space_or_a_slash_is_kept_readable(tmp_path):
    assert safe("left door/hinge  1") == "left_door_hinge_1"
    path = tmp_path / "cabinet.xml"
    path.write_text(MICROWAVE_XML.replace('name="microdoorroot"', 'name="micro door/root"')
                    .replace('name="microwave"', 'name="door hinge"'))
    asset = load_object(path)
    assert "micro_door_root" in asset.links and asset.joints["door_hinge"].child == "micro_door_root"


def test_a_made_up_name_never_takes_an_authors(tmp_path):
    """An author's body named as a made-up name would be: the unnamed body is numbered instead."""
    path = tmp_path / "clash.xml"
    path.write_text(MICROWAVE_XML.replace('<body name="object">', '<body name="worldbody:body0">'))
    asset = load_object(path)
    names = list(asset.links)
    assert len(names) == len(set(names)) and "worldbody:body0" in names and "worldbody:body0_2" in names
    assert np.isfinite(asset.bounds()).all()


def test_spark_benchs_own_model_xml_reads_back_with_the_names(microwave, tmp_path):
    """``convert --to mjcf`` names its bodies and joints as the asset's links and joints; read back, they are the
    same names (its root body is named ``worldbody``: MuJoCo's world body is then ``worldbody_2``)."""
    from spark_bench.sim.export import export
    from spark_bench.sim.options import ConvertOptions

    asset = load_object(microwave)
    back = load_object(export(asset, tmp_path / "out", "mjcf", ConvertOptions(workers=1)).model)
    assert back.root == "worldbody_2" and back.joints["worldbody:fixed"].child == "worldbody"
    assert set(asset.links) <= set(back.links) and {"microwave", "object:body1:hinge0"} <= set(back.joints)
    assert all(j.parent != j.child for j in back.joints.values())
