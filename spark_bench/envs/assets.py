"""What the environments' ``asset`` argument may be, and the default cabinet.

``asset`` is an :class:`~spark_bench.asset.model.ArticulatedAsset`, an object folder, a URDF file, or a
benchmark case folder (its ground truth, brought back from the benchmark frame to the source object's
size in metres: :meth:`~spark_bench.data.case.BenchmarkCase.gt_at_source_size`); ``None`` is the default
cabinet: the ``synth`` generator's StorageFurniture object of :data:`DEFAULT_SEED` (generated once into
the cache) when that generator is installed, else the in-memory
:func:`~spark_bench.envs.cabinet.procedural_cabinet`.
"""

from __future__ import annotations

from pathlib import Path

from spark_bench.asset.joint_type import ROTATIONAL_TYPES, JointType
from spark_bench.asset.model import ArticulatedAsset
from spark_bench.data.case import BenchmarkCase
from spark_bench.errors import InputError

DEFAULT_SEED = 0
DEFAULT_NAME = "default_cabinet"

AssetLike = ArticulatedAsset | str | Path | None


def asset_folder(path: str | Path) -> Path:
    """The object folder or URDF file that ``path`` names: a benchmark case folder maps to its ground
    truth's folder."""
    path = Path(path).expanduser()
    if not path.exists():
        raise InputError(path, "no such object folder, URDF file or benchmark case")
    case = BenchmarkCase.of_folder(path)
    if case is not None:
        if not case.gt_dir.is_dir():
            raise InputError(path, f"benchmark case has no {case.gt_dir.name}/ object folder")
        return case.gt_dir
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
    return JointType.PRISMATIC in types and bool(types & ROTATIONAL_TYPES)


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
    loaded = load_object(folder)
    case = BenchmarkCase.of_gt_folder(folder)
    if case is not None:  # stored in the benchmark frame: a robot must open the real object, at its real size
        loaded = case.gt_at_source_size(loaded)[0]
    return loaded, str(folder.resolve())
