"""The soft-silhouette renderer: agreement with an exact rasterizer, and gradients vs finite differences."""

import numpy as np
import torch
import trimesh

from spark_bench.methods.ours.camera import look_at_camera
from spark_bench.methods.ours.loss import halo_target
from spark_bench.methods.ours.render import SoftSilhouetteRenderer, rasterize_mask


def _scene():
    camera = look_at_camera((-3.0, -1.5, 1.8), size=128)
    box = trimesh.creation.box(extents=(0.8, 1.2, 1.6))
    slab = trimesh.creation.box(extents=(0.05, 0.9, 1.2))
    slab.apply_translation((-0.6, 0.3, 0.0))
    mesh = trimesh.util.concatenate([box, slab])
    return camera, mesh


def test_soft_silhouette_agrees_with_exact_coverage():
    camera, mesh = _scene()
    for size in (64, 128):
        soft = SoftSilhouetteRenderer(camera, size, tau=0.5).render(
            torch.tensor(mesh.vertices, dtype=torch.float32), torch.tensor(mesh.faces)).numpy()
        centres = rasterize_mask(mesh.vertices, mesh.faces, camera.resized(size), supersample=1) > 0.5
        # full coverage exactly where a pixel centre is inside the projection: no seams anywhere
        assert np.mean((soft > 0.9999) != centres) < 0.002
        # outside, the halo is 2 sigmoid(-d / tau): it vanishes a few pixels away
        coverage = rasterize_mask(mesh.vertices, mesh.faces, camera.resized(size), supersample=8)
        from scipy.ndimage import binary_dilation

        far = ~binary_dilation(coverage > 0, iterations=6)
        assert soft[far].max() < 1e-3
        assert np.abs(soft - coverage).mean() < 0.03


def test_halo_target_of_the_true_mask_matches_the_render():
    camera, mesh = _scene()
    fine = rasterize_mask(mesh.vertices, mesh.faces, camera.resized(512), supersample=1)
    for size, tau in ((32, 1.0), (64, 0.7), (128, 0.6)):
        soft = SoftSilhouetteRenderer(camera, size, tau=tau).render(
            torch.tensor(mesh.vertices, dtype=torch.float64), torch.tensor(mesh.faces)).numpy()
        target = halo_target(fine, size, tau)
        assert np.abs(soft - target).mean() < 0.012, size


def test_gradients_match_finite_differences():
    camera, mesh = _scene()
    renderer = SoftSilhouetteRenderer(camera, 24, tau=1.0)
    faces = torch.tensor(mesh.faces)
    weights = torch.rand(24, 24, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    vertices = torch.tensor(mesh.vertices, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda v: (renderer.render(v, faces) * weights).sum(), (vertices,),
                                    eps=1e-6, atol=1e-5, rtol=1e-3)
    # and a hand-made central difference along one vertex coordinate, at a visible silhouette vertex
    loss = (renderer.render(vertices, faces) * weights).sum()
    (grad,) = torch.autograd.grad(loss, vertices)
    k = int(torch.argmax(grad.abs().sum(1)))
    assert float(grad[k].abs().max()) > 0
    for axis in range(3):
        step = torch.zeros_like(vertices)
        step[k, axis] = 1e-5
        with torch.no_grad():
            plus = (renderer.render(vertices + step, faces) * weights).sum()
            minus = (renderer.render(vertices - step, faces) * weights).sum()
        assert abs(float((plus - minus) / 2e-5) - float(grad[k, axis])) < 1e-4 * max(1.0, float(grad[k].abs().max()))
