"""The sim checks in PhysX (SAPIEN 3 on the CPU, issue #44): a real object passes in both engines, its door turned the
wrong way fails in both (PhysX colliding the door with its body through a carrier link, and again by contact queries
where the articulation filters the pair), a hull over PhysX's 255 vertices is split into hulls PhysX takes as given,
and without SAPIEN ``--engine physx`` says in one line what to install.

SAPIEN is optional (``pip install -e ".[physx]"``): its tests skip without it; the real objects' skip without
``../shared/real_objects``.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
import trimesh
from helpers_assets import tiny_cabinet
from helpers_real import real_object_path

from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.shapes import CollisionShape

OPTIONS = ConvertOptions(workers=1)


def _sapien():
    from spark_bench.sim.physx import sapien_available

    if not sapien_available():
        pytest.skip('sapien is not installed (pip install -e ".[physx]")')


def _ellipsoid(centre, half_extents, subdivisions: int = 3) -> CollisionShape:
    """A convex hull with 642 vertices (subdivisions 3): over PhysX's 255."""
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    vertices = sphere.vertices * np.asarray(half_extents) + np.asarray(centre)
    return CollisionShape("mesh", "hull", vertices=vertices, faces=np.asarray(sphere.faces))


def test_a_hull_over_physx_limits_is_split_into_pieces_within_them_that_cover_it_exactly():
    from spark_bench.sim.physx.hulls import MAX_POLYGONS, MAX_VERTICES, hull_size, split_for_physx

    hull = _ellipsoid((0.1, -0.2, 0.3), (0.05, 0.14, 0.2))
    assert hull_size(hull)[0] > MAX_VERTICES
    pieces = split_for_physx(hull)
    assert len(pieces) >= 2
    for piece in pieces:
        vertices, polygons = hull_size(piece)
        assert vertices <= MAX_VERTICES and polygons <= MAX_POLYGONS
        assert np.all(trimesh.convex.convex_hull(hull.vertices).contains(piece.vertices * 0.999 + 0.001 *
                                                                          hull.vertices.mean(axis=0)))
    total = sum(piece.volume() for piece in pieces)
    assert total == pytest.approx(hull.volume(), rel=1e-6)  # the pieces tile the hull: no volume added or lost
    box = CollisionShape("box", "primitive", size=np.array([0.1, 0.2, 0.3]))
    assert split_for_physx(box) == [box]


def test_a_door_with_a_hull_over_255_vertices_loads_split_and_still_opens_in_physx(isolated_home):
    _sapien()
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.physx.build import build_object
    from spark_bench.sim.physx.engines import physx_report
    from spark_bench.sim.physx.hulls import MAX_VERTICES

    cabinet = tiny_cabinet()
    cabinet.warnings = ["@OmniPBR.mdl@ not found: a material's file, look only: not read"]
    shapes = prepare(cabinet, OPTIONS).shapes
    shapes["door"] = [_ellipsoid((-0.215, 0.14, 0.25), (0.008, 0.13, 0.19))]
    prepared = prepare(cabinet, OPTIONS, shapes=shapes)
    obj = build_object(prepared)
    report = physx_report(prepared)
    assert report.warnings == cabinet.warnings  # what reading left out, as the MuJoCo report says it
    loads = report.checks["physx_loads"]
    assert loads.passed, loads.details
    assert list(loads.details["split"]) == ["door"] and "split" in loads.details["note"]
    door_shapes = obj.links["door"].component.collision_shapes
    assert len(door_shapes) == loads.value - sum(len(v) for k, v in prepared.shapes.items() if k != "door")
    assert all(len(shape.get_vertices()) <= MAX_VERTICES for shape in door_shapes)
    assert obj.cooked_moved < 1e-3 * prepared.size  # PhysX cooked the pieces as they were given
    door = report.checks["joint_sweep"].details["joints"]["joint_door"]
    assert door["reached"] >= 0.9 and door["returned"] >= 0.9, door


def test_a_door_hung_from_a_carrier_link_collides_with_its_cabinet_where_a_direct_child_would_not(isolated_home):
    _sapien()
    from benchmarks.broken_twins import axis_reversed
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.physx.engines import physx_report

    cabinet = tiny_cabinet()  # door 0.21 m in front of its hinge, opening outwards about +z
    intact = physx_report(prepare(cabinet, OPTIONS))
    assert intact.passed, intact.failures()
    assert intact.checks["physx_loads"].details["carriers"] == ["joint_drawer", "joint_door"]
    reversed_door = prepare(axis_reversed(cabinet, "joint_door").asset, OPTIONS)
    for carriers, way in ((True, "contact"), (False, "query")):
        report = physx_report(reversed_door, carriers=carriers)
        door = report.checks["joint_sweep"].details["joints"]["joint_door"]
        assert door["verdict_by"] == way and door["reached"] < 0.6, (way, door)  # its far edge meets the body at 41 deg
        assert "door runs into body" in report.checks["joint_sweep"].details["reason"], way
        drawer = report.checks["joint_sweep"].details["joints"]["joint_drawer"]
        assert drawer["reached"] > 0.9 and drawer["returned"] > 0.9  # the drawer still slides out, queried or not


@pytest.mark.slow
@pytest.mark.real
def test_a_real_cabinet_passes_in_both_engines_and_its_reversed_door_fails_in_both(isolated_home):
    _sapien()
    from benchmarks.broken_twins import axis_reversed
    from spark_bench.data import load_object
    from spark_bench.sim.physx.engines import check_engines

    cabinet = load_object(real_object_path("45780"))  # StorageFurniture: two doors (link_0, link_1), body link_2
    intact = check_engines(cabinet, ("mujoco", "physx"), OPTIONS)
    assert intact.passed, {e: r.failures() for e, r in intact.reports.items()}
    physx_sweep = intact.reports["physx"].checks["joint_sweep"]
    assert physx_sweep.details["verdict_by"] == ["contact"]
    assert all(j["reached"] >= 0.9 for j in physx_sweep.details["joints"].values())
    assert intact.reports["physx"].checks["physx_loads"].details["carriers"] == ["joint_0", "joint_1"]

    twin = axis_reversed(cabinet, "joint_0")
    broken = check_engines(twin.asset, ("mujoco", "physx"), OPTIONS)
    for engine, report in broken.reports.items():
        sweep = report.checks["joint_sweep"]
        assert not sweep.passed and sweep.details["failed"] == ["joint_0"], (engine, sweep.details.get("reason"))
        assert sweep.details["joints"]["joint_0"]["reached"] < 0.5, engine  # it stops as it starts into the body
        assert "link_0 runs into link_2" in sweep.details["reason"], (engine, sweep.details["reason"])
    assert "PhysX contacts" in broken.reports["physx"].checks["joint_sweep"].details["reason"]
    assert not broken.passed


@pytest.mark.slow
@pytest.mark.real
def test_without_carrier_links_physx_filters_the_door_and_the_contact_queries_catch_it(isolated_home):
    _sapien()
    from benchmarks.broken_twins import axis_reversed
    from spark_bench.data import load_object
    from spark_bench.sim.mjcf import prepare
    from spark_bench.sim.physx.engines import physx_report

    cabinet = load_object(real_object_path("45780"))
    intact = physx_report(prepare(cabinet, OPTIONS), carriers=False)
    assert intact.passed, intact.failures()  # the queries see nothing on the intact doors' paths
    assert intact.checks["physx_loads"].details["filtered_pairs"] == ["base|link_0", "base|link_1"]  # link_2 welded to base
    broken = physx_report(prepare(axis_reversed(cabinet, "joint_0").asset, OPTIONS), carriers=False)
    sweep = broken.checks["joint_sweep"]
    door = sweep.details["joints"]["joint_0"]
    assert not sweep.passed and door["verdict_by"] == "query" and door["reached"] < 0.1, door
    assert door["returned"] > 0.9  # it swung through its body: only the queries stopped it
    assert "link_0 runs into link_2" in sweep.details["reason"] and "queries" in sweep.details["reason"]


def test_check_engine_all_shows_each_engines_verdict_per_check(isolated_home, tmp_path, capsys):
    _sapien()
    import json

    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.cli import main

    folder = write_object_folder(tiny_cabinet(), tmp_path / "cabinet")
    code = main(["check", str(folder), "--engine", "all", "--no-progress", "--workers", "1"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert code == 0
    assert lines[0].split() == ["check", "mujoco", "physx"]
    rows = {line.split()[0]: line.split()[1:] for line in lines[1:-1]}
    assert rows["joint_sweep"] == ["pass", "pass"] and rows["rest_penetration"] == ["pass", "pass"]
    assert rows["mjcf_compiles"] == ["pass", "-"] and rows["physx_loads"] == ["-", "pass"]
    assert lines[-1].endswith("passed (mujoco passed, physx passed)")
    main(["check", str(folder), "--engine", "physx", "--json", "--no-progress", "--workers", "1"])
    report = json.loads(capsys.readouterr().out)
    assert list(report["engines"]) == ["physx"] and report["passed"] is True
    sweep = report["engines"]["physx"]["checks"]["joint_sweep"]
    assert sweep["verdict_by"] == ["contact"] and sweep["joints"]["joint_door"]["reached"] >= 0.9


def test_without_sapien_engine_physx_exits_with_one_line_saying_what_to_install(monkeypatch, capsys, tmp_path):
    from spark_bench.cli import main

    monkeypatch.setitem(sys.modules, "sapien", None)  # import sapien raises ImportError
    code = main(["check", str(tmp_path / "absent"), "--engine", "physx", "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "pip install" in err[0] and "physx" in err[0] and "sapien" in err[0].lower()
