"""What the eval runner hands a worker: the measured options, the run's identity and one case's task, as
plain picklable data (a process pool and Ray ship them as they are)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from spark_bench.methods.base import MethodSpec
from spark_bench.rl import FINETUNE_STEPS

#: The engines the sim stage runs its checks in unless told otherwise (``eval --engine``): MuJoCo's alone.
DEFAULT_ENGINES = ("mujoco",)


@dataclass(frozen=True)
class EvalOptions:
    """What is measured per case (part of the run's identity: changing it starts a new run).

    :param sim: run the sim-readiness checks and the scripted opener
    :param rl: the RL transfer score: the shipped opening policy fine-tuned on the prediction, zero-shot and
        fine-tuned on the ground truth
    :param n_samples: surface samples per shape for the metrics
    :param seed: sampling seed
    :param align: ``none`` or ``icp``
    :param rl_finetune_steps: fine-tuning steps per policy kind with ``rl`` (0: zero-shot only)
    :param protocols: papers' metric protocols to score each case under as well
        (:mod:`spark_bench.metrics.protocols`), stored in the row's ``metrics["protocols"]``; none by default
    :param engines: the engines the sim checks run in (``mujoco``, ``physx``; ``eval --engine``): MuJoCo's verdict
        is the row's ``sim_pass`` and ``checks["sim"]``, PhysX's the row's ``checks["sim_physx"]``
        (:mod:`spark_bench.sim.physx`). Part of the run's identity only when not MuJoCo's alone, so a run with
        PhysX is a run of its own beside the MuJoCo-only one, and the MuJoCo-only run keeps its rows and its hash
    """

    sim: bool = True
    rl: bool = False
    n_samples: int = 100_000
    seed: int = 0
    align: str = "none"
    rl_finetune_steps: int = FINETUNE_STEPS
    protocols: tuple[str, ...] = ()
    engines: tuple[str, ...] = DEFAULT_ENGINES

    def identity(self) -> dict:
        out = asdict(self)
        if not self.rl:
            out.pop("rl_finetune_steps")
        if not self.protocols:  # a run without protocols keeps the identity it had before they existed
            out.pop("protocols")
        else:
            out["protocols"] = list(self.protocols)
        if tuple(self.engines) == DEFAULT_ENGINES:  # MuJoCo alone keeps the identity it had before engines existed
            out.pop("engines")
        else:
            out["engines"] = list(self.engines)
        return out

    @property
    def physx(self) -> bool:
        """Whether the sim stage runs the PhysX checks."""
        return self.sim and "physx" in self.engines


@dataclass(frozen=True)
class RunIdentity:
    """Who produced the rows of a run, resolved once in the driver.

    :param bench: benchmark name
    :param method: registry name
    :param label: display label (leaderboard row)
    :param regime: input regime
    :param version: method version
    :param config_json: method configuration and eval options, as JSON
    :param config_hash: hash of ``config_json`` (results key)
    :param generation_hash: hash of the method configuration alone (generation cache key)
    """

    bench: str
    method: str
    label: str
    regime: str
    version: str
    config_json: str
    config_hash: str
    generation_hash: str


@dataclass(frozen=True)
class CaseTask:
    """One case of one run, as plain data.

    :param case_id: the case id
    :param case_dir: the case folder
    :param spec: the method
    :param run: the run identity
    :param generation_dir: where this case's generation is cached
    :param options: what to measure
    :param threads: threads for the nearest-neighbour queries in this worker
    :param case_fingerprint: :meth:`BenchmarkCase.fingerprint` of the case when the run was planned
        (stored with the rows and the generation; empty: not checked)
    """

    case_id: str
    case_dir: str
    spec: MethodSpec
    run: RunIdentity
    generation_dir: str
    options: EvalOptions
    threads: int = 1
    case_fingerprint: str = ""
