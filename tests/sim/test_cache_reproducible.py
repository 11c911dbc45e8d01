"""A first run (caches filled), a later run (caches read) and a run without caches build the same model, to the
last bit: the collision shapes and contact decisions are used as the cache gives them back
(:func:`spark_bench.sim.shape_cache.as_cached`). Before, a first run simulated shapes ``x`` and every later
one ``x / size * size``; contact-rich episodes diverge from such a difference (35 of 221 scripted episodes
changed between a cold and a warm run)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers_assets import tiny_cabinet

from spark_bench.envs.cabinet import procedural_cabinet
from spark_bench.sim.mjcf import build_spec, prepare
from spark_bench.sim.options import ConvertOptions
from spark_bench.sim.shape_cache import as_cached

FIELDS = ("geom_size", "geom_pos", "geom_quat", "mesh_vert", "body_mass", "body_inertia", "body_ipos",
          "dof_damping", "dof_frictionloss")


def model_arrays(asset, use_cache: bool) -> dict[str, np.ndarray]:
    prepared = prepare(asset, ConvertOptions(use_cache=use_cache, workers=1))
    model = build_spec(asset, prepared=prepared, visuals=False).compile()
    return {name: np.array(getattr(model, name)) for name in FIELDS}


@pytest.mark.parametrize("make", [tiny_cabinet, lambda: procedural_cabinet(seed=4)], ids=["tiny", "procedural"])
def test_cold_warm_and_uncached_runs_build_the_same_model(make, isolated_home):
    asset = make()
    cold = model_arrays(asset, use_cache=True)
    warm = model_arrays(asset, use_cache=True)
    uncached = model_arrays(asset, use_cache=False)
    for name in FIELDS:
        assert np.array_equal(cold[name], warm[name]), f"{name}: the cache changed the model"
        assert np.array_equal(cold[name], uncached[name]), f"{name}: the model depends on the cache setting"


def test_as_cached_is_what_storing_and_loading_gives(tmp_path):
    from spark_bench.sim.hulls import CollisionShape
    from spark_bench.sim.shape_cache import load_shapes, store_shapes

    rng = np.random.default_rng(0)
    origin = np.eye(4)
    origin[:3, 3] = rng.normal(size=3)
    shape = CollisionShape("mesh", "hull", origin=origin, size=rng.uniform(0.01, 0.3, 3),
                           vertices=rng.normal(size=(20, 3)) * 0.37, faces=np.zeros((0, 3), np.int64))
    size = 1.7320508075688772
    store_shapes(tmp_path, "k" * 64, [shape], size)
    (loaded,) = load_shapes(tmp_path, "k" * 64, size)
    (rounded,) = as_cached([shape], size)
    for field in ("origin", "size", "vertices"):
        assert np.array_equal(getattr(loaded, field), getattr(rounded, field))
    assert not np.array_equal(rounded.vertices, shape.vertices)  # the round trip is not the identity
