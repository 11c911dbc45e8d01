"""spark-bench: accuracy and sim-readiness benchmark for single-image articulated-object reconstruction.

Importing the package pins the CPU kernels (:mod:`spark_bench.kernels`) and registers the Gymnasium
environments ``SparkDrawer-v0`` and ``SparkDoor-v0`` (:mod:`spark_bench.envs.registration`); every other
module is imported by whoever needs it.
"""

from importlib import metadata

# First, before anything imports NumPy or torch (Gymnasium, imported by the registration below, loads NumPy):
# each library reads its kernel choice from the environment once, when it loads.
from spark_bench import kernels

kernels.pin_cpu_kernels()

from spark_bench.convention import CONVENTION_VERSION  # noqa: E402  (re-exported for users)
from spark_bench.envs.registration import register_envs  # noqa: E402

try:  # one version string: pyproject.toml's, as installed
    __version__ = metadata.version("spark-bench")
except metadata.PackageNotFoundError:  # a source tree on sys.path that was never installed
    __version__ = "0+unknown"

register_envs()

__all__ = ["CONVENTION_VERSION", "__version__"]
