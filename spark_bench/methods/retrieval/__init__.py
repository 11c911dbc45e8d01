"""``--method retrieval``: render-and-compare retrieval from galleries of articulated objects, their
render index, and the search that returns the gallery object best explaining one image.

- :mod:`.method`: :class:`RetrievalMethod`, what the registry builds;
- :mod:`.gallery`: the default procedural gallery ``synth-gallery-v1`` and folder galleries, with
  content hashes;
- :mod:`.features`: the silhouette and edge features of one view (gallery render or input image);
- :mod:`.index`: features of every gallery object over a grid of views, cached by gallery content;
- :mod:`.search`: :func:`retrieve` (image + camera -> object in the benchmark frame + record).

Imports run one way: ``gallery``, ``features``, ``render`` <- ``index`` <- ``search`` <- ``method``; the
package uses ``asset`` and ``data`` (and ``ours``' retrieval backends use it, never the reverse).
"""

from spark_bench.lazy import lazy_exports

__all__, __getattr__ = lazy_exports(__name__, {
    "DEFAULT_GALLERY": "spark_bench.methods.retrieval.gallery", "Gallery": "spark_bench.methods.retrieval.gallery",
    "open_gallery": "spark_bench.methods.retrieval.gallery", "object_content_hash": "spark_bench.methods.retrieval.gallery",
    "Retrieval": "spark_bench.methods.retrieval.search", "SearchOptions": "spark_bench.methods.retrieval.search",
    "retrieve": "spark_bench.methods.retrieval.search", "write_retrieval": "spark_bench.methods.retrieval.search",
    "RetrievalMethod": "spark_bench.methods.retrieval.method",
})
