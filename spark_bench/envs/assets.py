"""What the environments' ``asset`` argument may be, and the default cabinet.

``asset`` is an :class:`~spark_bench.asset.model.ArticulatedAsset`, an object folder, a URDF file, or a
benchmark case folder (its ground truth ``gt/`` is used); ``None`` is the default cabinet: the ``synth``
generator's StorageFurniture object of :data:`DEFAULT_SEED` (generated once into the cache) when that
generator is installed, else the in-memory :func:`~spark_bench.envs.cabinet.procedural_cabinet`.
"""

from __future__ import annotations

from pathlib import Path

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
    try:
        from spark_bench.data.synth import generate_object
    except ImportError:
        return None
    return generate_object


def has_kinds(asset: ArticulatedAsset) -> bool:
    """Whether the asset has both a prismatic and a revolute joint (a cabinet for both environments)."""
    types = {j.type for j in asset.movable_joints()}
    return "prismatic" in types and bool(types & {"revolute", "continuous"})


def default_asset_path() -> Path | None:
    """The default cabinet's folder (generated on first use), or None without the synth generator.

    The first seed from :data:`DEFAULT_SEED` whose object has both a drawer and a door is used, so
    both environments run on the same cabinet.
    """
    generate = _synth_generator()
    if generate is None:
        return None
    from spark_bench.data import load_object
    from spark_bench.paths import cache_dir

    root = cache_dir("envs")
    marker = root / f"{DEFAULT_NAME}.txt"
    if marker.is_file():
        folder = Path(marker.read_text().strip())
        if (folder / "mobility.urdf").is_file():
            return folder
    for seed in range(DEFAULT_SEED, DEFAULT_SEED + 50):
        folder = Path(generate("StorageFurniture", seed, root, f"{DEFAULT_NAME}_{seed}"))
        if has_kinds(load_object(folder, load_meshes=False)):
            marker.write_text(str(folder))
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
    return load_object(folder), str(folder.resolve())
