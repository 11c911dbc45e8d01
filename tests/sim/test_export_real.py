"""Round trips of the shared real objects (skipped where ``../shared/real_objects`` is absent): each object's
URDF -> sim-ready USD -> the USD reader, and -> ``model.xml`` -> the MJCF reader, gives the same object: every
joint matched with its type, axis and pivot, the shapes at rest and open the same within sampling (CoACD
runs once per object, then comes from the cache)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from helpers_real import REAL_IDS

from spark_bench.data.readers import load_object
from spark_bench.metrics.evaluate import compute_metrics
from spark_bench.sim.export import export
from spark_bench.sim.options import ConvertOptions

pytest.importorskip("pxr")

#: MuJoCo's XML writer keeps 6 significant digits: model.xml's axes and pivots are that close.
ANGLE_TOL = 1e-4
#: Samples per shape: the Chamfer distance of a surface against itself resampled is the noise floor.
SAMPLES = 20_000


def resampled(asset):
    """The same surfaces with their faces in another order: sampled elsewhere, the noise floor of the metrics."""
    out = asset.copy()
    rng = np.random.default_rng(1)
    for link in out.links.values():
        for visual in link.visuals:
            faces = np.asarray(visual.mesh.faces)
            visual.mesh = trimesh.Trimesh(visual.mesh.vertices, faces[rng.permutation(len(faces))], process=False)
    return out


@pytest.mark.slow
@pytest.mark.real
@pytest.mark.parametrize("object_id", REAL_IDS)
def test_real_object_round_trips_through_usd_and_mjcf(real_object, object_id, tmp_path):
    original = load_object(real_object(object_id))
    written = export(original, tmp_path, "usd", ConvertOptions())
    floor = compute_metrics(resampled(original), original, n_samples=SAMPLES, n_match_samples=5_000, workers=1)
    size = float(np.linalg.norm(np.ptp(original.bounds(), axis=0)))
    for path in (written.model, written.mjcf):
        back = load_object(path)
        assert back.bounds(back.open_configuration()) == pytest.approx(
            original.bounds(original.open_configuration()), abs=1e-5 * size)
        result = compute_metrics(back, original, n_samples=SAMPLES, n_match_samples=5_000, workers=1)
        assert not result.missing_joints and not result.extra_joints, path.name
        assert len(result.matches) == len(original.movable_joints())
        for match in result.matches:
            assert match.type_match and match.axis_err < ANGLE_TOL, (path.name, match.to_dict())
            assert match.pivot_err is None or match.pivot_err < ANGLE_TOL, (path.name, match.to_dict())
        for state in ("rest", "open"):  # 0 within sampling: no farther than the surface from itself resampled
            cd, noise = getattr(result, state).cd, getattr(floor, state).cd
            assert cd < 1.5 * noise + 1e-6, (path.name, state, cd, noise)
