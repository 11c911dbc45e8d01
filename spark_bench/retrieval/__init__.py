"""Render-and-compare retrieval (``--method retrieval``): galleries of articulated objects, their
render index, and the search that returns the gallery object best explaining one image.

- :mod:`.gallery`: the default procedural gallery ``synth-gallery-v1`` and folder galleries, with
  content hashes;
- :mod:`.features`: the silhouette and edge features of one view (gallery render or input image);
- :mod:`.index`: features of every gallery object over a grid of views, cached by gallery content;
- :mod:`.search`: :func:`retrieve` (image + camera -> object in the benchmark frame + record).

Imports run one way: this package uses ``data``, ``asset`` and ``spark.open_state``; the method
(:mod:`spark_bench.methods.retrieval`) uses this package, never the reverse.
"""

from spark_bench.lazy import lazy_exports

__all__, __getattr__ = lazy_exports(__name__, {
    "DEFAULT_GALLERY": "spark_bench.retrieval.gallery", "Gallery": "spark_bench.retrieval.gallery",
    "open_gallery": "spark_bench.retrieval.gallery", "object_content_hash": "spark_bench.retrieval.gallery",
    "Retrieval": "spark_bench.retrieval.search", "SearchOptions": "spark_bench.retrieval.search",
    "retrieve": "spark_bench.retrieval.search", "write_retrieval": "spark_bench.retrieval.search",
})
