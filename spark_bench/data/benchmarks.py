"""Named benchmarks, built on first use into the cache (``$SPARK_BENCH_HOME/benchmarks/<name>``).

``synth-v1``: 50 procedural objects (``spark_bench.data.synth``, seed 0) over at least 20 categories,
prepared with the default :class:`~spark_bench.data.prepare.PrepareOptions` (512 px renders, R=200).

Listed benchmarks: the field's named test splits, the PartNet-Mobility ids each method publishes
(:mod:`spark_bench.data.splits`: ``spark-test``, the SPARK paper's own 42 test objects, seen by SPARK's
camera; ``singapo-test``, ``cage-test``, ``freeart3d-test``, ``physx-anything-test``, ``real2code-test``),
each with the file and commit its ids were read from and the camera its method states. Their meshes
cannot be shipped: :func:`prepare_listed` prepares the ones found in a user's PartNet-Mobility download
(``spark-bench data prepare --src DIR --bench NAME``) and lists the others as missing.

Building is safe to interrupt: the objects are generated into a temporary folder renamed into place,
the cases resume (each case is renamed into place when complete), and the benchmark counts as built
only when the marker file, written last, is there. A lock keeps two processes from building at once.
"""

from __future__ import annotations

import json
import logging
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.data.case import Benchmark
from spark_bench.data.prepare import PrepareOptions, bench_lock, find_objects, prepare_benchmark
from spark_bench.data.readers import read_json
from spark_bench.data.splits import SPARK_TEST_IDS as SPARK_TEST_IDS  # re-exported: spark-test's ids
from spark_bench.data.splits import SPARK_TEST_VIEW, SPLITS, Split, View
from spark_bench.errors import InputError, SparkBenchError
from spark_bench.paths import cache_dir

logger = logging.getLogger(__name__)

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
    :param ids: the object ids of a benchmark of listed real objects (prepared from the user's download
        with :func:`prepare_listed`, never generated); empty for a synth benchmark
    :param source: where a listed benchmark's ids come from (``owner/repo:path@commit``, see
        :class:`~spark_bench.data.splits.Split`); written into its manifest
    """

    name: str
    n_objects: int
    seed: int = 0
    min_categories: int = 1
    options: PrepareOptions = field(default_factory=PrepareOptions)
    ids: tuple[str, ...] = ()
    source: str = ""

    @property
    def is_listed(self) -> bool:
        """Whether this benchmark is a list of real objects the user provides."""
        return bool(self.ids)


def view_options(view: View) -> PrepareOptions:
    """The prepare options of a split's camera (the other options at their defaults)."""
    return PrepareOptions(fov_deg=view.fov_deg, distance=view.distance, azimuth_deg=view.azimuth_deg,
                          elevation_deg=view.elevation_deg)


def listed_spec(split: Split) -> BenchmarkSpec:
    """The listed benchmark of a published test split."""
    return BenchmarkSpec(split.name, n_objects=len(split.ids), options=view_options(split.view),
                         ids=split.ids, source=split.source)


#: SPARK's camera for ``spark-test`` (``datasets/preprocess/render.py``: radius 4, 40 degree field of view,
#: azimuth 0 and elevation 0 of its mesh frame, our front view, level). Its 2048 px renders become the
#: benchmark's default 512 px (``--image-size`` changes it).
SPARK_VIEW = view_options(SPARK_TEST_VIEW)

BENCHMARKS: dict[str, BenchmarkSpec] = {
    "synth-v1": BenchmarkSpec("synth-v1", n_objects=50, seed=0, min_categories=20),
    **{name: listed_spec(split) for name, split in SPLITS.items()},
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
            "generator_version": GENERATOR_VERSION, "options": spec.options.to_json()}


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


def is_stale(spec: BenchmarkSpec, folder: Path) -> bool:
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


def build_benchmark(spec: BenchmarkSpec, folder: Path, workers: int = 1, progress: bool = True,
                    isolate: bool = False) -> Path:
    """Generate and prepare ``spec`` into ``folder`` (resuming whatever is there); returns ``folder``.

    :param isolate: render in spawned processes only (:func:`~spark_bench.data.prepare.prepare_benchmark`)
    """
    folder.mkdir(parents=True, exist_ok=True)
    bench = Benchmark(folder)
    objects = _generate_objects(spec, folder, progress)
    manifest = prepare_benchmark(objects, folder, options=spec.options, workers=workers, progress=progress,
                                 name=spec.name, isolate=isolate)
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
                     progress: bool = True, isolate: bool = False) -> Path:
    """The folder of a named benchmark, built on first use and reused after. A benchmark of listed real
    objects (``spark-test``, ``singapo-test``...) is never built here: it must have been prepared into the
    cache from the user's download (:func:`prepare_listed` with its default ``out``).

    :param name: a key of :data:`BENCHMARKS`
    :param rebuild: delete and rebuild it (a build of other settings or generator version is rebuilt anyway)
    :param workers: processes for the preparation
    :param progress: show progress bars while building
    :param isolate: a build renders in spawned processes only, so that this process opens no OpenGL
        context (:func:`~spark_bench.data.prepare.prepare_benchmark`; ``eval`` forks workers after it)
    """
    spec = benchmark_spec(name)
    folder = benchmark_dir(name)
    if spec.is_listed:
        bench = Benchmark(folder)
        if not bench.exists or not bench.case_ids():
            raise SparkBenchError(f"benchmark {name} is made from your PartNet-Mobility download: run "
                                  f"`spark-bench data prepare --src PARTNET_MOBILITY_DIR --bench {name}` first "
                                  f"(it is prepared into {folder})")
        stored = bench.manifest().get("options")
        if stored is not None and stored != spec.options.to_json():
            # used as it is (its cases are consistent with its own manifest), but said: the images of an
            # earlier build (the remesh renders before the source default) are not what the docs describe
            logger.warning("benchmark %s in %s was prepared with other options than its spec's (%s, now %s); "
                           "`spark-bench data prepare --src PARTNET_MOBILITY_DIR --bench %s --overwrite` "
                           "prepares it again", name, folder, stored, spec.options.to_json(), name)
        return folder
    if is_built(folder, spec) and not rebuild:
        return folder
    with bench_lock(folder.parent / f".{name}.build", wait=True):
        if folder.exists() and (rebuild or is_stale(spec, folder)):
            shutil.rmtree(folder)
        if not is_built(folder, spec):  # another process may have finished it while we waited
            build_benchmark(spec, folder, workers=workers, progress=progress, isolate=isolate)
    Benchmark(folder).manifest()  # a readable manifest, or an input error naming it
    return folder


@dataclass
class ListedResult:
    """What :func:`prepare_listed` did.

    :param manifest: the benchmark's manifest
    :param found: listed ids found in the source, in list order
    :param missing: listed ids not found in the source, in list order
    :param folder: the benchmark folder
    """

    manifest: dict
    found: list[str]
    missing: list[str]
    folder: Path

    @property
    def prepared(self) -> list[str]:
        """Listed ids that are complete cases of the benchmark."""
        return [i for i in self.found if i in self.manifest["cases"]]


def prepare_listed(spec: BenchmarkSpec, src: str | Path, out: str | Path | None = None,
                   options: PrepareOptions | None = None, workers: int = 1, progress: bool = True,
                   overwrite: bool = False) -> ListedResult:
    """Prepare the listed objects of ``spec`` found under ``src`` (a PartNet-Mobility download: one folder
    per object id) into a benchmark folder, one case per id; ids not found are skipped and reported (in the
    result and the manifest's ``missing``), an object that fails is recorded in the manifest's ``failed``.

    :param spec: a listed benchmark (``spark-test``, ``singapo-test``, ...)
    :param src: the folder of object folders
    :param out: the benchmark folder (default: the cache's, where ``eval --bench NAME`` finds it)
    :param options: prepare options (default: the spec's, e.g. SPARK's camera for ``spark-test``)
    :param workers: processes
    :param progress: show a progress bar
    :param overwrite: rebuild complete cases too
    :raises SparkBenchError: when ``spec`` is not a listed benchmark or no listed object is in ``src``
    """
    if not spec.is_listed:
        raise SparkBenchError(f"benchmark {spec.name} is generated, not listed: build it with "
                              f"`spark-bench data build {spec.name}`")
    available = find_objects(src)
    found = [i for i in spec.ids if i in available]
    missing = [i for i in spec.ids if i not in available]
    if not found:
        raise SparkBenchError(f"{src}: none of the {len(spec.ids)} objects of {spec.name} is there (expected "
                              f"PartNet-Mobility folders named by id, e.g. {spec.ids[0]}/mobility.urdf)")
    out = Path(out) if out is not None else benchmark_dir(spec.name)
    manifest = prepare_benchmark(src, out, ids=found, options=options or spec.options, workers=workers,
                                 progress=progress, name=spec.name, overwrite=overwrite)
    manifest = Benchmark(out).write_manifest({**manifest, "listed": list(spec.ids), "missing": missing,
                                              "source": spec.source})
    return ListedResult(manifest, found, missing, out)
