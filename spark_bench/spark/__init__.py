"""``ours``: the SPARK pipeline (paper section 3) as interchangeable stage backends.

1. structure prior (:mod:`.structure`, :mod:`.vlm`, :mod:`.prior`): ``vlm`` | ``annotation`` | ``file``
2. part geometry (:mod:`.geometry`): ``annotation`` | ``predictions`` | ``spark``
3. open-state image (:mod:`.open_state`): ``dataset`` | ``http``
4. joint optimization, native (:mod:`.optimize`, :mod:`.refine`, :mod:`.render`, differentiable FK
   from :mod:`spark_bench.asset.torch_fk`)
5. export (:mod:`.pipeline`): PartNet-Mobility object folders

Entry point: :func:`run_ours` with a :class:`SparkConfig`. Both are loaded on first use, so that reading
a configuration (or any one stage module) does not import torch.
"""

from spark_bench.lazy import lazy_exports

__all__, __getattr__ = lazy_exports(__name__, {"SparkConfig": "spark_bench.spark.config",
                                               "run_ours": "spark_bench.spark.pipeline"})
