"""External methods: predictions written beforehand (``--method predictions``) and a program run
once per case (``--method command``, from a methods file).

Both hand the runner an object folder in PartNet-Mobility conventions; neither runs a shell.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.generators import INPUT_KINDS, CaseInput, Generation, GenerationError


def _case_dir_name(case_id: str) -> str:
    if not case_id or "/" in case_id or "\\" in case_id or case_id in (".", ".."):
        raise GenerationError(f"unsafe case id {case_id!r}")
    return case_id


class PredictionsFolder:
    """Predictions written beforehand by any method: ``DIR/<case id>/`` is the case's object folder.

    :param folder: the predictions folder
    :param label: display label (default ``predictions:<folder name>``)
    :param regime: the input regime the external method had (default ``image``)
    """

    name = "predictions"
    version = "1"
    inputs: tuple[str, ...] = ()

    def __init__(self, folder: str | Path, label: str | None = None, regime: str = "image"):
        self.folder = Path(folder).expanduser().resolve()
        if not self.folder.is_dir():
            raise InputError(self.folder, "predictions folder not found")
        self._label = label or f"predictions:{self.folder.name}"
        self.regime = regime

    def label(self) -> str:
        return self._label

    def config(self) -> dict:
        return {"predictions": str(self.folder)}

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        folder = self.folder / _case_dir_name(case.case_id)
        if not folder.is_dir():
            raise GenerationError(f"no prediction folder {folder}")
        return Generation(folder, {"source": str(folder)})


@dataclass
class CommandTemplate:
    """An external method run once per case.

    :param name: the entry name (the display label)
    :param argv: the program and its arguments; ``{image}``, ``{out}``, ``{camera}``, ``{case_dir}``,
        ``{case_id}``, ``{open_image}``, ``{masks}`` are replaced (each only if declared in ``inputs``,
        ``{out}``, ``{case_id}`` always)
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


class CommandMethod:
    """Runs an external program per case (e.g. SPARK's public ``run.py``), never through a shell.

    :param template: the command template
    """

    name = "command"

    def __init__(self, template: CommandTemplate):
        self.template = template
        self.version = template.version
        self.inputs = template.inputs
        self.regime = template.regime

    def label(self) -> str:
        return self.template.name

    def config(self) -> dict:
        return {"argv": self.template.argv, "inputs": list(self.inputs), "cwd": self.template.cwd,
                "env": self.template.env}

    def arguments(self, case: CaseInput, out_dir: Path) -> list[str]:
        """The argument list for ``case``, placeholders filled."""
        values = {"out": str(out_dir), "case_id": case.case_id}
        for kind in ("image", "camera", "open_image", "masks"):
            if kind in self.inputs:
                values[kind] = str(case.path(kind))
        if "gt" in self.inputs:  # the whole case folder holds the ground truth
            values["case_dir"] = str(case.case_dir)
        try:
            return [arg.format(**values) for arg in self.template.argv]
        except (KeyError, IndexError, ValueError) as exc:
            raise GenerationError(f"command template of {self.template.name!r}: placeholder {exc} "
                                  f"is unknown or not among its inputs {list(self.inputs)}") from None

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        argv = self.arguments(case, out_dir)
        env = {**os.environ, **self.template.env}
        try:
            proc = subprocess.run(argv, cwd=self.template.cwd, env=env, capture_output=True, text=True,
                                  timeout=self.template.timeout, shell=False, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            raise GenerationError(f"{self.template.name}: timed out after {self.template.timeout:g} s") from None
        except OSError as exc:
            raise GenerationError(f"{self.template.name}: cannot run {argv[0]!r}: {exc}") from None
        (out_dir / "method_stdout.txt").write_text(proc.stdout[-200_000:])
        (out_dir / "method_stderr.txt").write_text(proc.stderr[-200_000:])
        if proc.returncode != 0:
            tail = [line for line in proc.stderr.splitlines() if line.strip()][-1:] or ["(no stderr)"]
            raise GenerationError(f"{self.template.name}: exit status {proc.returncode}: {tail[0][:300]}")
        return Generation(find_object_folder(out_dir), {"returncode": proc.returncode})


def find_object_folder(out_dir: Path) -> Path:
    """The object folder a method wrote: ``out_dir`` itself, or its one sub-folder with a URDF."""
    out_dir = Path(out_dir)
    if any(out_dir.glob("*.urdf")):
        return out_dir
    found = sorted({p.parent for p in out_dir.rglob("*.urdf")})
    if len(found) == 1:
        return found[0]
    raise GenerationError(f"expected one object folder with a URDF under {out_dir}, found {len(found)}")
