"""Retrieval galleries: the objects a retrieval can return, each with a content hash.

Two kinds:

- the default procedural gallery ``synth-gallery-v1`` (:data:`DEFAULT_GALLERY`): every synth category,
  20 objects each, built on first use into ``$SPARK_BENCH_HOME/retrieval/galleries/<name>``. Its object
  seeds are checked to be disjoint from the seeds of every named benchmark's objects
  (:func:`check_disjoint`, run before generating and again on the seeds the generator wrote), so no
  benchmark case is ever in it;
- any folder of PartNet-Mobility-format object folders (``--method-args gallery=DIR``): every non-hidden sub-folder
  is an object (or ``DIR`` itself when it holds a URDF). Folders that are not objects are skipped and
  listed; a folder with no usable object at all is an :class:`~spark_bench.errors.InputError` naming it.

**Content hash** (:func:`object_content_hash`): SHA-256 over the files that define the object as
:func:`~spark_bench.data.readers.load_object` reads it: the URDF, the side files (``meta.json``,
``semantics.txt``, GAPartNet's annotation files) and every file the URDF references, with the material
libraries and textures those meshes reference; each by its path relative to the object folder and
the SHA-256 of its bytes. Other files (PartNet-Mobility's rendered images, point samples) do not count,
so a trimmed copy of a download hashes as the download does. Equal hashes mean the same object files;
a re-export of the same shape by another writer hashes differently (that is a copy, not a leak).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
from dataclasses import asdict, dataclass, field
from pathlib import Path

from spark_bench.errors import InputError, SparkBenchError

#: Files beside the URDF that :func:`~spark_bench.data.readers.load_object` reads.
SIDE_FILES = ("meta.json", "semantics.txt", "semantics_gapartnet.txt", "link_annotation_gapartnet.json")
#: Written last into a built synth gallery folder: the spec, the generator version, the object hashes.
BUILT_MARKER = ".spark_bench_gallery.json"
OBJECTS_DIR = "objects"
_URDF_REF = re.compile(rb'filename\s*=\s*"([^"]+)"')
_OBJ_REF = re.compile(rb"^\s*mtllib\s+(.+?)\s*$", re.MULTILINE)
_MTL_REF = re.compile(rb"^\s*(?:map_\w+|bump|disp|decal|norm)\s+(?:-\S+\s+\S+\s+)*(.+?)\s*$", re.MULTILINE)


# ----- content hashes --------------------------------------------------------------------------------
def _referenced(path: Path, data: bytes) -> list[str]:
    """File names a URDF, OBJ or MTL file refers to (relative to its own folder)."""
    suffix = path.suffix.lower()
    pattern = {".urdf": _URDF_REF, ".obj": _OBJ_REF, ".mtl": _MTL_REF}.get(suffix)
    if pattern is None:
        return []
    names = []
    for match in pattern.findall(data):
        name = match.decode("utf-8", errors="replace").strip()
        for prefix in ("package://", "file://"):
            if name.startswith(prefix):
                name = name[len(prefix):]
        names.append(name)
    return names


def object_content_hash(folder: str | Path) -> str:
    """SHA-256 (hex) of the files that define an object folder (see the module docstring).

    A referenced file that is missing or outside the folder counts by its name (so the hash is defined
    for a broken object too; loading it fails elsewhere).

    :param folder: an object folder (PartNet-Mobility layout) or its URDF file
    :raises InputError: naming ``folder`` when it holds no URDF
    """
    from spark_bench.data.readers import find_urdf

    urdf = find_urdf(folder)
    root = urdf.parent.resolve()
    entries: dict[str, str] = {}
    todo = [urdf.resolve()] + [root / name for name in SIDE_FILES if (root / name).is_file()]
    while todo:
        path = todo.pop()
        try:
            rel = path.relative_to(root).as_posix()
        except ValueError:
            entries[f"outside:{path.name}"] = "outside"
            continue
        if rel in entries:
            continue
        if not path.is_file():
            entries[rel] = "missing"
            continue
        data = path.read_bytes()
        entries[rel] = hashlib.sha256(data).hexdigest()
        for name in _referenced(path, data):
            todo.append((path.parent / name).resolve())
    digest = hashlib.sha256()
    for rel in sorted(entries):
        digest.update(f"{rel}\0{entries[rel]}\n".encode())
    return digest.hexdigest()


# ----- galleries ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GalleryObject:
    """One gallery object.

    :param id: the object's folder name
    :param folder: the object folder
    :param category: ``meta.json``'s ``model_cat`` (empty when absent)
    :param content_hash: :func:`object_content_hash` of the folder
    """

    id: str
    folder: Path
    category: str
    content_hash: str


@dataclass(frozen=True)
class Gallery:
    """The objects a retrieval may return.

    :param name: ``synth-gallery-v1`` for the default gallery, else the folder's name
    :param folder: the gallery folder
    :param objects: the usable objects, sorted by id
    :param skipped: sub-folders that are not objects, by name, with the reason
    """

    name: str
    folder: Path
    objects: tuple[GalleryObject, ...]
    skipped: dict[str, str] = field(default_factory=dict)

    @property
    def content_hash(self) -> str:
        """SHA-256 over the objects' ids, categories and content hashes: the key of the gallery's index."""
        digest = hashlib.sha256()
        for obj in self.objects:
            digest.update(f"{obj.id}\0{obj.category}\0{obj.content_hash}\n".encode())
        return digest.hexdigest()

    def with_hash(self, content_hash: str) -> GalleryObject | None:
        """The gallery object whose content hash is ``content_hash`` (None when there is none)."""
        return next((o for o in self.objects if o.content_hash == content_hash), None)

    def object(self, object_id: str) -> GalleryObject:
        return next(o for o in self.objects if o.id == object_id)

    def categories(self) -> dict[str, int]:
        """Number of objects per category."""
        out: dict[str, int] = {}
        for obj in self.objects:
            out[obj.category] = out.get(obj.category, 0) + 1
        return dict(sorted(out.items()))

    def describe(self) -> dict:
        """What the results say about the gallery."""
        return {"name": self.name, "folder": str(self.folder), "content_hash": self.content_hash,
                "objects": len(self.objects), "categories": self.categories(), "skipped": dict(self.skipped)}


def _category(folder: Path) -> str:
    try:
        meta = json.loads((folder / "meta.json").read_text())
    except (OSError, ValueError):
        return ""
    return str(meta.get("model_cat", "") or "") if isinstance(meta, dict) else ""


def _scan_object(folder: Path) -> GalleryObject:
    return GalleryObject(folder.name, folder, _category(folder), object_content_hash(folder))


def _stat_signature(folder: Path) -> tuple:
    """Every file's relative path, size and modification time: a cheap "has anything changed"."""
    out = []
    for dirpath, dirnames, filenames in os.walk(folder, followlinks=True):
        dirnames.sort()
        for name in sorted(filenames):
            path = Path(dirpath) / name
            try:
                stat = path.stat()
            except OSError:
                continue
            out.append((str(path.relative_to(folder)), stat.st_size, stat.st_mtime_ns))
    return tuple(out)


_FOLDER_GALLERIES: dict[tuple, Gallery] = {}


def folder_gallery(folder: str | Path, name: str | None = None) -> Gallery:
    """The gallery of a folder of object folders (hashes computed once per process while unchanged).

    :param folder: a folder of PartNet-Mobility-format object folders, or one object folder
    :param name: the gallery name (default: the folder's name)
    :raises InputError: naming ``folder`` when it is missing, empty, or holds no usable object
    """
    from spark_bench.data.readers import find_urdf

    folder = Path(folder).expanduser()
    if not folder.is_dir():
        raise InputError(folder, "gallery folder not found")
    key = (str(folder.resolve()), name, _stat_signature(folder))
    if key in _FOLDER_GALLERIES:
        return _FOLDER_GALLERIES[key]
    if any(folder.glob("*.urdf")):
        candidates = [folder]
    else:
        candidates = [p for p in sorted(folder.iterdir()) if p.is_dir() and not p.name.startswith(".")]
    if not candidates:
        raise InputError(folder, "empty gallery: no object folders (expected PartNet-Mobility-format "
                                 "folders, each with a mobility.urdf)")
    objects, skipped = [], {}
    for candidate in candidates:
        try:
            find_urdf(candidate)
            objects.append(_scan_object(candidate))
        except (InputError, OSError) as exc:
            skipped[candidate.name] = getattr(exc, "problem", None) or str(exc)
    if not objects:
        examples = "; ".join(f"{k}: {v}" for k, v in list(skipped.items())[:3])
        raise InputError(folder, f"broken gallery: none of its {len(candidates)} folder(s) is an object "
                                 f"({examples})")
    gallery = Gallery(name or folder.resolve().name, folder, tuple(objects), skipped)
    _FOLDER_GALLERIES[key] = gallery
    return gallery


# ----- the default procedural gallery ----------------------------------------------------------------
@dataclass(frozen=True)
class SynthGallerySpec:
    """A procedural gallery: ``per_category`` synth objects of every category.

    Object ``i`` is generated as :func:`~spark_bench.data.synth.generate.generate_dataset` makes object
    ``i`` of a dataset with seed ``seed`` (category ``categories[i % len(categories)]``, seed
    :func:`~spark_bench.data.synth.generate.object_seed` ``(seed, i)``).

    :param name: the gallery name (its folder name in the cache)
    :param seed: the dataset seed (never the seed of a named benchmark)
    :param per_category: objects per category
    :param categories: the categories (empty: every synth category)
    """

    name: str
    seed: int
    per_category: int = 20
    categories: tuple[str, ...] = ()

    def category_list(self) -> tuple[str, ...]:
        from spark_bench.data.synth.generate import CATEGORIES

        return tuple(self.categories) or CATEGORIES

    @property
    def n_objects(self) -> int:
        return self.per_category * len(self.category_list())


#: The default gallery. Its seed is not the seed of any named benchmark, and :func:`check_disjoint`
#: checks that no object seed is shared either.
DEFAULT_GALLERY = SynthGallerySpec("synth-gallery-v1", seed=14_000_001, per_category=20)


def gallery_seeds(spec: SynthGallerySpec) -> dict[str, int]:
    """The object seed of every object of ``spec``, by object id (as the generator names them)."""
    from spark_bench.data.synth.generate import object_seed

    cats = spec.category_list()
    return {f"{cats[i % len(cats)]}_{i:05d}": object_seed(spec.seed, i) for i in range(spec.n_objects)}


def benchmark_seeds() -> dict[int, str]:
    """The object seed of every object of every named synth benchmark (``BENCHMARKS``), with where it is used
    (a listed benchmark of real objects generates nothing)."""
    from spark_bench.data.benchmarks import BENCHMARKS
    from spark_bench.data.synth.generate import object_seed

    out: dict[int, str] = {}
    for name, bench in BENCHMARKS.items():
        if bench.is_listed:
            continue
        for i in range(bench.n_objects):
            out.setdefault(object_seed(bench.seed, i), f"{name} object {i}")
    return out


def check_disjoint(seeds) -> None:
    """Refuse gallery object seeds that a named benchmark also uses.

    :param seeds: object seeds (an iterable of ints, or a dict id -> seed)
    :raises SparkBenchError: naming the first shared seed and the benchmark object that has it
    """
    values = seeds.values() if isinstance(seeds, dict) else seeds
    used = benchmark_seeds()
    shared = sorted({int(s) for s in values} & set(used))
    if shared:
        raise SparkBenchError(f"gallery seeds overlap the named benchmarks' objects: seed {shared[0]} is "
                              f"{used[shared[0]]} ({len(shared)} shared seed(s))")


def synth_gallery_dir(spec: SynthGallerySpec = DEFAULT_GALLERY) -> Path:
    """Where a procedural gallery lives in the cache (it may not be built yet)."""
    from spark_bench.paths import cache_dir

    return cache_dir("retrieval") / "galleries" / spec.name


def _expected_marker(spec: SynthGallerySpec) -> dict:
    from spark_bench.data.synth import GENERATOR_VERSION

    return {"spec": {**asdict(spec), "categories": list(spec.category_list())},
            "generator_version": GENERATOR_VERSION}


def _read_marker(folder: Path, spec: SynthGallerySpec) -> dict | None:
    try:
        found = json.loads((folder / BUILT_MARKER).read_text())
    except (OSError, ValueError):
        return None
    expected = _expected_marker(spec)
    if not isinstance(found, dict) or any(found.get(k) != v for k, v in expected.items()):
        return None
    if not isinstance(found.get("objects"), dict):
        return None
    return found


def _generated_seeds(objects: Path) -> dict[str, int]:
    """The seed each generated object's ``meta.json`` says it was made from, by object id.

    :raises SparkBenchError: for an object whose ``meta.json`` gives no seed
    """
    out = {}
    for folder in sorted(p for p in objects.iterdir() if p.is_dir()):
        try:
            out[folder.name] = int(json.loads((folder / "meta.json").read_text())["generator"]["seed"])
        except (OSError, ValueError, KeyError, TypeError):
            raise SparkBenchError(f"{folder}: generated object without a seed in meta.json") from None
    return out


def build_synth_gallery(spec: SynthGallerySpec, folder: Path, workers: int = 1) -> dict:
    """Generate ``spec`` into ``folder/objects`` and write the built marker; returns the marker.

    Checks the seeds twice: the planned ones before generating, and the ones the generated objects'
    ``meta.json`` say they were made from.

    :param workers: processes generating objects
    :raises SparkBenchError: when a seed is shared with a named benchmark
    """
    from spark_bench.data.synth import GENERATOR_VERSION
    from spark_bench.data.synth.generate import SYNTH_MANIFEST, generate_object

    planned = gallery_seeds(spec)
    check_disjoint(planned)
    folder.mkdir(parents=True, exist_ok=True)
    partial = folder / f".{OBJECTS_DIR}.partial"
    if partial.exists():
        shutil.rmtree(partial)
    partial.mkdir()
    jobs = [(object_id.rsplit("_", 1)[0], seed, partial, object_id) for object_id, seed in planned.items()]
    if workers > 1 and len(jobs) > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            list(pool.map(generate_object, *zip(*jobs, strict=True), chunksize=8))
    else:
        for job in jobs:
            generate_object(*job)
    manifest = {"generator": "spark_bench.data.synth", "version": GENERATOR_VERSION, "seed": spec.seed,
                "n": spec.n_objects, "categories": list(spec.category_list()),
                "objects": [{"id": i, "category": i.rsplit("_", 1)[0], "seed": s} for i, s in planned.items()]}
    (partial / SYNTH_MANIFEST).write_text(json.dumps(manifest, sort_keys=True, indent=2) + "\n")
    written = _generated_seeds(partial)
    if written != planned:
        raise SparkBenchError(f"{partial}: the generated objects are not the planned ones")
    check_disjoint(written)
    objects = folder / OBJECTS_DIR
    if objects.exists():
        shutil.rmtree(objects)
    partial.rename(objects)
    hashes = {p.name: {"category": _category(p), "content_hash": object_content_hash(p)}
              for p in sorted(objects.iterdir()) if p.is_dir()}
    marker = {**_expected_marker(spec), "objects": hashes, "seeds": written}
    (folder / BUILT_MARKER).write_text(json.dumps(marker, indent=1, sort_keys=True) + "\n")
    return marker


def synth_gallery(spec: SynthGallerySpec = DEFAULT_GALLERY, workers: int = 1, rebuild: bool = False) -> Gallery:
    """A procedural gallery, built on first use into the cache and reused after.

    :param spec: which gallery (default: ``synth-gallery-v1``)
    :param workers: processes for the first build
    :param rebuild: delete and rebuild it (a build of another spec or generator version is rebuilt anyway)
    """
    from spark_bench.data.prepare import bench_lock

    folder = synth_gallery_dir(spec)
    marker = None if rebuild else _read_marker(folder, spec)
    if marker is None:
        with bench_lock(folder.parent / f".{spec.name}.build", wait=True):
            marker = None if rebuild else _read_marker(folder, spec)
            if marker is None:
                if (folder / BUILT_MARKER).exists():
                    (folder / BUILT_MARKER).unlink()
                marker = build_synth_gallery(spec, folder, workers)
    objects = folder / OBJECTS_DIR
    items = tuple(GalleryObject(i, objects / i, str(v["category"]), str(v["content_hash"]))
                  for i, v in sorted(marker["objects"].items()))
    return Gallery(spec.name, folder, items)


class GalleryLeakError(InputError):
    """The gallery holds the very object a benchmark case was made from."""


def source_check(record: dict, gallery: Gallery) -> dict:
    """Refuse a gallery that holds a case's own object; say how that was checked.

    The case's object is identified by content hash: ``record["source_hash"]`` when the case record has
    one, else :func:`object_content_hash` of the folder ``record["source"]`` (where the case was
    prepared from), compared with every gallery object's hash. Only the source's file hashes are read,
    never its geometry. When neither is available (a case prepared elsewhere, a procedural test case)
    the check cannot be made: the returned record says ``unchecked`` and why.

    :param record: the case record (``case.json``)
    :param gallery: the gallery
    :returns: ``{"status": "passed" | "unchecked", ...}`` for the results
    :raises GalleryLeakError: naming the gallery folder and the object when the hashes match
    """
    case_id = str(record.get("id", "?"))
    source_hash, how = record.get("source_hash"), "case.json source_hash"
    source = record.get("source")
    if not source_hash and isinstance(source, str) and source:
        try:
            source_hash, how = object_content_hash(source), f"content hash of the case's source {source}"
        except (InputError, OSError):
            source_hash = None
    if not source_hash:
        return {"status": "unchecked", "case": case_id, "gallery_objects": len(gallery.objects),
                "reason": f"the case's source object ({source!r}) is not available here to hash"}
    found = gallery.with_hash(str(source_hash))
    if found is not None:
        raise GalleryLeakError(gallery.folder, f"holds case {case_id}'s own object (gallery object {found.id}, "
                                               f"content hash {str(source_hash)[:16]}); a retrieval gallery "
                                               f"must not contain the benchmark's objects")
    return {"status": "passed", "case": case_id, "case_source_hash": str(source_hash), "how": how,
            "gallery_objects": len(gallery.objects)}


def open_gallery(gallery: str | Path | None = None, workers: int = 1) -> Gallery:
    """The default gallery (``None`` or its name) or the gallery folder ``gallery``."""
    if gallery is None or str(gallery) in ("", DEFAULT_GALLERY.name):
        return synth_gallery(DEFAULT_GALLERY, workers=workers)
    return folder_gallery(gallery)


__all__ = ["DEFAULT_GALLERY", "Gallery", "GalleryLeakError", "GalleryObject", "SynthGallerySpec", "benchmark_seeds",
           "build_synth_gallery", "check_disjoint", "folder_gallery", "gallery_seeds", "object_content_hash",
           "open_gallery", "source_check", "synth_gallery", "synth_gallery_dir"]
