"""Exact box decomposition of orthogonal parts (spark_bench.sim.boxes) and its place before CoACD."""

import numpy as np
import pytest
import trimesh
from helpers_assets import open_cabinet
from helpers_boxes import l_shape, v_shape

from spark_bench.asset.mesh import signed_volume
from spark_bench.sim import run_checks
from spark_bench.sim.boxes import box_decomposition, merge_cells
from spark_bench.sim.decompose import DecomposeStats, decompose_many
from spark_bench.sim.options import CoacdParams, ConvertOptions

# cell centres of each face of a unit cell, and its two triangles, per (axis, side)
_QUAD = {(0, 0): [[0, 0, 0], [0, 0, 1], [0, 1, 1], [0, 1, 0]], (0, 1): [[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]],
         (1, 0): [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], (1, 1): [[0, 1, 0], [0, 1, 1], [1, 1, 1], [1, 1, 0]],
         (2, 0): [[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]], (2, 1): [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]}


def surface_of_cells(inside: np.ndarray, spacing=(1.0, 1.0, 1.0)) -> trimesh.Trimesh:
    """The closed outer surface of the inside cells of a grid: two triangles per cell face between an
    inside cell and an outside one (what a voxel part's mesh is, vertices welded)."""
    quads = []
    padded = np.pad(inside, 1)
    for (axis, side), corners in _QUAD.items():
        step = np.zeros(3, int)
        step[axis] = 1 if side else -1
        for cell in np.argwhere(inside):
            if not padded[tuple(cell + 1 + step)]:
                quads.append(cell + np.array(corners))
    quads = np.array(quads, float) * spacing
    vertices, inverse = np.unique(quads.reshape(-1, 3), axis=0, return_inverse=True)
    quad_index = inverse.reshape(-1, 4)
    faces = np.concatenate([quad_index[:, [0, 1, 2]], quad_index[:, [0, 2, 3]]])
    return trimesh.Trimesh(vertices, faces, process=False)


def _raster(boxes, spacing, shape) -> np.ndarray:
    """How many boxes cover each grid cell."""
    count = np.zeros(shape, int)
    for corners, _ in boxes:
        lo = np.rint(corners.min(0) / spacing).astype(int)
        hi = np.rint(corners.max(0) / spacing).astype(int)
        count[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] += 1
    return count


def test_an_open_drawer_is_cut_into_boxes_that_tile_it_exactly():
    inside = np.zeros((6, 8, 4), bool)  # a drawer: a bottom and four walls, open at the top
    inside[:, :, 0] = True
    inside[[0, -1], :, :] = True
    inside[:, [0, -1], :] = True
    spacing = np.array([0.05, 0.04, 0.03])
    drawer = surface_of_cells(inside, spacing)
    boxes = box_decomposition(drawer.vertices, drawer.faces)
    assert boxes is not None
    assert np.array_equal(_raster(boxes, spacing, inside.shape), inside.astype(int))  # each cell once
    assert sum(np.prod(np.ptp(c, axis=0)) for c, _ in boxes) == pytest.approx(abs(signed_volume(drawer)))
    assert len(boxes) <= 5  # the bottom and four walls
    for corners, faces in boxes:  # each box a closed, outward surface
        assert signed_volume(trimesh.Trimesh(corners, faces, process=False)) == pytest.approx(np.prod(np.ptp(corners, axis=0)))


def test_a_boolean_union_with_t_junctions_is_cut_exactly():
    ell = l_shape()  # the union's faces meet other faces' edges midway (not a manifold triangulation)
    boxes = box_decomposition(ell.vertices, ell.faces)
    assert boxes is not None and len(boxes) == 2
    assert sum(np.prod(np.ptp(c, axis=0)) for c, _ in boxes) == pytest.approx(ell.volume, rel=1e-9)


def test_parts_that_are_not_orthogonal_or_not_closed_are_left_to_coacd():
    assert box_decomposition(v_shape().vertices, v_shape().faces) is None  # slanted faces
    assert box_decomposition(*_arrays(trimesh.creation.icosphere(subdivisions=1))) is None
    ell = l_shape()
    assert box_decomposition(ell.vertices, ell.faces[:-1]) is None  # a hole: not the surface of a solid
    touching = trimesh.util.concatenate([trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]]),
                                         trimesh.creation.box(bounds=[[1, 0, 0], [2, 1, 1]])])
    assert box_decomposition(touching.vertices, touching.faces) is None  # two faces inside the solid
    assert box_decomposition(np.zeros((0, 3)), np.zeros((0, 3), int)) is None
    assert box_decomposition(ell.vertices, ell.faces + len(ell.vertices)) is None  # indices out of range


def test_a_grid_too_fine_is_left_to_coacd():
    inside = np.zeros((10, 10, 10), bool)
    inside[::2, ::2, :] = True
    mesh = surface_of_cells(inside)
    assert box_decomposition(mesh.vertices, mesh.faces, max_cells=100) is None
    assert box_decomposition(mesh.vertices, mesh.faces) is not None


def test_merge_cells_covers_each_inside_cell_once():
    rng = np.random.default_rng(3)
    inside = rng.random((5, 6, 7)) < 0.6
    count = np.zeros(inside.shape, int)
    for lo, hi in merge_cells(inside):
        count[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] += 1
    assert np.array_equal(count, inside.astype(int))


def test_decompose_many_cuts_orthogonal_parts_without_coacd(tmp_path):
    ell = l_shape()
    turned = trimesh.transformations.rotation_matrix(np.radians(20.0), (0.3, 0.2, 1.0))
    moved = trimesh.Trimesh(trimesh.transform_points(ell.vertices * 3.0, turned), ell.faces, process=False)
    stats = DecomposeStats()
    hulls = decompose_many([(ell.vertices, ell.faces), (moved.vertices, moved.faces)], CoacdParams(),
                           cache=tmp_path, workers=1, stats=stats)
    assert stats.boxed == [0, 1] and stats.calls == 0 and stats.cache_hits == 0
    assert not list(tmp_path.rglob("*.npz"))  # nothing to cache
    assert len(hulls[0]) == len(hulls[1]) == 2
    # the turned copy is cut in its own planes' frame and placed back: the same boxes, turned and scaled
    expected = sorted(np.round(trimesh.transform_points(v * 3.0, turned), 9).tolist() for v, _ in hulls[0])
    found = sorted(np.round(v, 9).tolist() for v, _ in hulls[1])
    np.testing.assert_allclose(np.array(sorted(map(sorted, found))), np.array(sorted(map(sorted, expected))),
                               atol=1e-8)


def _arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_without_exact_boxes_an_orthogonal_part_goes_to_coacd():
    ell = l_shape()
    stats = DecomposeStats()
    hulls = decompose_many([(ell.vertices, ell.faces)], CoacdParams(mcts_iterations=20, mcts_nodes=8), workers=1,
                           stats=stats, exact_boxes=False)
    assert stats.boxed == [] and stats.calls == 1 and len(hulls[0]) >= 2


def test_a_boxed_body_collides_with_its_door_and_blocks_a_door_hinged_the_wrong_way():
    # conv-8: the exact boxes leave the door and the body apart at rest, so their contacts stay on (on
    # synth-v1's predictions CoACD's hulls overlapped 25 such pairs, which were then excluded from contact)
    right = run_checks(open_cabinet(), options=ConvertOptions(use_cache=False))
    compiled = right.checks["mjcf_compiles"].details
    assert compiled["boxed"] == 1 and compiled["hull_methods"].get("boxes", 0) >= 5
    assert compiled["excluded"] == [] and right.checks["joint_sweep"].passed  # it opens outwards, freely
    wrong = run_checks(open_cabinet(door_axis=(0.0, 0.0, -1.0)), options=ConvertOptions(use_cache=False))
    assert wrong.checks["mjcf_compiles"].details["excluded"] == []
    sweep = wrong.checks["joint_sweep"]
    assert not sweep.passed and sweep.details["joints"]["door_joint"]["reached"] < 0.5  # into the body
    assert sweep.details["joints"]["door_joint"]["stopped_by"]["cause"] == "contact"
