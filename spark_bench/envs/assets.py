"""What the environments' ``asset`` argument may be, and the default cabinet.

``asset`` is an :class:`~spark_bench.asset.model.ArticulatedAsset`, an object folder, a URDF file, or a
benchmark case folder (its ground truth ``gt/``, brought back from the benchmark frame to the source
object's size in metres with ``case.json``'s normalization); ``None`` is the default cabinet: the ``synth``
generator's StorageFurniture object of :data:`DEFAULT_SEED` (generated once into the cache) when that
generator is installed, else the in-memory :func:`~spark_bench.envs.cabinet.procedural_cabinet`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.errors import InputError

DEFAULT_SEED = 0
DEFAULT_NAME = "default_cabinet"

AssetLike = ArticulatedAsset | str | Path | None


def asset_folder(path: str | Path) -> Path:
    """The object folder or URDF file that ``path`` names: a benchmark case folder maps to its ``gt/``."""
    path = Path(path).expanduser()
    if not path.exists():
        raise InputError(path, "no such object folder, URDF file or benchmark case")
    if path.is_dir() and (path / "case.json").is_file():
        gt = path / "gt"
        if not gt.is_dir():
            raise InputError(path, "benchmark case has no gt/ object folder")
        return gt
    return path


def _synth_generator():
    """The synth generator's ``generate_object`` and its version, or None when it is not installed."""
    try:
        from spark_bench.data.synth import GENERATOR_VERSION, generate_object
    except ImportError:
        return None
    return generate_object, GENERATOR_VERSION


def has_kinds(asset: ArticulatedAsset) -> bool:
    """Whether the asset has both a prismatic and a revolute joint (a cabinet for both environments)."""
    types = {j.type for j in asset.movable_joints()}
    return "prismatic" in types and bool(types & {"revolute", "continuous"})


def default_asset_path() -> Path | None:
    """The default cabinet's folder (generated on first use), or None without the synth generator.

    The first seed from :data:`DEFAULT_SEED` whose object has both a drawer and a door is used, so
    both environments run on the same cabinet. The cache is kept per generator version (a marker file
    names the folder), so a new generator regenerates it.
    """
    generator = _synth_generator()
    if generator is None:
        return None
    generate, version = generator
    from spark_bench.data import load_object
    from spark_bench.paths import cache_dir

    root = cache_dir("envs")
    marker = root / f"{DEFAULT_NAME}_v{version}.txt"
    if marker.is_file():
        folder = root / marker.read_text().strip()
        if (folder / "mobility.urdf").is_file():
            return folder
    for seed in range(DEFAULT_SEED, DEFAULT_SEED + 50):
        folder = Path(generate("StorageFurniture", seed, root, f"{DEFAULT_NAME}_{seed}"))
        if has_kinds(load_object(folder, load_meshes=False)):
            marker.write_text(folder.name)
            return folder
    return None


def asset_key(asset: AssetLike) -> str | None:
    """A stable name for ``asset`` (a resolved path or ``procedural:<seed>``); None for an in-memory asset."""
    if isinstance(asset, ArticulatedAsset):
        return None
    if asset is None:
        folder = default_asset_path()
        return str(folder.resolve()) if folder is not None else f"procedural:{DEFAULT_SEED}"
    if isinstance(asset, str) and asset.startswith("procedural:"):
        return asset
    return str(asset_folder(asset).resolve())


def load_asset(asset: AssetLike) -> tuple[ArticulatedAsset, str]:
    """The asset and a key naming it (a resolved path, or ``""`` for an in-memory asset).

    :param asset: see the module docstring
    """
    if isinstance(asset, ArticulatedAsset):
        return asset, ""
    if asset is None:
        folder = default_asset_path()
        if folder is None:
            from spark_bench.envs.cabinet import procedural_cabinet

            return procedural_cabinet(DEFAULT_SEED), f"procedural:{DEFAULT_SEED}"
        asset = folder
    if isinstance(asset, str) and asset.startswith("procedural:"):
        from spark_bench.envs.cabinet import procedural_cabinet

        try:
            seed = int(asset.split(":", 1)[1])
        except ValueError:
            raise InputError(None, f"asset {asset!r}: expected procedural:<integer seed>") from None
        return procedural_cabinet(seed), asset
    from spark_bench.data import load_object

    folder = asset_folder(asset)
    return at_source_size(load_object(folder), folder)[0], str(folder.resolve())


def at_source_size(asset: ArticulatedAsset, folder: str | Path) -> tuple[ArticulatedAsset, np.ndarray]:
    """``(asset, 4x4 from its files' frame to metres)`` for the asset read from object folder ``folder``.

    A benchmark case's ground truth (a ``gt/`` folder beside ``case.json``) is stored normalized to
    [-1, 1]^3, and a robot must open the real object, not one scaled to two metres: it comes back (as a
    copy) at its source's size and place with ``case.json``'s normalization. Any other asset is returned
    as is, with the identity.
    """
    folder = Path(folder)
    if folder.name != "gt" or not (folder.parent / "case.json").is_file():
        return asset, np.eye(4)
    from spark_bench.asset.ops import similarity_asset
    from spark_bench.data.readers import case_to_source_frame

    to_source = case_to_source_frame(folder.parent)
    return similarity_asset(asset, to_source), to_source
