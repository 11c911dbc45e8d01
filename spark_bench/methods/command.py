"""An external program run once per case (``--method command``, or a methods-file entry by name:
``--method NAME --method-args methods_file=FILE``).

A methods file (TOML or JSON) holds command templates; :class:`CommandMethod` fills a template's
placeholders with the case files the method declared and runs it with
:func:`spark_bench.methods.process.run_program` (no shell, its process group killed on timeout).
"""

from __future__ import annotations

import json
import shlex
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError, SparkBenchError
from spark_bench.methods.base import INPUT_KINDS, CaseInput, Generation, GenerationError
from spark_bench.methods.options import MethodOption
from spark_bench.methods.process import ProgramError, run_program
from spark_bench.methods.registry import register_method

#: Input kinds that are one case file, filled into the placeholder of the same name.
FILE_PLACEHOLDERS = ("image", "camera", "open_image", "masks", "open_masks")
#: The tail of the program's output kept beside its object folder (characters).
OUTPUT_TAIL = 200_000
#: The option that names the methods file.
METHODS_FILE = MethodOption("the methods file (TOML or JSON) of external commands", "path")


@dataclass
class CommandTemplate:
    """An external method run once per case.

    :param name: the entry name (the display label)
    :param argv: the program and its arguments; ``{image}``, ``{camera}``, ``{open_image}``, ``{masks}``,
        ``{open_masks}`` (each only if declared in ``inputs``), ``{case_dir}`` (only with ``gt``: the
        case folder holds the ground truth), ``{out}`` and ``{case_id}`` (always) are replaced
    :param timeout: seconds before the program is killed and the case fails
    :param inputs: the input kinds the program receives
    :param version: the method's version, written into the rows
    :param cwd: working directory (relative to the methods file)
    :param env: extra environment variables
    :param regime: input regime shown on the leaderboard
    """

    name: str
    argv: list[str]
    timeout: float = 1800.0
    inputs: tuple[str, ...] = ("image", "camera")
    version: str = ""
    cwd: str | None = None
    env: dict[str, str] = field(default_factory=dict)
    regime: str = "image"


def read_methods_file(path: str | Path) -> dict[str, CommandTemplate]:
    """A methods file: TOML (``[methods.NAME]`` tables) or JSON (``{"methods": {NAME: {...}}}``).

    Each entry has ``command`` (a list of arguments, or one string split like a shell would, but never
    run through one), and optionally ``timeout``, ``inputs``, ``version``, ``cwd``, ``env``, ``regime``.
    """
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise InputError(path, "methods file not found")
    try:
        data = tomllib.loads(path.read_text()) if path.suffix == ".toml" else json.loads(path.read_text())
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"malformed methods file: {exc}") from None
    methods = data.get("methods") if isinstance(data, dict) else None
    if not isinstance(methods, dict) or not methods:
        raise InputError(path, "expected a 'methods' table with one entry per method")
    out = {}
    for name, entry in methods.items():
        if not isinstance(entry, dict) or "command" not in entry:
            raise InputError(path, f"method {name!r} needs a 'command'")
        command = entry["command"]
        argv = shlex.split(command) if isinstance(command, str) else [str(a) for a in command]
        if not argv:
            raise InputError(path, f"method {name!r} has an empty command")
        inputs = tuple(entry.get("inputs", ("image", "camera")))
        bad = set(inputs) - set(INPUT_KINDS)
        if bad:
            raise InputError(path, f"method {name!r}: unknown inputs {sorted(bad)} (choose from {INPUT_KINDS})")
        cwd = entry.get("cwd")
        out[name] = CommandTemplate(
            name=name, argv=argv, timeout=float(entry.get("timeout", 1800.0)), inputs=inputs,
            version=str(entry.get("version", "")), cwd=str((path.parent / cwd).resolve()) if cwd else None,
            env={str(k): str(v) for k, v in (entry.get("env") or {}).items()},
            regime=str(entry.get("regime", "image")))
    return out


@register_method("command")
class CommandMethod:
    """Runs an external program per case (e.g. SPARK's public ``run.py``), never through a shell.

    :param template: the command template
    """

    name = "command"
    accepts = {"methods_file": METHODS_FILE,
               "entry": MethodOption("which entry of the methods file (default: its only one)")}
    #: What a methods-file entry run by its own name takes (:meth:`entry_method`).
    entry_accepts = {"methods_file": METHODS_FILE}

    def __init__(self, template: CommandTemplate):
        self.template = template
        self.version = template.version
        self.inputs = template.inputs
        self.regime = template.regime

    @classmethod
    def from_options(cls, options: dict) -> CommandMethod:
        """The registry's factory: the entry ``entry`` of the methods file ``methods_file`` (the only entry
        when there is one)."""
        if not options.get("methods_file"):
            raise SparkBenchError("--method command needs --method-args methods_file=FILE "
                                  "(and entry=NAME if it has several)")
        templates = read_methods_file(options["methods_file"])
        entry = options.get("entry")
        if entry is None and len(templates) == 1:
            entry = next(iter(templates))
        if entry not in templates:
            raise InputError(options["methods_file"], f"no method {entry!r} (has {sorted(templates)})")
        return cls(templates[entry])

    @classmethod
    def entry_method(cls, name: str, methods_file: str | Path):
        """The factory of the entry ``name`` of ``methods_file`` run as ``--method name`` (its options:
        :attr:`entry_accepts`), or None when the file has no such entry."""
        templates = read_methods_file(methods_file)
        if name not in templates:
            return None

        def factory(options: dict) -> CommandMethod:
            return cls(templates[name])

        factory.accepts = cls.entry_accepts
        return factory

    def label(self) -> str:
        return self.template.name

    def prepare(self) -> None:
        """Nothing to prepare."""

    def config(self) -> dict:
        return {"argv": self.template.argv, "inputs": list(self.inputs), "cwd": self.template.cwd,
                "env": self.template.env}

    def arguments(self, case: CaseInput, out_dir: Path) -> list[str]:
        """The argument list for ``case``, placeholders filled."""
        values = {"out": str(out_dir), "case_id": case.case_id}
        for kind in FILE_PLACEHOLDERS:
            if kind in self.inputs:
                values[kind] = str(case.path(kind))
        if "gt" in self.inputs:  # the whole case folder holds the ground truth
            values["case_dir"] = str(case.folder)
        try:
            return [arg.format(**values) for arg in self.template.argv]
        except (KeyError, IndexError, ValueError) as exc:
            raise GenerationError(f"command template of {self.template.name!r}: placeholder {exc} "
                                  f"is unknown or not among its inputs {list(self.inputs)}") from None

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        """Run the program for ``case``; its stdout and stderr (tails) are kept in ``out_dir``.

        :raises GenerationError: when it cannot start, times out, exits non-zero (with its last stderr
            line) or writes no object folder
        """
        name = self.template.name
        try:
            done = run_program(self.arguments(case, out_dir), self.template.timeout, self.template.cwd,
                               self.template.env)
        except ProgramError as exc:
            raise GenerationError(f"{name}: {exc.problem}") from None
        (out_dir / "method_stdout.txt").write_text(done.stdout[-OUTPUT_TAIL:])
        (out_dir / "method_stderr.txt").write_text(done.stderr[-OUTPUT_TAIL:])
        if done.returncode != 0:
            tail = [line for line in done.stderr.splitlines() if line.strip()][-1:] or ["(no stderr)"]
            raise GenerationError(f"{name}: exit status {done.returncode}: {tail[0][:300]}")
        return Generation(find_object_folder(out_dir), {"returncode": done.returncode})


def find_object_folder(out_dir: Path) -> Path:
    """The object folder a method wrote: ``out_dir`` itself, or its one sub-folder with a URDF."""
    out_dir = Path(out_dir)
    if any(out_dir.glob("*.urdf")):
        return out_dir
    found = sorted({p.parent for p in out_dir.rglob("*.urdf")})
    if len(found) == 1:
        return found[0]
    raise GenerationError(f"expected one object folder with a URDF under {out_dir}, found {len(found)}")
