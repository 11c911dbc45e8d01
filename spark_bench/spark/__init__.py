"""``ours``: the SPARK pipeline (paper section 3) as interchangeable stage backends.

1. structure prior (:mod:`.structure`, :mod:`.vlm`, :mod:`.prior`, :mod:`.retrieved`): ``annotation`` |
   ``vlm`` | ``file`` | ``retrieval``
2. part geometry (:mod:`.geometry`, :mod:`.retrieved`): ``annotation`` | ``predictions`` | ``spark`` |
   ``retrieval`` (one retrieval serves both stages)
3. open-state image (:mod:`.open_state`): ``dataset`` | ``http``
4. joint optimization: ``spark``, SPARK's own recipe (:mod:`.spark_fit`), or ``native`` (:mod:`.optimize`,
   :mod:`.refine`, :mod:`.render`, :mod:`.simplify`, differentiable FK from :mod:`spark_bench.asset.torch_fk`)
5. export (:mod:`.pipeline`): PartNet-Mobility object folders

Configuration: :mod:`.config` (the sections and their defaults), :mod:`.config_parse` (reading them).
Entry point: :func:`run_ours` with a :class:`SparkConfig`. Both are loaded on first use, so that reading
a configuration (or any one stage module) does not import torch.
"""

from spark_bench.lazy import lazy_exports

__all__, __getattr__ = lazy_exports(__name__, {"SparkConfig": "spark_bench.spark.config",
                                               "run_ours": "spark_bench.spark.pipeline"})
