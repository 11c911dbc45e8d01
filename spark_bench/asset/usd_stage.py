"""Opening a USD stage for :mod:`spark_bench.asset.usd_model`: what the file's composition and metadata say, every
problem answered (``usd-core``'s own messages kept out of the user's way).

- **usd-core's messages**: while a stage is read, its diagnostics go to a ``UsdUtils.CoalescingDiagnosticDelegate``
  instead of the terminal (:func:`quiet_usd`). The crate-version deprecation ("has deprecated version 0.7.0",
  Isaac Sim's files; usd-core reads them) is recorded as the file's ``crate_version``, nothing more; the others
  come back as :class:`StageReading` warnings or errors in spark-bench's words.
- **Composition**: every arc the stage could not compose (``UsdStage.GetCompositionErrors``: a sublayer, reference
  or payload not found, not a USD layer, or forming a cycle, the file itself as its own sublayer included) is a
  :class:`BrokenArc` naming the asset path, the layer that names it and the prim it hangs on. usd-core composes
  the stage without it; :mod:`.usd_model` decides whether what it held was needed (an error) or not (a warning).
- **Look-only files**: an ``asset``-valued attribute that does not resolve (a material's MDL shader such as Isaac's
  ``OmniPBR.mdl``, which Isaac resolves from its own library and never ships beside an asset; a texture) is a
  warning, one per file named: spark-bench reads display colours, never materials, shaders or textures.
- **Units**: ``metersPerUnit`` and ``kilogramsPerUnit`` must be positive, finite numbers (a stage with
  ``metersPerUnit = 0`` collapses every length to a point): anything else is an
  :class:`~spark_bench.errors.InputError` naming the file and the value.
"""

from __future__ import annotations

import contextlib
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError

#: The start of a binary USD (crate) file; the three bytes after the next two give its version.
CRATE_MAGIC = b"PXR-USDC"
#: How usd-core says it reads a crate file of a version it will stop reading (Isaac Sim writes 0.7.0).
CRATE_DEPRECATION = "has deprecated version"
#: usd-core's messages about arcs it could not compose: :class:`BrokenArc` says them instead.
_COMPOSITION_WORDS = ("Could not open asset", "Could not load sublayer", "Cycle detected", "has cycles",
                      "Failed to resolve")


@dataclass
class BrokenArc:
    """A composition arc usd-core could not follow; the stage is composed without what it held.

    :param kind: ``sublayer``, ``reference`` or ``payload`` (``arc`` for a cycle usd-core does not name)
    :param target: the asset path as the layer writes it (or the layer seen twice, for a sublayer cycle)
    :param why: ``not found``, ``not a USD layer`` or ``a cycle``
    :param prim: the prim the arc hangs on (``/`` for a sublayer: the whole stage)
    :param layer: the layer that names it
    """

    kind: str
    target: str
    why: str
    prim: str
    layer: str

    def describe(self) -> str:
        """One line: which arc, where, why."""
        where = f"of layer {self.layer}" if self.kind == "sublayer" else f"on prim {self.prim} (layer {self.layer})"
        return f"{self.kind} @{self.target}@ {where}: {self.why}"


@dataclass
class StageReading:
    """An opened stage and what was found opening it.

    :param stage: the ``Usd.Stage``
    :param meters: ``metersPerUnit`` (positive, finite)
    :param kilograms: ``kilogramsPerUnit`` (positive, finite)
    :param up: ``upAxis`` (``Y`` or ``Z``)
    :param broken: the arcs that could not be composed
    :param warnings: look-only files not found and other usd-core messages, one line each
    :param crate_version: the crate version of a binary file (``0.7.0``), None for text
    """

    stage: object
    meters: float
    kilograms: float
    up: str
    broken: list[BrokenArc] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    crate_version: str | None = None


def pxr_modules():
    """``(Gf, Usd, UsdGeom, UsdPhysics, UsdUtils)``; an :class:`InputError` where usd-core is not installed."""
    try:
        from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdUtils
    except ImportError:  # declared in pyproject; a trimmed install may lack it
        raise InputError(None, "reading USD needs usd-core (pip install usd-core)") from None
    return Gf, Usd, UsdGeom, UsdPhysics, UsdUtils


@contextlib.contextmanager
def quiet_usd() -> Iterator[list[str]]:
    """usd-core's diagnostics (warnings, status) collected instead of printed while the block runs; yields the
    list their one-line texts are added to when the block ends."""
    _, _, _, _, UsdUtils = pxr_modules()
    delegate = UsdUtils.CoalescingDiagnosticDelegate()
    collected: list[str] = []
    try:
        yield collected
    finally:
        for item in delegate.TakeUncoalescedDiagnostics():
            collected.append(" ".join(str(item.commentary).split()))
        del delegate


def crate_version(path: Path) -> str | None:
    """The crate version of a binary USD file (``0.7.0``), None for any other file."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(11)
    except OSError:
        return None
    if not head.startswith(CRATE_MAGIC) or len(head) < 11:
        return None
    return ".".join(str(b) for b in head[8:11])


_SUBLAYER = re.compile(r"Could not load sublayer @([^@]*)@ of layer @([^@]*)@(?:\s*--\s*(.*?))?;")
_ARC = re.compile(r"Could not open asset @([^@]*)@ for (reference|payload) introduced by @([^@]*)@<([^>]*)>")
_SUBLAYER_CYCLE = re.compile(r"root layer @([^@]*)@ has cycles\. Detected when layer @([^@]*)@")
_CYCLE_FROM = re.compile(r"Cycle detected:\s*@([^@]*)@")
_CYCLE_TO = re.compile(r"CANNOT (reference|payload|inherit|specialize)\w*:\s*@([^@]*)@(?:,@[^@]*@)?<([^>]*)>")


def _arc_of(error) -> BrokenArc:
    """A composition error of usd-core as a :class:`BrokenArc` (its message parsed; the message itself where its
    wording is not one of those known)."""
    text = " ".join(str(error).split())
    prim = str(error.rootSite.path) if getattr(error, "rootSite", None) is not None else "/"
    found = _SUBLAYER.search(text)
    if found:
        why = "not a USD layer" if found.group(3) else "not found"
        return BrokenArc("sublayer", found.group(1), why, "/", found.group(2))
    found = _ARC.search(text)
    if found:
        return BrokenArc(found.group(2), found.group(1), "not found", found.group(4) or prim, found.group(3))
    found = _SUBLAYER_CYCLE.search(text)
    if found:
        return BrokenArc("sublayer", found.group(2), "a cycle (the layer includes itself)", "/", found.group(1))
    if "Cycle detected" in text:
        source, target = _CYCLE_FROM.search(text), _CYCLE_TO.search(text)
        if target:
            return BrokenArc(target.group(1), target.group(2), f"a cycle (it leads back to <{target.group(3)}>)",
                             prim, source.group(1) if source else target.group(2))
        return BrokenArc("arc", "?", f"a cycle ({text[:200]})", prim, source.group(1) if source else "?")
    return BrokenArc("arc", "?", text[:200], prim, "?")


def broken_arcs(stage) -> list[BrokenArc]:
    """Every arc of ``stage`` that could not be composed, once each (usd-core repeats an error at every prim the
    arc reaches)."""
    out: dict[tuple, BrokenArc] = {}
    for error in stage.GetCompositionErrors():
        arc = _arc_of(error)
        key = (arc.kind, arc.target, arc.layer) if arc.kind == "sublayer" else (arc.kind, arc.target, arc.why)
        if key not in out or len(arc.prim) < len(out[key].prim):  # the arc's own prim, not one it reaches
            out[key] = arc
    return list(out.values())


def unresolved_look_files(stage) -> list[str]:
    """One warning per ``asset``-valued attribute path that does not resolve (materials, MDL shaders, textures):
    the path, how many prims name it and the first of them."""
    from pxr import Sdf, Usd

    named: dict[str, list[str]] = {}
    for prim in stage.Traverse(Usd.PrimAllPrimsPredicate):
        for attribute in prim.GetAttributes():
            if attribute.GetTypeName() not in (Sdf.ValueTypeNames.Asset, Sdf.ValueTypeNames.AssetArray):
                continue
            value = attribute.Get()
            for asset in ([value] if isinstance(value, Sdf.AssetPath) else list(value or [])):
                if asset.path and not asset.resolvedPath:
                    named.setdefault(asset.path, []).append(f"{prim.GetPath()}.{attribute.GetName()}")
    return [f"@{target}@ not found ({len(places)} attribute(s), first {places[0]}): a material's or texture's "
            "file, look only: not read" for target, places in sorted(named.items())]


def usd_error(exc: Exception) -> str:
    """usd-core's error on one line, without its C++ function and source line (``Error in '...' at line N in file
    ... : 'what'`` becomes ``what``)."""
    text = " ".join(str(exc).split())
    reasons = re.findall(r"Error in '[^']*' at line \d+ in file \S+ : '(.*?)'(?= Error in|$)", text)
    return "; ".join(dict.fromkeys(reasons))[:300] if reasons else text[:300]


def _unit(value: float, what: str, path: Path) -> float:
    if not math.isfinite(value) or value <= 0.0:
        raise InputError(path, f"{what} is {value}: a stage's units must be a positive, finite number")
    return float(value)


def read_stage(path: Path) -> StageReading:
    """Open the stage of ``path`` and gather what its composition and metadata say (see the module docstring);
    call it inside :func:`quiet_usd`, so that usd-core's own messages stay out of the terminal.

    :raises InputError: no such file, usd-core cannot open it, or a unit that is not a positive, finite number
    """
    _, Usd, UsdGeom, UsdPhysics, _ = pxr_modules()
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "no such USD file")
    if path.stat().st_size == 0:
        raise InputError(path, "cannot open USD: the file is empty")
    try:
        stage = Usd.Stage.Open(str(path))
    except Exception as exc:  # pxr raises Tf errors of its own type
        raise InputError(path, f"cannot open USD: {usd_error(exc)}") from None
    if stage is None:
        raise InputError(path, "cannot open USD")
    meters = _unit(float(UsdGeom.GetStageMetersPerUnit(stage)), "metersPerUnit", path)
    kilograms = _unit(float(UsdPhysics.GetStageKilogramsPerUnit(stage)), "kilogramsPerUnit", path)
    up = str(UsdGeom.GetStageUpAxis(stage))
    reading = StageReading(stage, meters, kilograms, up, broken_arcs(stage), crate_version=crate_version(path))
    reading.warnings = unresolved_look_files(stage)
    return reading


def usd_core_warnings(diagnostics: list[str]) -> list[str]:
    """usd-core's own messages still worth a user's eye: not the crate deprecation (recorded as the file's
    ``crate_version``), not those about arcs (:class:`BrokenArc` says them), each once."""
    kept = [d for d in diagnostics
            if CRATE_DEPRECATION not in d and not any(word in d for word in _COMPOSITION_WORDS)]
    return [f"usd-core: {d[:300]}" for d in dict.fromkeys(kept)]


def needed_arcs(broken: list[BrokenArc], bodies: dict, joints: list, stage) -> list[tuple[BrokenArc, str]]:
    """The broken reference and payload arcs whose content the articulation needs, each with why: one on a rigid
    body or below it (its geometry or physics), on a joint, on or above a prim a joint names as its body that is
    no rigid body (the body was in it), or above a rigid body without any geometry.

    :param broken: :func:`broken_arcs` of the stage
    :param bodies: rigid body prims by path
    :param joints: the joint prims
    :param stage: the stage
    """
    from pxr import Sdf, Usd, UsdGeom

    def has_geometry(body) -> bool:
        return any(p.IsA(UsdGeom.Gprim) for p in Usd.PrimRange(body))

    out = []
    for arc in broken:
        if arc.kind == "sublayer":
            continue
        site = Sdf.Path(arc.prim)
        why = next((f"rigid body {b}" for b in bodies if site.HasPrefix(b)), "")
        why = why or next((f"joint {j.GetPath()}" for j in joints if j.GetPath() == site), "")
        if not why:
            targets = {t for j in joints for rel in (j.GetRelationship("physics:body0"),
                                                     j.GetRelationship("physics:body1")) if rel
                       for t in rel.GetTargets()}
            why = next((f"the body {t} a joint names" for t in sorted(targets)
                        if t.HasPrefix(site) and t not in bodies), "")
        if not why:
            why = next((f"rigid body {b}, which has no geometry" for b, prim in bodies.items()
                        if b.HasPrefix(site) and not has_geometry(prim)), "")
        if why:
            out.append((arc, why))
    return out
