"""Unit tests of the metric building blocks on hand-computed cases: shape scores, axis and pivot
errors, type agreement, Hungarian matching, alignment, aggregation."""

from __future__ import annotations

import numpy as np
import pytest

from spark_bench.metrics.align import Alignment, align_points, rigid_fit, rotation_z
from spark_bench.metrics.articulation import (
    JointAxis,
    axis_error,
    compare_joints,
    line_distance,
    point_line_distance,
    same_type,
)
from spark_bench.metrics.matching import match_parts, part_cost_matrix
from spark_bench.metrics.report import mean_over_objects
from spark_bench.metrics.sampling import sample_triangles, triangle_areas
from spark_bench.metrics.shape import (
    build_tree,
    fscore,
    mutual_nearest_distances,
    nearest_distances,
    query_nearest,
    scores_from_distances,
    shape_scores,
)


def grid_plane(spacing: float = 0.1, size: int = 11, z: float = 0.0) -> np.ndarray:
    xs = np.arange(size) * spacing
    x, y = np.meshgrid(xs, xs)
    return np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1)


def square(z: float = 0.0, half: float = 1.0) -> np.ndarray:
    """A flat square [-half, half]^2 at height z as two triangles."""
    a, b, c, d = [(-half, -half, z), (half, -half, z), (half, half, z), (-half, half, z)]
    return np.array([[a, b, c], [a, c, d]], dtype=float)


# ----- shape ---------------------------------------------------------------------------------------
def test_shape_scores_of_grids_a_known_distance_apart():
    # every point's nearest neighbour is its own copy 0.03 above: 0.03 < half the 0.1 spacing
    gt = grid_plane()
    pred = gt + [0.0, 0.0, 0.03]
    scores = shape_scores(pred, gt, thresholds=(0.01, 0.1))
    assert scores.cd == pytest.approx(0.06, abs=1e-12)
    assert scores.fscore[0.1] == 1.0
    assert scores.fscore[0.01] == 0.0  # P = R = 0: defined as 0, not a division by zero
    assert scores.n_points == (121, 121)


def test_fscore_precision_recall_by_hand():
    d_pg = np.array([0.05, 0.05, 0.3, 0.3])  # P@0.1 = 0.5
    d_gp = np.array([0.05, 0.3, 0.3, 0.3])  # R@0.1 = 0.25
    scores = scores_from_distances(d_pg, d_gp, thresholds=(0.1, 0.5))
    assert scores.cd == pytest.approx(0.175 + 0.2375)
    assert scores.precision[0.1] == 0.5 and scores.recall[0.1] == 0.25
    assert scores.fscore[0.1] == pytest.approx(2 * 0.5 * 0.25 / 0.75)
    assert scores.fscore[0.5] == 1.0
    assert fscore(0.0, 0.0) == 0.0


def test_one_sided_distances_use_the_right_direction():
    gt = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    pred = np.array([[0.0, 0, 0]])  # covers only half of the ground truth
    d_pg, d_gp = mutual_nearest_distances(pred, gt)
    np.testing.assert_allclose(d_pg, [0.0])
    np.testing.assert_allclose(d_gp, [0.0, 1.0])
    scores = shape_scores(pred, gt, thresholds=(0.5,))
    assert scores.precision[0.5] == 1.0 and scores.recall[0.5] == 0.5
    assert scores.cd == pytest.approx(0.5)


def test_two_squares_a_known_distance_apart():
    # dense samples on parallel squares 0.2 apart: nearest distances tend to 0.2 from above
    a = sample_triangles(square(0.0), 20_000, seed=1)
    b = sample_triangles(square(0.2), 20_000, seed=2)
    scores = shape_scores(a, b)
    assert scores.cd == pytest.approx(0.4, abs=2e-3)
    assert scores.fscore[0.1] == 0.0 and scores.fscore[0.5] == 1.0


def test_matches_scikit_learn_partcrafter_formula():
    neighbors = pytest.importorskip("sklearn.neighbors")
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(25_000, 3)), rng.normal(size=(21_000, 3)) * 1.1 + 0.05
    a[:200] *= 5.0  # far outliers: long searches through many leaves
    d_pg, d_gp = mutual_nearest_distances(a, b)
    ref_pg = neighbors.NearestNeighbors(n_neighbors=1, algorithm="kd_tree").fit(b).kneighbors(a)[0][:, 0]
    ref_gp = neighbors.NearestNeighbors(n_neighbors=1, algorithm="kd_tree").fit(a).kneighbors(b)[0][:, 0]
    np.testing.assert_allclose(d_pg, ref_pg, atol=1e-12)
    np.testing.assert_allclose(d_gp, ref_gp, atol=1e-12)


def test_nearest_query_indices_and_one_thread_agree_with_brute_force():
    rng = np.random.default_rng(4)
    reference, query = rng.uniform(-1, 1, size=(500, 3)), rng.uniform(-2, 2, size=(300, 3))
    brute = np.linalg.norm(query[:, None] - reference[None], axis=2)
    for workers in (-1, 1):
        distances, indices = query_nearest(build_tree(reference), query, workers)
        np.testing.assert_allclose(distances, brute.min(axis=1), atol=1e-12)
        np.testing.assert_array_equal(indices, brute.argmin(axis=1))
        assert indices.dtype == np.intp
    # a strided float32 view is converted, not misread
    strided = np.asfortranarray(query.astype(np.float32))
    np.testing.assert_allclose(nearest_distances(strided, reference), brute.min(axis=1), atol=1e-6)


# ----- sampling ------------------------------------------------------------------------------------
def test_sampler_is_seeded_uniform_and_on_the_surface():
    tris = np.concatenate([square(0.0, half=1.0), square(1.0, half=0.5)])  # areas 4 and 1
    a = sample_triangles(tris, 50_000, seed=3)
    np.testing.assert_array_equal(a, sample_triangles(tris, 50_000, seed=3))
    assert not np.array_equal(a, sample_triangles(tris, 50_000, seed=4))
    on_small = np.isclose(a[:, 2], 1.0)
    assert np.all(on_small | np.isclose(a[:, 2], 0.0))
    assert on_small.mean() == pytest.approx(0.2, abs=0.01)  # area-weighted
    assert np.all(np.abs(a[on_small, :2]) <= 0.5 + 1e-12)
    # uniform inside a face: each quadrant of the big square holds a quarter
    big = a[~on_small]
    assert ((big[:, 0] > 0) & (big[:, 1] > 0)).mean() == pytest.approx(0.25, abs=0.01)
    assert triangle_areas(square(0.0)).sum() == pytest.approx(4.0)


def test_sampler_is_continuous_in_the_geometry():
    # the same seed on a surface moved by rounding-sized amounts gives the same points up to rounding:
    # a nearly perfect prediction scores nearly zero, not sampling noise
    rng = np.random.default_rng(5)
    tris = rng.normal(size=(300, 3, 3))
    a = sample_triangles(tris, 20_000, seed=0)
    b = sample_triangles(tris * (1 + 1e-13) + 1e-13, 20_000, seed=0)
    assert np.abs(a - b).max() < 1e-9


def test_sampler_rejects_empty_and_flat():
    with pytest.raises(ValueError, match="empty"):
        sample_triangles(np.zeros((0, 3, 3)), 10)
    with pytest.raises(ValueError, match="zero"):
        sample_triangles(np.zeros((2, 3, 3)), 10)


# ----- articulation --------------------------------------------------------------------------------
@pytest.mark.parametrize("angle", [0.0, 0.1, 0.7, np.pi / 2 - 1e-9, np.pi / 2])
def test_axis_error_is_the_angle_sign_free(angle):
    a = np.array([0.0, 0.0, 1.0])
    b = np.array([0.0, np.sin(angle), np.cos(angle)])
    assert axis_error(a, b) == pytest.approx(angle, abs=1e-12)
    assert axis_error(a, -b) == pytest.approx(angle, abs=1e-12)
    assert axis_error(3 * a, 0.5 * b) == pytest.approx(angle, abs=1e-12)


def test_axis_error_obtuse_folds_to_acute():
    assert axis_error([1, 0, 0], [-1, 1e-3, 0]) == pytest.approx(1e-3, rel=1e-6)
    assert axis_error([1, 0, 0], [np.cos(2.5), np.sin(2.5), 0]) == pytest.approx(np.pi - 2.5)


def test_pivot_error_skew_lines():
    # z-line through (0,0,0) and y-line through (0.2, 5, 3): the common normal is x, distance 0.2
    assert line_distance([0, 0, 0], [0, 0, 1], [0.2, 5.0, 3.0], [0, 1, 0]) == pytest.approx(0.2)
    # intersecting lines: 0
    assert line_distance([0, 0, 0], [0, 0, 1], [0, 0, 0.7], [1, 1, 0]) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("direction", [[0, 0, 1], [0, 0, -1], [0, 0, 2.5]])
def test_pivot_error_parallel_lines_no_division_by_zero(direction):
    # hinge moved by (0.3, 0.4, 0) plus a slide along the axis: distance 0.5 whatever the slide
    d = line_distance([0, 0, 0], [0, 0, 1], [0.3, 0.4, 7.0], direction)
    assert np.isfinite(d) and d == pytest.approx(0.5)
    # nearly parallel, under the tolerance: still the point-to-line distance
    assert line_distance([0, 0, 0], [0, 0, 1], [0.3, 0.4, 0], [1e-9, 0, 1]) == pytest.approx(0.5)
    assert point_line_distance([0.3, 0.4, 9.0], [0, 0, 0], [0, 0, 1]) == pytest.approx(0.5)


def test_pivot_error_does_not_depend_on_the_point_chosen_on_each_axis():
    p, a = np.array([0.1, -0.2, 0.3]), np.array([0.3, 0.1, 0.9])
    q, b = np.array([-0.4, 0.5, 0.0]), np.array([0.2, -0.7, 0.4])
    d0 = line_distance(p, a, q, b)
    assert line_distance(p + 2.0 * a, -a, q - 3.0 * b, b) == pytest.approx(d0)
    assert line_distance(q, b, p, a) == pytest.approx(d0)


def test_type_agreement():
    assert same_type("continuous", "revolute") and same_type("revolute", "continuous")
    assert not same_type("prismatic", "revolute")
    with pytest.raises(ValueError):
        same_type("ball", "revolute")


def test_compare_joints_pivot_for_every_rotating_ground_truth():
    """FreeArt3D's rule: a ground-truth revolute joint gets a PivotErr whatever the predicted type (a predicted
    slider is scored by its axis line through its origin); a ground-truth slider gets none."""
    z = np.array([0.0, 0.0, 1.0])
    hinge = JointAxis("g", "revolute", np.zeros(3), z)
    moved = JointAxis("p", "continuous", np.array([0.0, 0.25, 0.0]), -z)
    errors = compare_joints(moved, hinge)
    assert errors.axis_err == pytest.approx(0.0) and errors.pivot_err == pytest.approx(0.25)
    assert errors.type_match
    # a slider along +y through (0.3, 0.25, 0.1): skew to the hinge's z axis, 0.3 apart (along x)
    slider = JointAxis("p", "prismatic", np.array([0.3, 0.25, 0.1]), np.array([0.0, 1.0, 0.0]))
    errors = compare_joints(slider, hinge)
    assert errors.pivot_err == pytest.approx(0.3) and not errors.type_match
    assert errors.axis_err == pytest.approx(np.pi / 2)
    # a parallel slider 0.4 off the hinge: the point-to-line distance (FreeArt3D's formula divides by zero)
    parallel = JointAxis("p", "prismatic", np.array([0.0, -0.4, 0.7]), z)
    assert compare_joints(parallel, hinge).pivot_err == pytest.approx(0.4)
    # the other way round: a ground-truth slider has no pivot, whatever was predicted
    gt_slider = JointAxis("g", "prismatic", np.zeros(3), z)
    assert compare_joints(moved, gt_slider).pivot_err is None
    assert compare_joints(slider, gt_slider).pivot_err is None


def test_line_distance_matches_closest_points_by_least_squares():
    """PivotErr against an independent computation: the closest points of the two lines by least squares."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        pa, pb = rng.normal(size=3), rng.normal(size=3)
        a, b = rng.normal(size=3), rng.normal(size=3)
        (s_, t_), *_ = np.linalg.lstsq(np.stack([a, -b], axis=1), pb - pa, rcond=None)
        expected = np.linalg.norm(pa + s_ * a - (pb + t_ * b))
        assert compare_joints(JointAxis("p", "prismatic", pb, b / np.linalg.norm(b)),
                              JointAxis("g", "revolute", pa, a / np.linalg.norm(a))).pivot_err \
            == pytest.approx(expected, abs=1e-9)


# ----- matching ------------------------------------------------------------------------------------
def test_hungarian_matching_by_hand():
    cost = np.array([[0.9, 0.1, 0.5], [0.2, 0.8, 0.6]])  # 2 pred, 3 gt
    pairs = match_parts(cost)
    assert [(p.pred, p.gt) for p in pairs] == [(1, 0), (0, 1)]
    assert sum(p.cost for p in pairs) == pytest.approx(0.3)


def test_matching_ties_broken_and_impossible_pairs_dropped():
    cost = np.full((2, 2), 0.4)
    tie = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert [(p.pred, p.gt) for p in match_parts(cost, tie)] == [(1, 0), (0, 1)]
    cost = np.array([[np.inf, 0.5], [np.inf, np.inf]])
    assert [(p.pred, p.gt) for p in match_parts(cost)] == [(0, 1)]
    assert match_parts(np.zeros((0, 3))) == []


def test_part_cost_matrix_is_chamfer():
    a, b = grid_plane(), grid_plane() + [0, 0, 0.03]
    cost = part_cost_matrix([a, None], [a, b])
    np.testing.assert_allclose(cost[0], [0.0, 0.06], atol=1e-12)
    assert np.isinf(cost[1]).all()


# ----- alignment -----------------------------------------------------------------------------------
def test_rigid_fit_recovers_a_rotation():
    rng = np.random.default_rng(1)
    src = rng.normal(size=(50, 3))
    rot = rotation_z(0.3)
    fit = rigid_fit(src, src @ rot.T + [0.1, 0.2, 0.3])
    np.testing.assert_allclose(fit[:3, :3], rot, atol=1e-12)
    np.testing.assert_allclose(fit[:3, 3], [0.1, 0.2, 0.3], atol=1e-12)


def test_align_points_undoes_a_yaw_off_the_grid():
    # an L-shaped cloud (no symmetry) turned by 100 degrees and shifted: the grid start at 270
    # degrees is 10 degrees off, ICP closes the rest
    rng = np.random.default_rng(2)
    target = np.concatenate([rng.uniform([-1, -0.2, -0.1], [1, 0.2, 0.1], (1500, 3)),
                             rng.uniform([0.6, 0.2, -0.1], [1, 1, 0.1], (800, 3))])
    rot = rotation_z(np.deg2rad(100))
    source = target @ rot.T + [0.05, -0.03, 0.0]
    found = align_points(source, target)
    np.testing.assert_allclose(found.rotation, rot.T, atol=1e-6)
    np.testing.assert_allclose(found.apply_points(source), target, atol=1e-6)
    assert found.cd < 1e-6


def test_alignment_moves_points_fully_and_directions_by_rotation_only():
    matrix = np.eye(4)
    matrix[:3, :3] = 2.0 * rotation_z(np.pi / 2)
    matrix[:3, 3] = [5.0, 0.0, 0.0]
    al = Alignment(matrix, 0.0)
    np.testing.assert_allclose(al.apply_points([[1.0, 0.0, 0.0]]), [[5.0, 2.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(al.apply_direction([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)
    assert al.scale == pytest.approx(2.0)


# ----- aggregation ---------------------------------------------------------------------------------
def test_mean_over_objects_skips_absent_values():
    rows = [{"cd": 0.1, "axis_err": None, "type_err": 1.0, "n_missing_joints": 2, "convention": "x"},
            {"cd": 0.3, "axis_err": 0.2, "type_err": 0.0, "n_missing_joints": 0}]
    out = mean_over_objects(rows)
    assert out["n_objects"] == 2
    assert out["cd"] == pytest.approx(0.2) and out["type_err"] == pytest.approx(0.5)
    assert out["axis_err"] == pytest.approx(0.2) and out["n_axis_err"] == 1
    assert out["n_missing_joints"] == pytest.approx(1.0)
    assert "convention" not in out
