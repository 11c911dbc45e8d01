"""Generate objects and datasets: sample a category's parameters, make every motion collision-free, write.

Each object is sampled from its seed alone, so a dataset is reproducible object by object: object
``i`` of a dataset with seed ``s`` has the seed :func:`object_seed` ``(s, i)`` and its category is
``categories[i % len(categories)]``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from spark_bench.asset.joint_type import JointType
from spark_bench.data.synth.clearance import find_overlaps, first_overlap, spec_pieces
from spark_bench.data.synth.spec import ObjectSpec
from spark_bench.data.synth.writer import GENERATOR_NAME, clean_json, write_object
from spark_bench.errors import InputError

#: Bumped whenever the same seed would give a different object.
GENERATOR_VERSION = "1.0"
#: The file :func:`generate_dataset` writes beside the objects, listing them.
SYNTH_MANIFEST = "synth_manifest.json"
MAX_ATTEMPTS = 8
#: Gap (m) the generator demands between parts that move relative to each other.
GENERATOR_TOLERANCE = 0.0005
SWEEP_SAMPLES = 9


class GenerationError(Exception):
    """A sampled object is infeasible (too small, or a part cannot move freely); the generator resamples."""


def _builders(table: str) -> dict[str, Callable[[np.random.Generator], ObjectSpec]]:
    """The category modules' builder tables named ``table`` (``BUILDERS`` or ``VARIANTS``), merged in order."""
    from spark_bench.data.synth import appliances, furniture, household

    out = {}
    for module in (furniture, appliances, household):
        out.update(getattr(module, table, {}))
    return out


BUILDERS = _builders("BUILDERS")
#: The categories a dataset draws round-robin (a named benchmark's objects follow this order).
CATEGORIES: tuple[str, ...] = tuple(BUILDERS)
#: Variants of a category, asked for by name (``TopLoadingWasher`` makes a ``WashingMachine``): kept out of
#: :data:`CATEGORIES` so that adding one never changes a named benchmark's objects.
VARIANTS = _builders("VARIANTS")


def object_seed(seed: int, index: int) -> int:
    """The seed of object ``index`` of a dataset generated with ``seed``."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1, dtype=np.uint32)[0])


def settle_limits(spec: ObjectSpec, tolerance: float = GENERATOR_TOLERANCE, samples: int = SWEEP_SAMPLES) -> None:
    """Make every part clear of the others at rest, at open and along each joint's sweep.

    While some checked configuration has an overlap, one joint that is displaced in it and moves one
    of the two overlapping links gets a smaller upper limit (one sample step below its value there),
    never below its ``min_upper``; joints held at open are shrunk before the joint being swept.

    :raises GenerationError: when the object cannot be made collision-free
    """
    pieces = spec_pieces(spec)
    hits = find_overlaps(pieces, spec.poses(spec.rest()), tolerance, "rest")
    if hits:
        raise GenerationError(f"parts overlap at rest: {hits[:3]}")
    movable = {p.name: p for p in spec.movable_parts()}
    for _ in range(3 * len(movable) + 5):
        joints = [(p.name, p.joint.lower, p.joint.open_value) for p in movable.values()]
        found = first_overlap(pieces, spec.poses, joints, tolerance, samples)
        if found is None:
            return
        name, config, hit = found
        swept = name.split("=", 1)[0] if "=" in name else None
        movers = [m for link in (hit.link_a, hit.link_b) for m in _movable_chain(spec, link)]
        displaced = [m for m in dict.fromkeys(movers)
                     if movable[m].joint.type != JointType.CONTINUOUS and config[m] > movable[m].joint.lower + 1e-9]
        displaced.sort(key=lambda m: m == swept)  # joints held open first
        for m in displaced:
            joint = movable[m].joint
            step = (joint.upper - joint.lower) / (samples - 1)
            new_upper = config[m] - step if m == swept else joint.upper - step
            if joint.min_upper is not None and new_upper >= joint.min_upper and new_upper > joint.lower:
                joint.upper = float(new_upper)
                break
        else:
            raise GenerationError(f"cannot clear {hit.link_a} / {hit.link_b} in {name} "
                                  f"(separation {hit.separation:.4f})")
    raise GenerationError("clearance repair did not converge")


def _movable_chain(spec: ObjectSpec, part_name: str) -> list[str]:
    """Movable joints (by child part name) on the path from ``part_name`` up to the body."""
    out = []
    part = spec.part(part_name)
    while part.joint is not None:
        if part.joint.movable:
            out.append(part.name)
        part = spec.part(part.parent)
    return out


def build_object(category: str, seed: int) -> tuple[ObjectSpec, int]:
    """Sample a collision-free object of ``category`` from ``seed``; returns it and the attempt that worked."""
    builder = BUILDERS.get(category) or VARIANTS.get(category)
    if builder is None:
        raise InputError(None, f"unknown synth category {category!r}; known: {', '.join(CATEGORIES + tuple(VARIANTS))}")
    if int(seed) < 0:
        raise InputError(None, f"seed must be non-negative, got {seed}")
    last = None
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng([int(seed), attempt])
        try:
            spec = builder(rng)
            settle_limits(spec)
        except (GenerationError, ValueError) as exc:
            last = exc
            continue
        return spec, attempt
    raise RuntimeError(f"{category} seed {seed}: no valid object in {MAX_ATTEMPTS} attempts; last problem: {last}")


def generate_object(category: str, seed: int, out: Path, object_id: str) -> Path:
    """Generate one object of ``category`` into the folder ``out / object_id``; returns that folder.

    :param category: one of :data:`CATEGORIES` or :data:`VARIANTS`
    :param seed: non-negative integer; the same seed gives the same bytes
    :param out: parent folder (created if missing)
    :param object_id: the object's folder name and URDF robot name
    """
    spec, attempt = build_object(category, seed)
    provenance = {"seed": int(seed), "attempt": attempt, "version": GENERATOR_VERSION}
    return write_object(spec, Path(out) / object_id, object_id, provenance)


def generate_dataset(out: Path, n: int, seed: int = 0, categories: Sequence[str] | None = None,
                     progress: bool = True) -> list[Path]:
    """Generate ``n`` objects into ``out``, round-robin over ``categories`` (all of them by default).

    Object ``i`` is ``out / f"{category}_{i:05d}"``, generated from :func:`object_seed` ``(seed, i)``.
    A ``synth_manifest.json`` lists them.

    :returns: the object folders, in index order
    """
    cats = tuple(categories) if categories else CATEGORIES
    unknown = [c for c in cats if c not in BUILDERS and c not in VARIANTS]
    if unknown:
        raise InputError(None, f"unknown synth categories {unknown}; known: {', '.join(CATEGORIES + tuple(VARIANTS))}")
    if n < 0:
        raise InputError(None, f"number of objects must be non-negative, got {n}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    from tqdm import tqdm

    folders, entries = [], []
    for index in tqdm(range(n), desc="synth objects", unit="obj", disable=not progress):
        category = cats[index % len(cats)]
        object_id = f"{category}_{index:05d}"
        s = object_seed(seed, index)
        folders.append(generate_object(category, s, out, object_id))
        entries.append({"id": object_id, "category": category, "seed": s})
    manifest = {"generator": GENERATOR_NAME, "version": GENERATOR_VERSION, "seed": int(seed), "n": int(n),
                "categories": list(cats), "objects": entries}
    (out / SYNTH_MANIFEST).write_text(json.dumps(clean_json(manifest), sort_keys=True, indent=2) + "\n")
    return folders
