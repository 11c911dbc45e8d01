"""The ``retrieval`` method: render-and-compare retrieval from a gallery of articulated objects.

The classic single-view baseline (URDFormer's template retrieval, Articulate-Anything's mesh
retrieval): it sees the input image and the camera only, and returns the whole gallery object whose
renders best explain the image, with its parts, joints, limits and semantics, turned about the up
axis to match the image and placed in the benchmark frame (:mod:`spark_bench.methods.retrieval.search`).
Nothing of the ground truth is an input: the object's silhouette comes from the image itself.

Gallery: the default procedural gallery ``synth-gallery-v1`` (every synth category, 20 objects each,
seeds disjoint from every named benchmark's), or any folder of PartNet-Mobility-format objects
(option ``gallery``: ``--method-args gallery=DIR``).

**The gallery never holds the case's own object.** The case record names the object folder the case
was prepared from (``source``; provenance, not an input); its content hash
(:func:`~spark_bench.methods.retrieval.gallery.object_content_hash`) is compared with every gallery object's,
and a match fails the case with an error naming the gallery (:func:`~spark_bench.methods.retrieval.gallery.source_check`).
Every result says how the check went (``info["gallery_check"]``: ``passed``, or ``unchecked`` with the
reason when the source is not on this machine).

Output per case: the object folder (``mobility.urdf`` + meshes) and ``retrieval.json`` (gallery, object
id, category, content hash, matched view, yaw, scale, score, pose, runners-up, timings).
"""

from __future__ import annotations

from pathlib import Path

from spark_bench.methods.base import CaseInput, Generation, NotPreparedError, regime_of
from spark_bench.methods.options import MethodOption
from spark_bench.methods.registry import register_method
from spark_bench.methods.retrieval.gallery import DEFAULT_GALLERY, Gallery, open_gallery, source_check
from spark_bench.methods.retrieval.index import gallery_index
from spark_bench.methods.retrieval.search import RECORD_FILE, SearchOptions, retrieve, write_retrieval

#: Processes that build the default gallery and a gallery's index on first use.
BUILD_WORKERS = 2


@register_method("retrieval")
class RetrievalMethod:
    """``--method retrieval`` (options: ``gallery``, a folder; default ``synth-gallery-v1``).

    :param gallery: a gallery folder, or None (or ``synth-gallery-v1``) for the default gallery
    :param options: search options
    """

    name = "retrieval"
    version = "1"
    inputs = ("image", "camera")
    regime = regime_of(inputs)
    accepts = {"gallery": MethodOption("a folder of PartNet-Mobility objects (default: synth-gallery-v1)", "path")}

    def __init__(self, gallery: str | Path | None = None, options: SearchOptions | None = None):
        default = gallery is None or str(gallery) in ("", DEFAULT_GALLERY.name)
        self.gallery_folder = None if default else str(Path(gallery).expanduser().resolve())
        self.options = options or SearchOptions()
        self._gallery: Gallery | None = None
        self._prepared = False

    @classmethod
    def from_options(cls, options: dict) -> RetrievalMethod:
        """From registry options: ``gallery`` (folder or ``synth-gallery-v1``)."""
        return cls(options.get("gallery"))

    @property
    def gallery(self) -> Gallery:
        """The gallery (the default one is built on first use; a folder is hashed once per process)."""
        if self._gallery is None:
            self._gallery = open_gallery(self.gallery_folder, workers=BUILD_WORKERS)
        return self._gallery

    @property
    def gallery_name(self) -> str:
        return DEFAULT_GALLERY.name if self.gallery_folder is None else Path(self.gallery_folder).name

    def label(self) -> str:
        return f"retrieval (gallery={self.gallery_name})"

    def prepare(self) -> None:
        """Open the gallery and build its index: the default gallery is generated and the index built on
        first use (:data:`BUILD_WORKERS` spawned processes; this process opens no OpenGL context, so the
        runner may fork its workers after), once, not in every worker at once."""
        if not self._prepared:
            gallery_index(self.gallery, self.options.index, workers=BUILD_WORKERS, isolate=True)
            self._prepared = True

    def config(self) -> dict:
        """The gallery (name, folder, content hash) and the search options.

        :raises NotPreparedError: before :meth:`prepare` (the content hash is the built gallery's)
        """
        if not self._prepared:
            raise NotPreparedError("retrieval: call prepare() before config() (the gallery's content hash is "
                                   "known once the gallery is built)")
        return {"gallery": self.gallery_name, "gallery_folder": self.gallery_folder,
                "gallery_hash": self.gallery.content_hash, "search": self.options.to_json()}

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        """Retrieve the object of ``case``'s input image and write it into ``out_dir``.

        :raises GalleryLeakError: when the gallery holds the case's own object (the case fails)
        :raises InputError: for an empty or broken gallery folder, an unreadable image or camera
        """
        gallery = self.gallery
        check = source_check(case.case.record, gallery)
        found = retrieve(case.image, case.camera, gallery, self.options)
        found.record["gallery_check"] = check
        write_retrieval(found, out_dir)
        record = found.record
        summary = {k: record[k] for k in ("gallery", "gallery_hash", "object_id", "category", "object_hash",
                                          "score", "yaw_deg", "scale", "view")}
        return Generation(Path(out_dir), {"retrieval": summary, "gallery_check": check,
                                          "record": str(Path(out_dir) / RECORD_FILE),
                                          "timings": record["timings"]})


__all__ = ["RetrievalMethod"]
