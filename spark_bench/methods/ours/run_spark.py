"""Run SPARK per case, stage by stage, with SPARK's own scripts and their real flags.

SPARK's ``run.py`` cannot be driven from outside (module constants, no flags) and exits 0 whatever
fails. This driver does what ``run.py`` does (see :mod:`spark_bench.formats.spark.layout` for every stage,
script and flag, read from SPARK's code) with four differences: it runs the stages it is told to
(:class:`DriverConfig`: e.g. no texturing, or with the joint optimizer), each program through the shared
runner (:func:`spark_bench.methods.process.run_program`: argument list, no shell, SPARK's folder as
working directory, the whole process group killed on timeout), it tells a failed stage by its missing
output, and it does not run a stage whose inputs a failed stage should have made. The run folder is
``output/<case id>_<YYYYmmdd_HHMMSS>/`` as ``run.py`` names it (one timestamp per driver run), so
``spark-bench import spark`` reads it like any other, and the driver leaves ``spark_bench_driver.json``
there: its configuration, results label, and every command with its exit status.

``optimize`` (not a ``run.py`` stage) first re-runs ``generate_urdf.py --mesh-dir inference/<TAG>
--mesh-pattern part_{index:02d}_cleaned.glb`` so that ``mobility.urdf`` points at meshes that exist (the
optimizer loads them where the URDF points), then ``optimize_urdf_joint_v4.py`` once per revolute joint
(it fits one joint per call), chaining ``mobility.urdf`` -> ``mobility_optimized.urdf``.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.formats.spark import layout

#: The stages each stage needs to have succeeded (or to have left its outputs, when not run).
REQUIRES = {
    "structure": (), "axes": ("structure",), "urdf": ("structure",), "part_prompts": ("structure",),
    "part_images": ("part_prompts",), "inference": ("part_images",), "clean": ("inference",),
    "open_prompt": ("structure",), "open_image": ("open_prompt",), "retexture": ("clean",),
    "align_texture": ("retexture",), "optimize": ("urdf", "clean", "open_image"),
}


def expand_stages(names) -> list[str]:
    """Stage names with groups (``texture``, ``open``) expanded, checked, in SPARK's order.

    :raises InputError: for an unknown name
    """
    wanted = set()
    for name in names:
        if name in layout.STAGE_GROUPS:
            wanted.update(layout.STAGE_GROUPS[name])
        elif name in layout.STAGE_NAMES:
            wanted.add(name)
        else:
            choices = ", ".join(layout.STAGE_NAMES + tuple(layout.STAGE_GROUPS))
            raise InputError(None, f"unknown SPARK stage {name!r}; expected one of {choices}")
    return [s for s in layout.STAGE_NAMES if s in wanted]


@dataclass(frozen=True)
class DriverConfig:
    """Which stages run and with which of ``run.py``'s settings (defaults: ``run.py``'s constants).

    :param stages: the stages to run (SPARK's order is kept whatever the order given)
    :param python: the interpreter of SPARK's environment (``run.py`` calls ``python``)
    :param timeout_s: seconds per program before its process group is killed
    :param optimizer_args: extra flags for ``optimize_urdf_joint_v4.py`` (e.g. ``--iters 100``)
    """

    stages: tuple[str, ...] = layout.RUN_PY_STAGES
    python: str = "python"
    csv: str = layout.CSV_PATH
    seed: int = layout.SEED
    temperature: float = layout.IMAGE_GEN_TEMPERATURE
    image_seed: int | None = None
    cuda_device: str = layout.CUDA_DEVICE
    inference_seed: int = layout.INFERENCE_SEED
    guidance_scale: float = layout.GUIDANCE_SCALE
    num_inference_steps: int = layout.NUM_INFERENCE_STEPS
    timeout_s: float = 7200.0
    optimizer_args: tuple[str, ...] = ()

    @classmethod
    def with_stages(cls, skip=(), add=(), only=None, **settings) -> DriverConfig:
        """``run.py``'s stages (or ``only``), less ``skip``, plus ``add`` (group names allowed)."""
        base = expand_stages(only) if only else list(layout.RUN_PY_STAGES)
        dropped = set(expand_stages(skip))
        stages = [s for s in expand_stages(base + expand_stages(add)) if s not in dropped]
        if not stages:
            raise InputError(None, "no SPARK stage left to run")
        return cls(stages=tuple(stages), **settings)

    @property
    def tag(self) -> str:
        """``run.py``'s ``INFERENCE_TAG``."""
        return f"FT5_G1_{self.inference_seed}"

    def label(self) -> str:
        """The results label: ``spark``, with the stages left out (``-texture``) and added (``+optimize``)."""
        missing = [s for s in layout.RUN_PY_STAGES if s not in self.stages]
        added = [s for s in self.stages if s not in layout.RUN_PY_STAGES]
        for group, members in layout.STAGE_GROUPS.items():
            if all(m in missing for m in members):
                missing = [group] + [s for s in missing if s not in members]
        text = "spark" + "".join(f"-{s}" for s in missing) + "".join(f"+{s}" for s in added)
        if self.inference_seed != layout.INFERENCE_SEED:
            text += f"@seed{self.inference_seed}"
        return text

    def to_dict(self) -> dict:
        return {**asdict(self), "stages": list(self.stages), "optimizer_args": list(self.optimizer_args),
                "tag": self.tag, "label": self.label()}


@dataclass
class CommandResult:
    """One program run: its arguments, exit status (None: it did not finish), seconds, last output line."""

    argv: list[str]
    returncode: int | None
    seconds: float
    tail: str = ""


@dataclass
class StageResult:
    """One stage: ``ok``, ``failed`` (``reason``), ``not_run`` (needs a stage that failed)."""

    name: str
    status: str
    reason: str = ""
    commands: list[CommandResult] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)


@dataclass
class DriverRun:
    """One case run through SPARK: its run folder and every stage's result."""

    case_id: str
    run_dir: Path
    label: str
    stages: list[StageResult] = field(default_factory=list)

    @property
    def failed_stage(self) -> str | None:
        return next((s.name for s in self.stages if s.status == "failed"), None)

    def to_dict(self, config: DriverConfig) -> dict:
        return {"case_id": self.case_id, "run": str(self.run_dir), "label": self.label,
                "failed_stage": self.failed_stage, "config": config.to_dict(),
                "stages": [asdict(s) for s in self.stages]}


class SparkDriver:
    """Runs SPARK's stage scripts for benchmark cases.

    :param spark_dir: SPARK's checkout (holding ``run.py`` and ``VLMguidance/``)
    :param config: which stages, which settings
    :param output_dir: where run folders go (default: ``SPARK/output``, as ``run.py``)
    :param runner: the program runner (``run_program``'s signature; tests may wrap it)
    """

    def __init__(self, spark_dir: str | Path, config: DriverConfig | None = None, output_dir: str | Path | None = None,
                 runner: Callable | None = None):
        from spark_bench.methods.process import run_program

        self.spark_dir = Path(spark_dir).expanduser().resolve()
        if not (self.spark_dir / "run.py").is_file() or not (self.spark_dir / "VLMguidance").is_dir():
            raise InputError(self.spark_dir, "not a SPARK checkout (expected run.py and VLMguidance/)")
        self.config = config or DriverConfig()
        self.output_dir = Path(output_dir).resolve() if output_dir else self.spark_dir / layout.OUTPUT_DIR
        self.runner = runner or run_program

    # ----- commands ----------------------------------------------------------------------------------------
    def _py(self, script: str, *args) -> list[str]:
        return [self.config.python, script, *[str(a) for a in args]]

    def _seed(self) -> list[str]:
        return [] if self.config.image_seed is None else ["--seed", str(self.config.image_seed)]

    def commands(self, name: str, run: Path) -> Iterator[tuple[list[str], dict | None]]:
        """``(argv, extra environment)`` of each program of stage ``name``, decided when it is reached
        (per-part stages read what the stages before them wrote)."""
        c, tag_dir = self.config, run / layout.INFERENCE_DIR / self.config.tag
        script = layout.stage(name).script
        if name == "structure":
            yield self._py(script, "--input", run / layout.INPUT, "--output", run / layout.METADATA, "--csv", c.csv,
                           "--seed", c.seed), None
        elif name == "axes":
            yield self._py(script, "--input", run, "--image", layout.INPUT, "--single"), None
        elif name == "urdf":
            yield self._py(script, "--input-dir", run, "--single"), None
        elif name in ("part_prompts", "open_prompt"):
            yield self._py(script, "--input", run), None
        elif name == "part_images":
            try:
                labels = list(json.loads((run / layout.PROMPT_PART).read_text()).get("prompts", {}))
            except (OSError, ValueError, AttributeError):
                labels = []
            for label in labels:
                yield self._py(script, "--input", run, "--part", label, "--temperature", c.temperature) + self._seed(), None
        elif name == "inference":
            env = {"CUDA_VISIBLE_DEVICES": c.cuda_device,
                   "PYTHONPATH": str(self.spark_dir) + ":" + os.environ.get("PYTHONPATH", "")}
            yield self._py(script, "--image_folder", run, "--output_dir", run / layout.INFERENCE_DIR, "--tag", c.tag,
                           "--seed", c.inference_seed, "--num_inference_steps", c.num_inference_steps,
                           "--guidance_scale", c.guidance_scale, "--render"), env
        elif name == "clean":
            for mesh in sorted(tag_dir.glob("part_*.glb")):
                if mesh.stem[len("part_"):].isdigit():
                    yield self._py(script, "--in_mesh", mesh, "--out_mesh", mesh.with_name(f"{mesh.stem}_cleaned.glb"),
                                   "--keep_largest", "--merge_tol", "1e-5", "--target_faces", "200000"), None
        elif name == "open_image":
            yield self._py(script, "--input", run, "--temperature", c.temperature) + self._seed(), None
        elif name in ("retexture", "align_texture"):
            for mesh in sorted(tag_dir.glob("part_*_cleaned.glb")):
                out = tag_dir / f"{mesh.stem}_texture"
                if name == "retexture":
                    yield self._py(script, "--image", run / layout.INPUT, "--model", mesh, "--outdir", out), None
                    continue
                textured = sorted(out.glob("**/*.glb"))
                if textured:
                    yield self._py(script, "--reference", mesh, "--target", textured[0], "--output",
                                   tag_dir / f"{mesh.stem}_textured_aligned.glb"), None
        elif name == "optimize":
            yield self._py(layout.stage("urdf").script, "--input-dir", run, "--single", "--mesh-dir", tag_dir,
                           "--mesh-pattern", "part_{index:02d}_cleaned.glb"), None
            optimized = layout.stage_outputs(run, "optimize")[0]
            for joint in revolute_joints(run / layout.URDF):
                source = optimized if optimized.is_file() else run / layout.URDF
                yield self._py(script, "--urdf", source, "--joint-name", joint, "--opened-img", run / layout.OPEN,
                               "--closed-img", run / layout.INPUT, "--out-urdf", optimized, *c.optimizer_args), None

    def expected(self, name: str, run: Path) -> list[Path]:
        """The outputs stage ``name`` must leave (``optimize``: none when there is no revolute joint)."""
        if name == "optimize" and not revolute_joints(run / layout.URDF):
            return []
        return layout.stage_outputs(run, name, self.config.tag)

    # ----- running -------------------------------------------------------------------------------------------
    def _run_stage(self, name: str, run: Path) -> StageResult:
        from spark_bench.methods.process import ProgramError

        result = StageResult(name, "ok")
        for argv, env in self.commands(name, run):
            start = time.monotonic()
            try:
                done = self.runner(argv, self.config.timeout_s, cwd=self.spark_dir, extra_env=env)
            except ProgramError as exc:
                result.commands.append(CommandResult(argv, None, time.monotonic() - start, exc.problem))
                result.status, result.reason = "failed", exc.problem
                return result
            tail = (done.last_lines(1) or [""])[0]
            result.commands.append(CommandResult(argv, done.returncode, time.monotonic() - start, tail))
            if name == "axes" and done.returncode != 0:  # its only output is an edit in place
                result.status, result.reason = "failed", f"exit status {done.returncode}: {tail}"
        missing = [p for p in self.expected(name, run) if not layout.output_present(p)]
        if missing:
            result.missing = [str(p.relative_to(run)) for p in missing]
            result.status = "failed"
            result.reason = (f"no output: {', '.join(result.missing[:4])}" if result.commands
                             else "nothing to run (its inputs are missing)")
            failing = [c for c in result.commands if c.returncode]
            if failing:
                result.reason += f" (exit status {failing[-1].returncode}: {failing[-1].tail})"
        return result

    def run_case(self, case_id: str, image: str | Path, stamp: str | None = None) -> DriverRun:
        """Run the configured stages on one image, in a new run folder.

        :param case_id: the case id (the run folder's name before the timestamp)
        :param image: the input image (copied as ``input.png``)
        :param stamp: the run timestamp (default: now, ``YYYYmmdd_HHMMSS``)
        """
        image = Path(image)
        if not image.is_file():
            raise InputError(image, "input image not found")
        name = str(case_id)
        if not name or name in (".", "..") or "/" in name or "\\" in name or name.startswith("."):
            raise InputError(image, f"unsafe run name {name!r} (it names a folder inside {self.output_dir})")
        stamp = stamp or time.strftime(layout.TIMESTAMP_FORMAT)
        run = self.output_dir / layout.run_folder_name(case_id, stamp)
        run.mkdir(parents=True, exist_ok=True)
        shutil.copy2(image, run / layout.INPUT)
        out = DriverRun(case_id, run, self.config.label())
        status: dict[str, str] = {}
        for name in self.config.stages:
            blocked = [r for r in REQUIRES[name] if status.get(r) in ("failed", "not_run")
                       or (r not in status and not all(layout.output_present(p) for p in self.expected(r, run)))]
            if blocked:
                out.stages.append(StageResult(name, "not_run", f"needs {', '.join(blocked)}"))
            else:
                out.stages.append(self._run_stage(name, run))
            status[name] = out.stages[-1].status
            (run / layout.DRIVER_RECORD).write_text(json.dumps(out.to_dict(self.config), indent=1, default=str) + "\n")
        return out

    def run_benchmark(self, bench: str | Path, cases: list[str] | None = None,
                      progress: Callable[[DriverRun], None] | None = None) -> list[DriverRun]:
        """Run every case (or ``cases``) of a benchmark, one timestamp for all (as ``run.py``)."""
        from spark_bench.data.case import Benchmark

        benchmark = Benchmark(Path(bench))
        ids = benchmark.case_ids()
        unknown = [c for c in cases or () if c not in ids]
        if unknown:
            raise InputError(benchmark.manifest_path, f"no case {unknown[0]!r} in this benchmark")
        stamp = time.strftime(layout.TIMESTAMP_FORMAT)
        runs = []
        for case_id in [c for c in ids if not cases or c in cases]:
            runs.append(self.run_case(case_id, benchmark.case(case_id).input_image, stamp))
            if progress is not None:
                progress(runs[-1])
        return runs


def revolute_joints(urdf: Path) -> list[str]:
    """Names of the revolute joints of a URDF, in file order (empty when it cannot be read)."""
    from lxml import etree

    try:
        parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
        root = etree.fromstring(Path(urdf).read_bytes(), parser=parser)
    except (OSError, etree.XMLSyntaxError):
        return []
    return [j.get("name") for j in root.findall("joint") if j.get("type") == "revolute" and j.get("name")]
