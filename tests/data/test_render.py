"""MuJoCo offscreen rendering and the camera model: the images must agree with camera.json exactly."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from helpers_assets import tiny_cabinet
from matplotlib.path import Path as PolygonPath
from scipy.ndimage import binary_dilation
from scipy.spatial import ConvexHull

from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.asset.ops import normalize_asset
from spark_bench.asset.transforms import make_transform
from spark_bench.data.camera import (
    CameraView,
    front_view_angles,
    intrinsics_matrix,
    look_at,
    view_seed,
)
from spark_bench.data.render import BACKGROUND, AssetRenderer, render_asset
from spark_bench.errors import InputError


def two_boxes() -> ArticulatedAsset:
    """Two separated boxes on two links (a fixed base and a sliding part), distinct colours."""
    left = trimesh.creation.box(extents=(0.8, 0.5, 0.9), transform=make_transform(translation=(0, -0.5, 0)))
    right = trimesh.creation.box(extents=(0.6, 0.4, 0.5), transform=make_transform(translation=(0, 0.5, 0.1)))
    links = {
        "base": Link("base"),
        "left": Link("left", visuals=[Visual(left, (0.9, 0.1, 0.1, 1.0))]),
        "right": Link("right", visuals=[Visual(right, (0.1, 0.2, 0.9, 1.0))]),
    }
    joints = {
        "fix": Joint("fix", "fixed", "base", "left"),
        "slide": Joint("slide", "prismatic", "left", "right", axis=np.array([0.0, 0.0, 1.0]), lower=0.0, upper=0.3),
    }
    return ArticulatedAsset("two_boxes", links, joints, category="Test")


def box_corners(mesh: trimesh.Trimesh) -> np.ndarray:
    lo, hi = mesh.bounds
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def polygon_mask(view: CameraView, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels whose centers lie inside the convex hull of the projected points, and that hull."""
    uv, depth = view.project(points)
    assert (depth > 0).all()
    hull = uv[ConvexHull(uv).vertices]
    rows, cols = np.mgrid[0:view.height, 0:view.width]
    centers = np.stack([cols.ravel() + 0.5, rows.ravel() + 0.5], axis=1)
    return PolygonPath(hull).contains_points(centers).reshape(view.height, view.width), hull


def distance_to_polygon(points: np.ndarray, hull: np.ndarray) -> np.ndarray:
    out = np.full(len(points), np.inf)
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        t = np.clip(((points - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        out = np.minimum(out, np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1))
    return out


# ----- camera model ---------------------------------------------------------------------------
def test_intrinsics_follow_the_format():
    k = intrinsics_matrix(640, 480, 40.0)
    focal = 240.0 / np.tan(np.radians(20.0))
    assert k[0, 0] == pytest.approx(focal) and k[1, 1] == pytest.approx(focal)
    assert k[0, 2] == 320.0 and k[1, 2] == 240.0


def test_look_at_is_a_rigid_opencv_pose():
    view = CameraView.on_sphere(200.0, 25.0, 4.0, size=64)
    rot = view.world_to_camera[:3, :3]
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0)
    assert view.distance == pytest.approx(4.0)
    assert view.position[2] == pytest.approx(4.0 * np.sin(np.radians(25.0)))
    # the origin projects to the image center, world up points up in the image (v decreases)
    uv, depth = view.project([[0, 0, 0], [0, 0, 0.5]])
    np.testing.assert_allclose(uv[0], [32.0, 32.0], atol=1e-9)
    assert depth[0] == pytest.approx(4.0)
    assert uv[1, 1] < uv[0, 1] and uv[1, 0] == pytest.approx(32.0, abs=1e-9)
    # a point behind the camera has negative depth
    _, behind = view.project([2.0 * view.position])
    assert behind[0] < 0
    # looking straight down still gives a valid frame
    down = look_at((0.0, 0.0, 4.0))
    np.testing.assert_allclose(down[:3, :3] @ down[:3, :3].T, np.eye(3), atol=1e-12)


def test_front_views_are_seeded_and_in_the_front_hemisphere():
    angles = np.array([front_view_angles(s) for s in range(200)])
    assert (np.abs(angles[:, 0] - 180.0) <= 60.0).all()
    assert ((angles[:, 1] >= 10.0) & (angles[:, 1] <= 40.0)).all()
    assert angles[:, 0].std() > 20.0  # the views really vary
    assert front_view_angles(7) == front_view_angles(7)
    assert view_seed("40147") == view_seed("40147") != view_seed("40148")
    # the front faces -X: every camera of the front hemisphere sits at negative x
    for seed in range(20):
        assert CameraView.front(seed).position[0] < -1.0


def test_camera_json_round_trip(tmp_path):
    view = CameraView.front(3, size=96)
    path = view.save(tmp_path / "camera.json")
    data = json.loads(path.read_text())
    assert data["convention"] == "opencv" and data["fov_deg"] == 40.0 and data["distance"] == pytest.approx(4.0)
    np.testing.assert_allclose(np.asarray(data["camera_to_world"]) @ np.asarray(data["world_to_camera"]), np.eye(4),
                               atol=1e-12)
    again = CameraView.load(path)
    np.testing.assert_allclose(again.world_to_camera, view.world_to_camera)
    np.testing.assert_allclose(again.intrinsics, view.intrinsics)
    data["intrinsics"][0][0] *= 1.1
    with pytest.raises(InputError, match="intrinsics"):
        CameraView.from_json(data, source=path)
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(InputError, match="bad.json"):
        CameraView.load(tmp_path / "bad.json")


# ----- rendering --------------------------------------------------------------------------------
@pytest.mark.parametrize("width,height,seed", [(160, 160, 1), (200, 120, 5)])
def test_silhouette_matches_camera_projection(width, height, seed):
    """The rendered mask of a box equals the polygon that camera.json projects, to the pixel."""
    box = trimesh.creation.box(extents=(1.2, 0.8, 1.0))
    asset = ArticulatedAsset("box", {"base": Link("base", [Visual(box, (0.2, 0.4, 0.8, 1.0))])}, {})
    azimuth, elevation = front_view_angles(seed)
    view = CameraView.on_sphere(azimuth, elevation, 4.0, size=width, height=height)
    image = render_asset(asset, view)
    assert image.rgb.shape == (height, width, 3) and image.segmentation.shape == (height, width)
    expected, hull = polygon_mask(view, box_corners(box))
    mask = image.segmentation == 1
    assert mask.sum() > 500
    wrong = np.argwhere(mask != expected)
    # only pixels whose center lies (numerically) on the polygon's edge may disagree
    assert len(wrong) <= 0.002 * mask.sum()
    if len(wrong):
        assert distance_to_polygon(wrong[:, ::-1] + 0.5, hull).max() < 0.05
    # a half-pixel shift of the principal point would be caught
    shifted = PolygonPath(hull + 0.5).contains_points(
        np.argwhere(np.ones((height, width)))[:, ::-1] + 0.5).reshape(height, width)
    assert (shifted != mask).sum() > 10 * max(len(wrong), 1)


def test_per_link_labels_colours_and_configurations():
    asset, _, _ = normalize_asset(two_boxes())
    view = CameraView.on_sphere(180.0, 20.0, 4.0, size=128)
    with AssetRenderer(asset, 128) as renderer:
        rest = renderer.render(view)
        opened = renderer.render(view, asset.open_configuration())
    assert rest.links == ["base", "left", "right"]
    assert set(np.unique(rest.segmentation)) == {0, 2, 3}  # base has no geometry: label 1 never appears
    for name in ("left", "right"):
        expected, _ = polygon_mask(view, box_corners(asset.link_meshes()[name]))
        assert (rest.mask(name) != expected).sum() <= 0.01 * expected.sum()
    # colours: the left box is red, the right one blue, the background the neutral grey
    red = rest.rgb[rest.mask("left")].mean(0)
    blue = rest.rgb[rest.mask("right")].mean(0)
    assert red[0] > 2 * red[2] and blue[2] > 2 * blue[0]
    np.testing.assert_allclose(rest.rgb[rest.segmentation == 0].mean(0), np.array(BACKGROUND) * 255, atol=2.0)
    # the open state moves the right box up by the prismatic upper limit (benchmark frame)
    rows_rest = np.nonzero(rest.mask("right").any(1))[0]
    rows_open = np.nonzero(opened.mask("right").any(1))[0]
    expected_up, _ = polygon_mask(view, box_corners(asset.link_meshes(asset.open_configuration())["right"]))
    assert rows_open.min() < rows_rest.min() - 5
    assert (opened.mask("right") != expected_up).sum() <= 0.01 * expected_up.sum()
    assert (opened.mask("left") == rest.mask("left")).all()


def test_tiny_cabinet_renders_every_visible_part():
    asset, _, _ = normalize_asset(tiny_cabinet())
    view = CameraView.front(3, size=96)
    rendering = render_asset(asset, view, asset.open_configuration())
    labels = set(np.unique(rendering.segmentation)) - {0}
    assert labels == {rendering.links.index(n) + 1 for n in ("body", "drawer", "door")}
    # every projected vertex of the object lands within 2 px of a foreground pixel (a sharp silhouette
    # corner may cover no pixel center right at its tip)
    points = asset.mesh(asset.open_configuration()).vertices
    cols, rows = view.pixel_of(points).T
    inside = (cols >= 0) & (cols < 96) & (rows >= 0) & (rows < 96)
    assert inside.mean() > 0.9
    grown = binary_dilation(rendering.segmentation > 0, np.ones((5, 5), bool))
    assert grown[rows[inside], cols[inside]].all()
    # and the background is where no vertex is: the object's mask fits the projected points' box
    fg_rows, fg_cols = np.nonzero(rendering.segmentation)
    assert fg_rows.min() >= rows[inside].min() - 1 and fg_cols.max() <= cols[inside].max() + 1


def test_renderer_rejects_unknown_links_and_oversized_images():
    asset = two_boxes()
    with pytest.raises(KeyError):
        AssetRenderer(asset, 32, links=["nope"])
    with AssetRenderer(asset, 32) as renderer, pytest.raises(ValueError, match="exceeds"):
        renderer.render(CameraView.on_sphere(180.0, 20.0, size=64))
