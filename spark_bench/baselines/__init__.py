"""Reference methods that run offline, registered in :mod:`spark_bench.generators`:

- ``oracle`` (:class:`~spark_bench.baselines.oracle.Oracle`): the ground truth itself;
- ``geometry`` (:class:`~spark_bench.baselines.geometry.GeometryBaseline`): a geometry-only
  articulation estimator in the spirit of Articulate AnyMesh, from the case's part meshes at rest.
"""
