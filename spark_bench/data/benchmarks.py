"""Named benchmarks, built on first use into the cache (``$SPARK_BENCH_HOME/benchmarks/<name>``).

``synth-v1``: 50 procedural objects (``spark_bench.data.synth``, seed 0) over at least 20 categories,
prepared with the default :class:`~spark_bench.data.prepare.PrepareOptions` (512 px renders, R=200).

Building is safe to interrupt: the objects are generated into a temporary folder renamed into place,
the cases resume (each case is renamed into place when complete), and the benchmark counts as built
only when the marker file, written last, is there. A lock keeps two processes from building at once.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import asdict, dataclass, field
from pathlib import Path

from spark_bench.data.case import Benchmark
from spark_bench.data.prepare import PrepareOptions, bench_lock, prepare_benchmark
from spark_bench.data.readers import read_json
from spark_bench.errors import InputError, SparkBenchError
from spark_bench.paths import cache_dir

#: Written last into a built benchmark folder; its content says how the benchmark was made.
BUILT_MARKER = ".spark_bench_built.json"
OBJECTS_DIR = "objects"


@dataclass(frozen=True)
class BenchmarkSpec:
    """How a named benchmark is made.

    :param name: the benchmark name (folder name in the cache)
    :param n_objects: number of synth objects
    :param seed: seed of the synth generator
    :param min_categories: the generated objects must span at least this many categories
    :param options: prepare options
    """

    name: str
    n_objects: int
    seed: int = 0
    min_categories: int = 1
    options: PrepareOptions = field(default_factory=PrepareOptions)


BENCHMARKS: dict[str, BenchmarkSpec] = {
    "synth-v1": BenchmarkSpec("synth-v1", n_objects=50, seed=0, min_categories=20),
}
DEFAULT_BENCHMARK = "synth-v1"


def benchmark_spec(name: str) -> BenchmarkSpec:
    """The spec of a named benchmark (SparkBenchError naming the known ones otherwise)."""
    if name not in BENCHMARKS:
        raise SparkBenchError(f"unknown benchmark {name!r} (known: {', '.join(sorted(BENCHMARKS))})")
    return BENCHMARKS[name]


def benchmark_dir(name: str = DEFAULT_BENCHMARK) -> Path:
    """Where a named benchmark lives in the cache (it may not be built yet)."""
    return cache_dir("benchmarks") / name


def expected_marker(spec: BenchmarkSpec) -> dict:
    """What the built marker of ``spec`` must say; another content means a stale build."""
    from spark_bench.data.synth import GENERATOR_VERSION

    return {"name": spec.name, "n_objects": spec.n_objects, "seed": spec.seed,
            "generator_version": GENERATOR_VERSION, "options": asdict(spec.options)}


def _json_object(path: Path) -> dict | None:
    """A JSON object file of our own making; None when it is absent, malformed or not an object
    (the build it belongs to then counts as unfinished or stale, never as an error)."""
    try:
        found = read_json(path, default=None)
    except InputError:
        return None
    return found if isinstance(found, dict) else None


def is_built(folder: Path, spec: BenchmarkSpec | None = None) -> bool:
    """Whether ``folder`` holds a finished build (of ``spec``, when given)."""
    marker = Path(folder) / BUILT_MARKER
    if not marker.is_file():
        return False
    if spec is None:
        return True
    found, expected = _json_object(marker), expected_marker(spec)
    return found is not None and {k: found.get(k) for k in expected} == expected


def _is_stale(spec: BenchmarkSpec, folder: Path) -> bool:
    """A finished build of other settings, or generated objects of another generator version."""
    if (folder / BUILT_MARKER).is_file():
        return not is_built(folder, spec)
    from spark_bench.data.synth.generate import SYNTH_MANIFEST

    synth_manifest = folder / OBJECTS_DIR / SYNTH_MANIFEST
    if synth_manifest.is_file():
        found = _json_object(synth_manifest)
        return found is None or found.get("version") != expected_marker(spec)["generator_version"]
    return False


def _generate_objects(spec: BenchmarkSpec, folder: Path, progress: bool) -> Path:
    """The synth objects of ``spec`` in ``folder/objects`` (generated into a temp folder, renamed)."""
    objects = folder / OBJECTS_DIR
    if objects.is_dir():
        return objects
    from spark_bench.data.synth import generate_dataset

    partial = folder / f".{OBJECTS_DIR}.partial"
    if partial.exists():
        shutil.rmtree(partial)
    partial.mkdir(parents=True)
    generate_dataset(partial, spec.n_objects, seed=spec.seed, progress=progress)
    partial.rename(objects)
    return objects


def build_benchmark(spec: BenchmarkSpec, folder: Path, workers: int = 1, progress: bool = True) -> Path:
    """Generate and prepare ``spec`` into ``folder`` (resuming whatever is there); returns ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    bench = Benchmark(folder)
    objects = _generate_objects(spec, folder, progress)
    manifest = prepare_benchmark(objects, folder, options=spec.options, workers=workers, progress=progress,
                                 name=spec.name)
    if manifest["failed"]:
        first = next(iter(manifest["failed"].items()))
        raise SparkBenchError(f"benchmark {spec.name}: {len(manifest['failed'])} case(s) failed, "
                              f"e.g. {first[0]}: {first[1]} (see {bench.manifest_path})")
    categories = {bench.case(c).record.get("category") for c in manifest["cases"]}
    if len(manifest["cases"]) != spec.n_objects or len(categories) < spec.min_categories:
        raise SparkBenchError(f"benchmark {spec.name}: built {len(manifest['cases'])} cases over "
                              f"{len(categories)} categories, expected {spec.n_objects} over at least "
                              f"{spec.min_categories}")
    marker = {**expected_marker(spec), "categories": sorted(c for c in categories if c)}
    (folder / BUILT_MARKER).write_text(json.dumps(marker, indent=1) + "\n")
    return folder


def ensure_benchmark(name: str = DEFAULT_BENCHMARK, rebuild: bool = False, workers: int = 1,
                     progress: bool = True) -> Path:
    """The folder of a named benchmark, built on first use and reused after.

    :param name: a key of :data:`BENCHMARKS`
    :param rebuild: delete and rebuild it (a build of other settings or generator version is rebuilt anyway)
    :param workers: processes for the preparation
    :param progress: show progress bars while building
    """
    spec = benchmark_spec(name)
    folder = benchmark_dir(name)
    if is_built(folder, spec) and not rebuild:
        return folder
    with bench_lock(folder.parent / f".{name}.build", wait=True):
        if folder.exists() and (rebuild or _is_stale(spec, folder)):
            shutil.rmtree(folder)
        if not is_built(folder, spec):  # another process may have finished it while we waited
            build_benchmark(spec, folder, workers=workers, progress=progress)
    Benchmark(folder).manifest()  # a readable manifest, or an input error naming it
    return folder
