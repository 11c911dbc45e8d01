"""spark_bench.sim geometry and physics: hulls, thickening, erosion, hull budget, CoACD cache, masses."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from helpers_boxes import l_shape, v_shape
from scipy.spatial import ConvexHull

from spark_bench.sim.decompose import DecomposeStats, decompose_many, load_cached, mesh_key
from spark_bench.sim.hulls import (
    concavity,
    convex_hull,
    erode_hull,
    merge_to_budget,
    thicken_points,
    vertex_components,
)
from spark_bench.sim.options import MATERIALS, CoacdParams, ConvertOptions, Material
from spark_bench.sim.physical import (
    inertia_is_valid,
    joint_dynamics,
    link_mass_properties,
    principal_inertia,
    shell_fraction,
)
from spark_bench.sim.shapes import CollisionShape


def test_thicken_flat_square_to_thickness():
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    thick = thicken_points(square, 0.01)
    assert np.ptp(thick[:, 2]) == pytest.approx(0.01)
    assert np.ptp(thick[:, 0]) == pytest.approx(1.0)
    # towards a point far above the plane: grows on that side only
    up = thicken_points(square, 0.01, toward=np.array([0.5, 0.5, 0.3]))
    assert up[:, 2].min() == pytest.approx(0.0) and up[:, 2].max() == pytest.approx(0.01)


def test_convex_hull_of_plane_has_volume():
    square = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]], dtype=float)
    vertices, faces = convex_hull(square, 0.02)
    mesh = trimesh.Trimesh(vertices, faces)
    assert mesh.is_watertight and mesh.is_convex
    assert mesh.volume == pytest.approx(2 * 1 * 0.02, rel=1e-6)


def test_convex_hull_vertex_budget():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    vertices, _ = convex_hull(sphere.vertices, 1e-3, max_vertices=32)
    assert len(vertices) <= 32
    assert ConvexHull(vertices).volume > 0.7 * sphere.volume


def test_erode_hull_is_exact_offset():
    cube = trimesh.creation.box(extents=(1.0, 0.5, 0.4))
    eroded = erode_hull(cube.vertices, 0.05)
    assert np.ptp(eroded, axis=0) == pytest.approx([0.9, 0.4, 0.3])
    # too thin to erode by that much: unchanged
    slab = trimesh.creation.box(extents=(1.0, 1.0, 0.01))
    assert np.allclose(erode_hull(slab.vertices, 0.01), slab.vertices)


def test_concavity_separates_convex_from_l_shape():
    box = trimesh.creation.box(extents=(0.2, 0.2, 0.05))
    v, f = convex_hull(box.vertices, 1e-4)
    assert concavity(box, v, f, spacing=0.005) < 0.01
    ell = l_shape()
    v, f = convex_hull(ell.vertices, 1e-4)
    assert concavity(ell, v, f, spacing=0.005) > 0.05  # the hull fills the inner corner


def test_vertex_components_keeps_two_sided_surfaces_together():
    disc = trimesh.creation.annulus(r_min=0.5, r_max=1.0, height=0.0, sections=16)
    two_sided = trimesh.Trimesh(np.concatenate([disc.vertices]), np.concatenate([disc.faces, disc.faces[:, ::-1]]),
                                process=False)
    two_sided.merge_vertices()
    assert len(vertex_components(two_sided)) == 1
    pair = trimesh.util.concatenate([trimesh.creation.box(), trimesh.creation.box(
        transform=trimesh.transformations.translation_matrix((3, 0, 0)))])
    assert len(vertex_components(pair)) == 2


def test_merge_to_budget_keeps_volume_close():
    shapes = []
    for k in range(10):
        box = trimesh.creation.box(extents=(0.1, 0.1, 0.1),
                                   transform=trimesh.transformations.translation_matrix((0.1 * k, 0, 0)))
        shapes.append(CollisionShape("mesh", "hull", vertices=box.vertices, faces=box.faces))
    merged = merge_to_budget(shapes, budget=3, thickness=1e-3, max_vertices=64)
    assert len(merged) == 3
    total = sum(ConvexHull(s.vertices).volume for s in merged)
    assert total == pytest.approx(10 * 0.001, rel=1e-6)  # a row of touching cubes merges without gaps


def test_box_mass_properties_match_formula():
    box = trimesh.creation.box(extents=(0.4, 0.2, 0.1))
    as_mesh = CollisionShape("mesh", "hull", vertices=box.vertices, faces=box.faces)
    as_box = CollisionShape("box", "primitive", size=np.array([0.4, 0.2, 0.1]))
    for shape in (as_mesh, as_box):
        props = link_mass_properties([shape], density=500.0)
        mass = 500.0 * 0.4 * 0.2 * 0.1
        assert props.mass == pytest.approx(mass)
        expected = mass / 12 * np.array([0.2 ** 2 + 0.1 ** 2, 0.4 ** 2 + 0.1 ** 2, 0.4 ** 2 + 0.2 ** 2])
        assert np.diag(props.inertia) == pytest.approx(expected, rel=1e-6)


def test_two_boxes_parallel_axis_and_triangle_inequality():
    a = CollisionShape("box", "primitive", origin=trimesh.transformations.translation_matrix((-1, 0, 0)),
                       size=np.array([0.1, 0.1, 0.1]))
    b = CollisionShape("box", "primitive", origin=trimesh.transformations.translation_matrix((1, 0, 0)),
                       size=np.array([0.1, 0.1, 0.1]))
    props = link_mass_properties([a, b], density=1000.0)
    assert props.com == pytest.approx([0, 0, 0])
    m_each = 1.0
    own = m_each / 12 * 0.02
    assert props.inertia[1, 1] == pytest.approx(2 * (own + m_each * 1.0))
    moments, axes = principal_inertia(props.inertia)
    assert inertia_is_valid(moments)
    assert np.linalg.det(axes) == pytest.approx(1.0)


def test_degenerate_inertia_is_made_valid():
    rod = np.diag([0.0, 1.0, 1.0])
    moments, _ = principal_inertia(rod)
    assert inertia_is_valid(moments) and moments.min() > 0


def test_helper_link_without_shapes_gets_small_positive_mass():
    props = link_mass_properties([], density=600.0)
    assert 0 < props.mass < 0.01
    assert inertia_is_valid(np.linalg.eigvalsh(props.inertia))


def test_joint_dynamics_scale_with_part_and_hold_gravity():
    light = joint_dynamics("slide", mass=0.05, inertia_axis=0, lever=0, size=0.1,
                           damping=1.0, armature=0.05, frictionloss=0.02)
    heavy = joint_dynamics("slide", mass=5.0, inertia_axis=0, lever=0, size=0.5,
                           damping=1.0, armature=0.05, frictionloss=0.02)
    assert heavy.damping / light.damping == pytest.approx(100.0)
    held = joint_dynamics("hinge", mass=5.0, inertia_axis=0.4, lever=0.3, size=0.6, damping=1.0,
                          armature=0.05, frictionloss=0.02, gravity_load=2.0)
    assert held.frictionloss == pytest.approx(3.0)  # 1.5 times the gravity pull
    urdf = joint_dynamics("hinge", mass=5.0, inertia_axis=0.4, lever=0.3, size=0.6, damping=1.0,
                          armature=0.05, frictionloss=0.02, urdf_damping=7.0)
    assert urdf.damping == 7.0


def test_material_by_category_moving_part_and_override():
    options = ConvertOptions()
    assert options.material_of("StorageFurniture", "link_0") == MATERIALS["wood"]
    assert options.material_of("Safe", "link_0").wall == pytest.approx(0.003)
    assert options.material_of("Unknown", "link_0") == MATERIALS["default"]
    assert options.material_of("Toilet", "link_0") == MATERIALS["ceramic"]
    assert options.material_of("Toilet", "link_1", moving=True) == MATERIALS["plastic"]  # seat and lid
    assert options.material_of("Storage Furniture", "link_1", moving=True) == MATERIALS["wood"]
    options = ConvertOptions(density=1000.0, link_density={"link_1": 50.0})
    assert options.material_of("StorageFurniture", "link_0") == Material(1000.0)  # solid, as given
    assert options.material_of("StorageFurniture", "link_1") == Material(50.0)


def _box_shape(size, center=(0.0, 0.0, 0.0)) -> CollisionShape:
    origin = np.eye(4)
    origin[:3, 3] = center
    return CollisionShape(kind="box", method="given", origin=origin, size=np.asarray(size, float))


def test_thin_walled_part_weighs_its_walls_and_a_panel_stays_solid():
    # a closed 55 x 40 x 20 cm suitcase half modelled solid: 2.5 mm of ABS over its 0.82 m^2 of surface
    solid = link_mass_properties([_box_shape((0.55, 0.40, 0.20))], 1050.0)
    shell = link_mass_properties([_box_shape((0.55, 0.40, 0.20))], 1050.0, wall=0.0025)
    area = 2 * (0.55 * 0.40 + 0.40 * 0.20 + 0.55 * 0.20)
    assert solid.mass == pytest.approx(1050.0 * 0.044)
    assert shell.mass == pytest.approx(1050.0 * area * 0.0025, rel=1e-6)  # 2.15 kg, not 46 kg
    assert shell.mass < 0.05 * solid.mass
    np.testing.assert_allclose(shell.inertia, solid.inertia * shell.mass / solid.mass, rtol=1e-9)
    # an 18 mm door panel is thinner than two walls of 18 mm: it stays solid
    panel = [_box_shape((0.60, 0.018, 0.70))]
    assert link_mass_properties(panel, 600.0, wall=0.018).mass == pytest.approx(600.0 * 0.6 * 0.018 * 0.7)
    # two hulls of one link: the walls are over their common outer surface (0.5 x 0.4 x 0.2), not each hull's
    halves = [_box_shape((0.5, 0.4, 0.1), (0, 0, 0.05)), _box_shape((0.5, 0.4, 0.1), (0, 0, -0.05))]
    two = link_mass_properties(halves, 1050.0, wall=0.003)
    assert two.mass == pytest.approx(1050.0 * 2 * (0.2 + 0.1 + 0.08) * 0.003, rel=1e-6)
    assert two.volume == pytest.approx(0.04)  # the solid model's volume is kept
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    assert shell_fraction(0.04, corners * [0.5, 0.4, 0.2], None) == 1.0
    assert shell_fraction(0.0, corners, 0.003) == 1.0
    assert shell_fraction(1.0, corners * [1, 1, 0], 0.003) == 1.0  # flat points: no shell


def test_mesh_key_is_translation_and_scale_invariant_and_parameter_sensitive():
    box = trimesh.creation.box()
    params = CoacdParams()
    key = mesh_key(box.vertices, box.faces, params)
    assert mesh_key(box.vertices + 3.0, box.faces, params) == key
    assert mesh_key(box.vertices * 2.0, box.faces, params) == key  # CoACD's hulls scale with the mesh
    assert mesh_key(box.vertices * [2.0, 1.0, 1.0], box.faces, params) != key  # another shape
    assert mesh_key(box.vertices, box.faces, CoacdParams(threshold=0.1)) != key


def test_coacd_decomposes_v_shape_and_caches(tmp_path):
    vee = v_shape()
    moved = vee.copy()
    moved.apply_translation((5.0, 0, 0))
    params = CoacdParams(mcts_iterations=20, mcts_nodes=8, resolution=500)
    stats = DecomposeStats()
    first = decompose_many([(vee.vertices, vee.faces), (moved.vertices, moved.faces)], params,
                           cache=tmp_path, workers=1, stats=stats)
    assert stats.calls == 1 and not stats.failed  # the moved copy is the same part: decomposed once
    assert len(first[0]) >= 2  # a V needs two hulls
    shift = np.mean(np.concatenate([v for v, _ in first[1]]), axis=0) - np.mean(
        np.concatenate([v for v, _ in first[0]]), axis=0)
    assert shift == pytest.approx([5.0, 0, 0], abs=1e-9)
    covered = sum(ConvexHull(v).volume for v, _ in first[0])
    assert covered == pytest.approx(vee.volume, rel=0.25)
    again = DecomposeStats()
    second = decompose_many([(vee.vertices, vee.faces)], params, cache=tmp_path, workers=1, stats=again)
    assert again.calls == 0 and again.cache_hits == 1
    assert all(np.allclose(a[0], b[0]) for a, b in zip(first[0], second[0]))


def test_torn_cache_entry_is_recomputed(tmp_path):
    vee = v_shape()
    params = CoacdParams(mcts_iterations=20, mcts_nodes=8, resolution=500)
    decompose_many([(vee.vertices, vee.faces)], params, cache=tmp_path, workers=1)
    (entry,) = tmp_path.rglob("*.npz")
    entry.write_bytes(entry.read_bytes()[: entry.stat().st_size // 2])  # a copy cut short
    stats = DecomposeStats()
    hulls = decompose_many([(vee.vertices, vee.faces)], params, cache=tmp_path, workers=1, stats=stats)
    assert stats.calls == 1 and stats.cache_hits == 0 and len(hulls[0]) >= 2
    assert load_cached(entry.stem, tmp_path) is not None  # overwritten with a whole entry


def test_coacd_crash_costs_only_its_mesh_and_says_why():
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    vee = v_shape()
    assert len(ball.faces) > len(vee.faces)  # the largest mesh runs first: the others come after it
    broken = (ball.vertices, ball.faces + 10 ** 9)  # faces far out of range: CoACD segfaults on it
    stats = DecomposeStats()
    hulls = decompose_many([(vee.vertices, vee.faces), broken, (vee.vertices + 1.0, vee.faces[:, ::-1])],
                           CoacdParams(mcts_iterations=20, mcts_nodes=8), workers=1, stats=stats)
    assert list(stats.failed) == [1]
    assert stats.failed[1].startswith("CoACD worker killed by SIG")  # SIGSEGV or SIGABRT
    assert len(hulls[0]) >= 2 and len(hulls[2]) >= 2  # the meshes after it in the batch still ran
    assert len(hulls[1]) == 1 and np.ptp(hulls[1][0][0], axis=0) == pytest.approx([0.2, 0.2, 0.2], rel=0.01)


def test_hung_coacd_call_is_killed_with_a_reason():
    vee = v_shape()
    stats = DecomposeStats()
    hulls = decompose_many([(vee.vertices, vee.faces)], CoacdParams(), workers=1, stats=stats, timeout=0.0)
    assert stats.failed == {0: "CoACD ran over 0 s (taken as hung; worker killed)"}
    assert len(hulls[0]) == 1  # its convex hull stands in
