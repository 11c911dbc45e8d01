"""Which MJCF file a run folder holds, and every file it makes MuJoCo open, checked to stay inside the run
folder *before* MuJoCo opens anything (an ``<include>`` is read while MuJoCo parses, a mesh while it
compiles).

MuJoCo's rules for file names (its XML reference, ``compiler`` and ``include``): an ``<include file>`` is
relative to the main model file's folder; ``compiler meshdir`` / ``texturedir`` (``assetdir`` sets both)
are relative to that folder too; a ``mesh``, ``skin``, ``hfield`` or ``flexcomp`` file is relative to
``meshdir``, a ``texture`` file (``file``, ``fileright``... for a cube) to ``texturedir``; an absolute
name is used as it is; ``compiler strippath="true"`` keeps only the file's name.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError

#: PhysX-Anything's ``4_simready_gen.py`` writes ``<basepath>/<name>/basic.xml``.
PHYSX_MODEL = "basic.xml"
#: Particulate's ``infer.py`` writes ``<output_dir>/mjcf_<timestamp>/model.xml`` (``--export_mjcf``).
PARTICULATE_GLOB = "mjcf_*/model.xml"
#: Elements whose files are found in ``meshdir`` (the others with a file: ``texture``, in ``texturedir``).
MESHDIR_TAGS = ("mesh", "skin", "hfield", "flexcomp")
#: Compiler settings the files and the record need (the last ``<compiler>`` giving one wins, as in MuJoCo).
COMPILER_KEYS = ("meshdir", "texturedir", "assetdir", "strippath", "angle", "eulerseq")


@dataclass
class ModelFiles:
    """The files an MJCF model names, checked.

    :param model: the main MJCF file
    :param layout: which method's layout it was found by (``PhysX-Anything``, ``Particulate``, ``one MJCF``)
    :param includes: the ``<include>`` files, in the order read
    :param assets: asset files MuJoCo opens (meshes, skins, height fields, flex meshes)
    :param textures: texture files (not read: the reader drops textures before compiling)
    :param compiler: the ``<compiler>`` attributes of :data:`COMPILER_KEYS` the files give
    :param not_read: other MJCF files of the run folder, not read
    """

    model: Path
    layout: str
    includes: list[Path] = field(default_factory=list)
    assets: list[Path] = field(default_factory=list)
    textures: list[Path] = field(default_factory=list)
    compiler: dict[str, str] = field(default_factory=dict)
    not_read: list[str] = field(default_factory=list)


def find_model(run_dir: Path) -> tuple[Path, str, list[str]]:
    """The MJCF file of a run folder: PhysX-Anything's ``basic.xml``, else Particulate's newest
    ``mjcf_<timestamp>/model.xml`` (the timestamp ``%Y%m%d_%H%M%S`` sorts by time), else the one ``*.xml``
    of the folder.

    :param run_dir: the run folder
    :returns: the file, the layout's name, the other candidates (not read)
    :raises InputError: when there is none, or several ``*.xml`` and no layout says which
    """
    if (run_dir / PHYSX_MODEL).is_file():
        return run_dir / PHYSX_MODEL, "PhysX-Anything", []
    exports = sorted(run_dir.glob(PARTICULATE_GLOB))
    if exports:
        return exports[-1], "Particulate", [str(p.relative_to(run_dir)) for p in exports[:-1]]
    candidates = sorted(p for p in run_dir.glob("*.xml") if p.is_file())
    if len(candidates) == 1:
        return candidates[0], "one MJCF", []
    if not candidates:
        raise InputError(run_dir, f"no MJCF file: neither {PHYSX_MODEL} (PhysX-Anything), {PARTICULATE_GLOB} "
                                  "(Particulate) nor one *.xml")
    raise InputError(run_dir, f"{len(candidates)} *.xml files and no layout says which is the model: "
                              f"{', '.join(p.name for p in candidates[:5])}")


def outside_hint(example: str) -> str:
    """What a refusal of a path outside the run folder says: an import reads its run folder only; a model file
    named directly (``check``, ``convert``, ``metrics``) is read as MuJoCo reads it."""
    return (f"(an import reads its run folder only: copy what the run names into it, or name the file itself: "
            f"`spark-bench check|convert|metrics {example}` reads it as MuJoCo does)")


def inside(run_dir: Path, path: Path, named_in: Path, what: str) -> Path:
    """``path`` resolved (links followed), checked to stay inside ``run_dir``.

    :param named_in: the file naming it, for the error
    :param what: what names it, for the error (``<include file="../x.xml">``)
    :raises InputError: naming ``named_in`` when the path leaves the run folder
    """
    resolved = path.resolve()
    if not resolved.is_relative_to(run_dir.resolve()):
        raise InputError(named_in, f"{what} leads out of the run folder (to {resolved}) {outside_hint('model.xml')}")
    return resolved


def parse_xml(path: Path) -> ET.Element:
    """The root element of an MJCF file.

    :raises InputError: when it is not XML, or its root is not ``<mujoco>`` (a URDF's is ``<robot>``)
    """
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise InputError(path, f"not an XML file: {' '.join(str(exc).split())[:200]}") from None
    if root.tag != "mujoco":
        hint = " (a URDF, not MJCF)" if root.tag == "robot" else ""
        raise InputError(path, f"not an MJCF file: its root element is <{root.tag}>, not <mujoco>{hint}")
    return root


def expand_includes(path: Path, run_dir: Path, base: Path, stack: tuple[Path, ...] = ()
                    ) -> tuple[list[tuple[Path, ET.Element]], list[Path]]:
    """The elements of ``path`` and of every file it includes, in document order, each with its file.

    :param base: the main model file's folder (MuJoCo resolves every include against it)
    :param stack: the files including this one (a cycle is an error)
    :returns: ``(file, element)`` pairs, and the included files read
    :raises InputError: for an include leaving the run folder, missing, not MJCF, or in a cycle
    """
    root = parse_xml(path)
    elements: list[tuple[Path, ET.Element]] = []
    includes: list[Path] = []
    for element in root.iter():
        if element.tag != "include":
            elements.append((path, element))
            continue
        name = element.get("file", "")
        target = inside(run_dir, base / name, path, f'<include file="{name}">')
        if target in stack or target == path.resolve():
            raise InputError(path, f'<include file="{name}"> makes a cycle of includes')
        if not target.is_file():
            raise InputError(path, f'<include file="{name}">: no such file')
        nested, more = expand_includes(target, run_dir, base, (*stack, path.resolve()))
        elements += [(f, e) for f, e in nested if e.tag != "mujoco"]  # an included file's own root
        includes += [target, *more]
    return elements, includes


def compiler_settings(elements: list[tuple[Path, ET.Element]]) -> dict[str, str]:
    """The ``<compiler>`` attributes of :data:`COMPILER_KEYS`, later elements overriding earlier ones."""
    out: dict[str, str] = {}
    for _, element in elements:
        if element.tag == "compiler":
            out.update({k: v for k, v in element.attrib.items() if k in COMPILER_KEYS})
    return out


def asset_folders(base: Path, compiler: dict[str, str]) -> tuple[Path, Path]:
    """``(meshdir, texturedir)`` as MuJoCo resolves them (``assetdir`` when one is not given)."""
    assetdir = compiler.get("assetdir", "")
    return base / compiler.get("meshdir", assetdir), base / compiler.get("texturedir", assetdir)


def check_files(model: Path, layout: str, run_dir: Path) -> ModelFiles:
    """Every file ``model`` makes MuJoCo open, checked (see the module docstring).

    :param model: the main MJCF file
    :param layout: its layout's name (:func:`find_model`)
    :param run_dir: the run folder
    :raises InputError: naming the file that names a path leaving the run folder, or an asset that is
        missing
    """
    inside(run_dir, model, model, "the model file (a link)")
    base = model.parent
    elements, includes = expand_includes(model, run_dir, base)
    compiler = compiler_settings(elements)
    meshdir, texturedir = asset_folders(base, compiler)
    strip = compiler.get("strippath", "false").lower() == "true"
    found = ModelFiles(model, layout, includes=includes, compiler=compiler)
    for path, element in elements:
        for key, name in element.attrib.items():
            if not key.startswith("file") or not name:
                continue
            folder = meshdir if element.tag in MESHDIR_TAGS else texturedir if element.tag == "texture" else base
            target = inside(run_dir, folder / (Path(name).name if strip else name), path,
                            f'<{element.tag} {key}="{name}">')
            if element.tag == "texture":
                found.textures.append(target)
                continue
            if not target.is_file():
                raise InputError(path, f'<{element.tag} {key}="{name}">: no such file ({target})')
            found.assets.append(target)
    return found
