"""Mesh operations of the SPARK appendix: merge, pitch, watertight remesh, surface sampling."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from spark_bench.asset.mesh import (
    cleanup,
    cleanup_with_watertight,
    drop_degenerate_faces,
    edge_structure,
    face_components,
    make_watertight,
    merge_meshes,
    min_face_height,
    sample_surface,
    shell_cleanup,
    signed_volume,
    twin_pairs,
    vertex_spacing,
)
from spark_bench.asset.voxel import (
    VoxelGrid,
    fill_holes,
    sample_grids,
    voxel_pitch,
    voxelize_surface,
    walk_rows,
)


def test_merge_is_plain_vertex_face_concatenation():
    a = trimesh.creation.box(extents=(1, 1, 1))
    b = trimesh.creation.box(extents=(1, 1, 1))
    b.apply_translation((0.5, 0, 0))  # overlapping: nothing is repaired or welded
    merged = merge_meshes([a, b])
    assert len(merged.vertices) == 16 and len(merged.faces) == 24
    np.testing.assert_array_equal(merged.faces[12:], b.faces + 8)
    assert len(merge_meshes([]).faces) == 0


def test_pitch_follows_resolution_thin_axis_and_memory_cap():
    assert voxel_pitch([2.0, 1.0, 1.0], resolution=200, n_min=3) == pytest.approx(0.01)
    # a 3 mm thick door needs at least 3 voxels across: the thin-axis pitch wins
    assert voxel_pitch([1.0, 1.0, 0.003], resolution=200, n_min=3) == pytest.approx(0.001)
    # a flat part (zero thickness) keeps the resolution pitch
    assert voxel_pitch([1.0, 1.0, 0.0], resolution=100, n_min=3) == pytest.approx(0.01)
    capped = voxel_pitch([1.0, 1.0, 1.0], resolution=1000, n_min=3, memory_cap=1e6)
    assert np.prod(np.ceil(1.0 / capped) + 2) <= 1.01e6


def test_voxelize_marks_every_cell_the_surface_crosses():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    occupancy, origin = voxelize_surface(box, 0.1)
    # 10 cells across plus the half-pitch margins; the six faces form a closed shell of cells (the
    # shape is ceil(1.1 / 0.1) + 1 in IEEE arithmetic, the same on every machine)
    assert occupancy.shape == (12, 12, 12)
    np.testing.assert_allclose(origin, [-0.55, -0.55, -0.55])
    from scipy.ndimage import binary_fill_holes

    filled = binary_fill_holes(occupancy)
    # the shell is closed, so the interior fills: 11^3 cells span the box, none outside it
    assert filled.sum() == 11**3 and occupancy.sum() == 11**3 - 9**3


def test_open_mesh_becomes_watertight_with_original_extents():
    box = trimesh.creation.box(extents=(0.4, 0.3, 0.2))
    open_box = trimesh.Trimesh(box.vertices, box.faces[2:], process=False)  # one face missing
    assert not open_box.is_watertight
    shell, report = make_watertight(open_box, resolution=60)
    assert report.method == "voxel" and report.watertight and shell.is_watertight
    # the axis-wise rescale restores the extents up to float64 rounding of ~0.4 m coordinates (~1e-16)
    np.testing.assert_allclose(shell.extents, open_box.extents, atol=1e-9)
    np.testing.assert_allclose(shell.bounds.mean(0), open_box.bounds.mean(0), atol=1e-9)
    assert shell.volume > 0


def test_flat_mesh_gets_a_thin_closed_shell():
    plane = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    shell, report = make_watertight(plane, resolution=50)
    assert shell.is_watertight and report.method == "voxel"
    np.testing.assert_allclose(shell.extents[:2], [1, 1], atol=1e-9)


def test_watertight_input_takes_the_cleanup_path_and_keeps_all_pieces():
    a = trimesh.creation.box(extents=(1, 1, 1))
    b = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    b.apply_translation((2, 0, 0))  # a separate closed piece (a handle) must survive
    shell, report = make_watertight(merge_meshes([a, b]))
    assert report.method == "cleanup" and report.pitch is None
    assert len(shell.faces) == 24 and shell.volume == pytest.approx(1.008)


def test_voxel_path_drops_floating_fragments():
    a = trimesh.creation.box(extents=(1, 1, 1))
    speck = trimesh.creation.box(extents=(0.05, 0.05, 0.05))
    speck.apply_translation((1.5, 0, 0))
    torn = merge_meshes([trimesh.Trimesh(a.vertices, a.faces[1:]), speck])
    shell, _ = make_watertight(torn, resolution=60)
    assert shell.bounds[1, 0] < 0.6  # the speck is gone, the box stays


def test_sampling_is_uniform_by_area_and_seeded():
    # two unit squares, one 3x larger in area: it should get ~3/4 of the samples
    small = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    big = trimesh.Trimesh([[0, 0, 5], [3, 0, 5], [3, 1, 5], [0, 1, 5]], [[0, 1, 2], [0, 2, 3]])
    mesh = merge_meshes([small, big])
    points = sample_surface(mesh, 40_000, seed=3)
    assert abs((points[:, 2] > 2).mean() - 0.75) < 0.01
    # the same call twice (one code path, no threads): a seed must give bit-identical points
    np.testing.assert_array_equal(points, sample_surface(mesh, 40_000, seed=3))
    assert not np.array_equal(points, sample_surface(mesh, 40_000, seed=4))
    # points lie on the surface, inside each square
    top = points[points[:, 2] > 2]
    assert top[:, 0].min() >= 0 and top[:, 0].max() <= 3 and np.allclose(top[:, 2], 5)


def test_sampling_refuses_empty_and_degenerate_meshes():
    with pytest.raises(ValueError, match="empty"):
        sample_surface(trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int)), 10)
    degenerate = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(ValueError, match="zero"):
        sample_surface(degenerate, 10)


def test_sliver_in_watertight_mesh_keeps_the_cleanup_path():
    box = trimesh.creation.box(extents=(1, 1, 1))
    # put vertex m on edge (a, b) of triangle (a, b, c), split that triangle, and close the edge with
    # the zero-area face (a, b, m): still closed, but cleanup would drop the sliver and open it
    a, b, c = box.faces[0]
    m = len(box.vertices)
    vertices = np.vstack([box.vertices, (box.vertices[a] + box.vertices[b]) / 2])
    faces = np.vstack([box.faces[1:], [[a, m, c], [m, b, c], [b, a, m]]])
    sliver = trimesh.Trimesh(vertices, faces, process=False)
    assert sliver.is_watertight
    shell, report = make_watertight(sliver, resolution=50)
    assert report.method == "cleanup" and shell.is_watertight and len(shell.faces) <= 14


def test_simplify_keeps_shell_watertight_and_close():
    open_box = trimesh.creation.box(extents=(0.4, 0.3, 0.2))
    open_box = trimesh.Trimesh(open_box.vertices, open_box.faces[2:], process=False)
    full, report = make_watertight(open_box, resolution=80)
    small, _ = make_watertight(open_box, resolution=80, simplify=0.5)
    assert small.is_watertight and len(small.faces) < len(full.faces) / 20
    np.testing.assert_allclose(small.extents, full.extents, atol=report.pitch)


def _random_triangles(rng, count: int, thin: bool) -> np.ndarray:
    """Triangles in the unit cube; ``thin`` ones are slivers (one short side) like CAD meshes have."""
    a = rng.uniform(0, 1, (count, 3))
    b = a + rng.normal(0, 0.3, (count, 3))
    c = (a + b) / 2 + rng.normal(0, 0.003 if thin else 0.3, (count, 3))
    return np.stack([a, b, c], axis=1)


@pytest.mark.parametrize("family", [0, 1, 2])
def test_row_walk_marks_the_voxels_of_every_lattice_point(family):
    """The row walk evaluates a few points per row with the full grid's own formula: the set of
    voxels is the same set, compared exactly (both evaluate identical float expressions)."""
    rng = np.random.default_rng(family)
    triangles = np.concatenate([_random_triangles(rng, 300, thin=True),
                                _random_triangles(rng, 60, thin=False)])
    triangles[0] = [[-1, -1, -1]] * 3
    triangles[1] = [[2, 2, 2]] * 3  # fixes the grid: the origin is -1.01
    pitch = 0.02
    # corners of some triangles on voxel faces (to rounding): crossings right at lattice points
    triangles[2:40] = -1.01 + pitch * np.round((triangles[2:40] + 1.01) / pitch)
    origin = triangles.reshape(-1, 3).min(0) - 0.5 * pitch
    shape = np.ceil((triangles.reshape(-1, 3).max(0) + 0.5 * pitch - origin) / pitch).astype(int) + 1
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(1)
    steps = np.maximum(1, np.ceil(edges / (0.5 * pitch))).astype(int)
    full, walked = VoxelGrid(origin, pitch, shape), VoxelGrid(origin, pitch, shape)
    sample_grids(full, triangles, steps)
    walk_rows(walked, triangles, steps, np.full(len(triangles), family))
    assert full.occupancy.sum() > 1000
    np.testing.assert_array_equal(walked.occupancy, full.occupancy)


def test_voxelize_with_and_without_the_walk_agree_on_a_sliver_mesh():
    rng = np.random.default_rng(7)
    triangles = _random_triangles(rng, 400, thin=True)
    faces = np.arange(len(triangles) * 3).reshape(-1, 3)
    mesh = trimesh.Trimesh(triangles.reshape(-1, 3), faces, process=False)
    walked, origin = voxelize_surface(mesh, 0.01)
    full, origin_full = voxelize_surface(mesh, 0.01, walk=False, max_rows=1000)
    np.testing.assert_array_equal(origin, origin_full)
    np.testing.assert_array_equal(walked, full)


def test_fill_holes_matches_scipy():
    from scipy.ndimage import binary_fill_holes

    rng = np.random.default_rng(0)
    for density in (0.2, 0.5, 0.7):
        occupancy = rng.random((23, 17, 11)) < density
        np.testing.assert_array_equal(fill_holes(occupancy), binary_fill_holes(occupancy))
    shell = np.ones((6, 6, 6), dtype=bool)
    shell[1:-1, 1:-1, 1:-1] = False
    assert fill_holes(shell).all() and not fill_holes(shell[:, :, :-1])[2, 2, 2]  # an open shell stays open


def test_edge_structure_follows_trimesh_split_and_watertight():
    box = trimesh.creation.box()
    far = box.copy()
    far.apply_translation((3, 0, 0))
    fan = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]],
                          [[0, 1, 2], [0, 1, 3], [0, 1, 4]], process=False)  # one edge, three faces
    pinch = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]],
                            [[0, 1, 2], [0, 3, 4]], process=False)  # two faces sharing a vertex only
    open_box = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)
    cases = ((box, True), (merge_meshes([box, far]), False), (fan, False), (pinch, False), (open_box, True))
    for mesh, one in cases:
        one_piece, watertight = edge_structure(mesh.faces)
        assert one_piece == one == (len(mesh.split(only_watertight=False)) == 1)
        assert watertight == mesh.is_watertight


def test_signed_volume_is_trimesh_volume():
    box = trimesh.creation.box(extents=(0.4, 0.3, 0.2))
    # the same integral summed in another order: equal to float64 rounding of a sum of 12 terms
    assert signed_volume(box) == pytest.approx(box.volume, rel=1e-12) and box.volume == pytest.approx(0.024)
    box.invert()
    assert signed_volume(box) == pytest.approx(-0.024, rel=1e-12)


def _cleanup_reference(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """cleanup(fix_normals=False) as the plain sequence of trimesh steps, with no shortcut."""
    mesh = mesh.copy()
    mesh.merge_vertices(digits_vertex=6)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    parts = mesh.split(only_watertight=False)
    return max(parts, key=lambda m: (len(m.faces), abs(m.volume) if m.is_watertight else 0.0)) if len(parts) > 1 \
        else mesh


def test_cleanup_shortcuts_change_nothing():
    """cleanup skips the steps it can prove change nothing: the result is the plain sequence's."""
    box = trimesh.creation.box()
    repeated = trimesh.Trimesh(box.vertices, np.vstack([box.faces, box.faces[:1]]), process=False)
    flat = trimesh.Trimesh(np.vstack([box.vertices, [[0.5, 0.5, 0.5]]]), np.vstack([box.faces, [[0, 0, 8]]]),
                           process=False)  # a zero-area face
    speck = box.copy()
    speck.apply_scale(0.1)
    speck.apply_translation((3, 0, 0))
    shell, _ = make_watertight(trimesh.Trimesh(box.vertices, box.faces[1:], process=False), resolution=30)
    assert min_face_height(flat) == 0.0 and min_face_height(box) > 0.1
    for mesh in (box, repeated, flat, merge_meshes([box, speck]), shell):
        got, want = cleanup(mesh, fix_normals=False), _cleanup_reference(mesh)
        np.testing.assert_array_equal(got.faces, want.faces)
        np.testing.assert_array_equal(got.vertices, want.vertices)
    assert len(cleanup(repeated).faces) == len(cleanup(flat).faces) == 12


def test_drop_degenerate_faces_keeps_faces_with_area_and_their_vertices():
    rng = np.random.default_rng(3)
    vertices = rng.normal(size=(40, 3))
    vertices[30] = vertices[2] + 0.5 * (vertices[5] - vertices[2])  # on the segment 2-5
    faces = rng.integers(0, 30, size=(200, 3))
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    bad = np.array([[1, 1, 4], [2, 30, 5], [7, 8, 7]])  # a repeated corner, three collinear points
    mixed = np.vstack([faces[:10], bad, faces[10:]])
    kept_vertices, kept_faces = drop_degenerate_faces(vertices, mixed)
    # the faces with an area, in order, on the vertices they use (in order): the same triangles
    np.testing.assert_array_equal(kept_vertices[kept_faces], vertices[faces])
    used = np.unique(faces)
    np.testing.assert_array_equal(kept_vertices, vertices[used])
    assert drop_degenerate_faces(vertices, bad) is None
    assert drop_degenerate_faces(np.full((3, 3), np.nan), [[0, 1, 2]]) is None


def _marching_cubes_shell(occupancy: np.ndarray) -> tuple[trimesh.Trimesh, np.ndarray]:
    """The shell make_watertight builds from a filled grid (pitch 0.01), and the grid vertices."""
    from skimage.measure import marching_cubes

    grid_verts, faces, _, _ = marching_cubes(np.pad(occupancy, 1).astype(np.float32), level=0.5)
    return trimesh.Trimesh((grid_verts - 0.5) * 0.01, faces[:, ::-1], process=False), grid_verts


def test_shell_cleanup_is_cleanup_on_marching_cubes_shells():
    """The shortcut path of make_watertight gives cleanup_with_watertight's bytes: one piece, several pieces (the largest
    kept), two equal largest pieces (the first kept), and a grid whose shell has cube-interior vertices."""
    one = np.zeros((12, 12, 12), dtype=bool)
    one[2:9, 3:10, 2:7] = True
    pieces = one.copy()
    pieces[10:12, 0:2, 9:12] = True  # a small second piece
    twins = np.zeros((14, 6, 6), dtype=bool)
    twins[1:4, 1:4, 1:4] = twins[8:11, 1:4, 1:4] = True  # equal faces and volume: the first is kept
    noisy = np.random.default_rng(0).random((8, 8, 8)) < 0.3  # Lewiner adds vertices at cube centres
    taken = 0
    for occupancy in (one, pieces, twins, noisy):
        shell, grid_verts = _marching_cubes_shell(occupancy)
        spacing = vertex_spacing(grid_verts)
        assert 0 < spacing <= 0.5
        got = shell_cleanup(shell, spacing * 0.01)
        want, _ = cleanup_with_watertight(shell, fix_normals=False)
        if got is None:  # a proof failed (e.g. a piece of two faces): the caller runs cleanup_with_watertight
            continue
        taken += 1
        np.testing.assert_array_equal(got[0].vertices, want.vertices)
        np.testing.assert_array_equal(got[0].faces, want.faces)
        assert got[1] and want.is_watertight
    assert taken >= 3
    shell, grid_verts = _marching_cubes_shell(noisy)
    frac = grid_verts - np.floor(grid_verts)
    assert (frac == 0.5).all(1).any()  # cube centres: half a voxel from every edge midpoint
    assert vertex_spacing(grid_verts) == 0.5
    assert vertex_spacing(np.array([[0.5, 0, 0], [0.5, 0.5, 0.5], [0.5, 0.6, 0.5]])) == pytest.approx(0.1)
    assert vertex_spacing(np.array([[0.3, 0.3, 0.3], [0.3, 0.3, 0.3], [0.5, 0, 0]])) == 0.0
    # welding would merge vertices closer than its radius: then the shortcut declines
    assert shell_cleanup(_marching_cubes_shell(one)[0], 1e-6) is None


def test_face_components_twin_path_matches_edge_sort():
    """The sparse-transpose pairing (closed, consistently oriented faces) labels the faces as the edge sort
    does; a face flipped against its neighbours falls back to the sort and is still watertight."""
    box = trimesh.creation.box()
    far = box.copy()
    far.apply_translation((3, 0, 0))
    two = merge_meshes([box, far])
    assert twin_pairs(np.asarray(two.faces)) is not None
    count, labels, watertight = face_components(two.faces)
    assert count == 2 and watertight and labels.tolist() == [0] * 12 + [1] * 12
    flipped = np.asarray(box.faces).copy()
    flipped[0] = flipped[0, ::-1]
    assert twin_pairs(flipped) is None
    count, labels, watertight = face_components(flipped)
    assert count == 1 and watertight == trimesh.Trimesh(box.vertices, flipped, process=False).is_watertight


def test_mark_points_marks_what_mark_of_coordinates_marks():
    rng = np.random.default_rng(2)
    triangles = rng.random((50, 3, 3))
    origin, pitch = np.full(3, -0.05), 0.013
    shape = np.ceil((1.1 - origin) / pitch).astype(int) + 1
    weights = rng.dirichlet((1, 1, 1), size=40)
    w0, w1, w2 = (weights[None, :, k] for k in range(3))
    corners = triangles[:, None, :, :]
    reference, reused = VoxelGrid(origin, pitch, shape), VoxelGrid(origin, pitch, shape)
    reference.mark(reference.coordinates(w0, w1, w2, corners[:, :, 0], corners[:, :, 1], corners[:, :, 2]))
    for block in (slice(0, 30), slice(30, 50)):  # the buffers are reused for a smaller block
        c = corners[block]
        reused.mark_points(w0, w1, w2, c[:, :, 0], c[:, :, 1], c[:, :, 2])
    assert reference.occupancy.sum() > 100
    np.testing.assert_array_equal(reused.occupancy, reference.occupancy)


def test_make_watertight_gives_the_same_mesh_when_the_shell_shortcut_declines(monkeypatch):
    """make_watertight's fallback (``cleanup_with_watertight`` where ``shell_cleanup`` declines) gives the shortcut's
    mesh: a torn box with a floating speck (two pieces, the largest kept)."""
    import spark_bench.asset.mesh as mesh_module

    a = trimesh.creation.box(extents=(1, 0.6, 0.4))
    speck = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    speck.apply_translation((1.5, 0, 0))
    torn = merge_meshes([trimesh.Trimesh(a.vertices, a.faces[1:]), speck])
    taken = []
    shortcut = mesh_module.shell_cleanup
    monkeypatch.setattr(mesh_module, "shell_cleanup", lambda *args: taken.append(shortcut(*args)) or taken[-1])
    fast, _ = make_watertight(torn, resolution=40)
    assert taken and taken[0] is not None  # the shortcut ran and was used
    monkeypatch.setattr(mesh_module, "shell_cleanup", lambda *args: None)
    slow, report = make_watertight(torn, resolution=40)
    assert report.method == "voxel" and slow.is_watertight
    np.testing.assert_array_equal(fast.vertices, slow.vertices)
    np.testing.assert_array_equal(fast.faces, slow.faces)
