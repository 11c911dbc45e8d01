"""spark-bench: accuracy and sim-readiness benchmark for single-image articulated-object reconstruction.

Importing the package registers the gymnasium environments ``SparkDrawer-v0`` and ``SparkDoor-v0``
(when :mod:`spark_bench.envs` is present); heavy dependencies are imported lazily by each module.
"""

# Before anything loads NumPy or torch (the environments' registration below does): the same CPU kernels on
# every x86 machine (spark_bench.kernels).
from spark_bench.kernels import pin_cpu_kernels as _pin_cpu_kernels

_pin_cpu_kernels()

__version__ = "0.2.0"

#: Version of the metric definitions (docs/conventions.md "The benchmark frame", "Shape metrics",
#: "Articulation metrics", "Opening score"), written into every results row. conv-2 (issue #16): PivotErr
#: for every matched ground-truth revolute joint whatever the predicted type (FreeArt3D's rule); the mean
#: over all joints (``joint_mean``) and the GAPartNet part class per joint are stored beside the per-object
#: means. conv-3
#: (issue #23): the opening score acts on the case's source object and opens a part with nothing to pinch
#: with a suction cup; the metrics are conv-2's. conv-4 (issue #23): simulated masses follow the thin-wall
#: rule (a shell of its material's wall thickness, never more than the solid), which moves sim-readiness
#: verdicts and opening scores; the metrics are conv-2's. conv-5 (issue #23): a PartNet-Mobility joint written
#: without <axis> or <limit> takes them from mobility_v2.json (the ground truth of such objects changes), and a
#: flat-faced part turned off the coordinate planes is decomposed in its own planes' frame.
#: conv-6: a PartNet-Mobility object is read at its real size (spark_bench.data.real_size), not its units as metres.
CONVENTION_VERSION = "spark-bench-conv-6"


def _register_envs() -> None:
    try:
        from spark_bench import envs  # noqa: F401  (registers at import)
    except ModuleNotFoundError as exc:  # envs not built yet in a partial install
        if exc.name not in ("spark_bench.envs", "spark_bench.envs.registration"):
            raise


_register_envs()
