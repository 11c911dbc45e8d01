"""MJCF (MuJoCo's model format): one articulated object as an MJCF file and its meshes, read through MuJoCo
itself, as PhysX-Anything, Particulate and Real2Code write it.

Read from the methods' public repositories (newest snapshots in the index). The facts, each with where
it comes from:

**PhysX-Anything** (``ziangcao0312/PhysX-Anything``, 2025-11-27), ``4_simready_gen.py``: the run folder
is ``<basepath>/<name>/`` (``__main__``); ``generate_mjcf`` writes ``basic.xml`` there: ``<compiler
angle="radian" autolimits="true">``; an asset ``mesh`` per part, ``file="./objs/<k>/<k>.obj"`` with
``scale`` = the largest of the VLM's dimensions (centimetres) / 100, so metres; a ``texture``
``./objs/<k>/material_0.png`` per part and a skybox ``./desert.png`` (copied beside it); a default class
per part (``type="mesh"``, ``contype``/``conaffinity`` 1: the same geom is the visual and the collision,
group 0); in ``worldbody`` a ``plane`` floor at z = 0, a light, the body ``base`` at ``pos="0 0 1"``
with a ``<freejoint>`` (``--fixed_base 0``, the default) and one body ``grouppart_<g>`` per moving group
(``pos="0 0 0"``), moved under its parent group's body (``reparent_by_group_info``): a ``hinge``
(``pivot_<g>``: ``axis``, ``pos`` = the point scaled like the meshes, ``range`` = the VLM's fractions
times pi, radians), a ``slide`` (``slide_<g>``: ``axis``, ``range`` as the VLM gave it, *not* scaled like
the meshes), both (group type ``CB``: hinge then slide on one body), a ``ball`` (``D``) or a free body
(``A``: its own ``<freejoint>``, moved back to ``worldbody``). ``3_split.py`` turns the decoder's
``sample.glb`` (glTF, Y up) by +90 degrees about X before cutting it into ``objs/``: the model is Z up.
``--deformable 1`` adds ``<flexcomp>`` parts (the README advises against it).

**Particulate** (``RuiningLi/particulate``, 2026-01-25): ``infer.py`` ``infer_single_mesh`` with
``--export_mjcf`` calls ``particulate/export_utils.py`` ``export_mjcf``, which writes
``<output_dir>/mjcf_<%Y%m%d_%H%M%S>/model.xml`` and ``meshes/part_<pid>.obj`` (the run folder is
``output_dir``, one per input mesh): ``<compiler angle="degree"/>``; per part a body ``link_<pid>`` (the
roots directly in ``worldbody``, children nested), ``pos`` relative to the parent's origin, no rotation;
its origin is the revolute axis's point (``plucker_to_axis_point``), else the part's mean vertex, and its
mesh is saved centred on it; one geom ``visual_<pid>`` (group 0: visual and collision); a ``hinge``
(``axis`` normalized, ``range`` = the predicted radians converted to **degrees**, ``limited="true"``, no
``pos``: at the body's origin) or a ``slide`` (``range`` in the model's units), none for a fixed part.
``infer_single_asset`` turns the input to +Z up (``--up_dir``) and scales it into a unit box
(``[-0.5, 0.5]``, largest side 1): Z up, the scale open.

**Real2Code** (``MandiZhao/real2code``, 2025-03-05): the repository holds the data processing, not the
inference that runs the fine-tuned LLM's code, so no writer of a predicted MJCF is public. Its code
representation (``data_utils/obb_helper_functions.py``, ``data_utils/obb_utils.py``
``get_mjcf_import_lines``) builds a dm_control ``mjcf.RootElement`` with ``compiler.meshdir``,
``compiler.angle = 'radian'``, ``autolimits``; a body ``root`` in ``worldbody`` holding the root part's
mesh geom, and per part a body ``link_<k>`` under it with a mesh geom and a ``joint`` of ``type``
``hinge`` or ``slide``, ``pos`` and ``axis`` in world coordinates, ``range=[0, 1]``. Its meshes carry
``refquat="0.5 -0.5 0.5 0.5"`` (``data_utils/xml_utils.py`` ``get_offset_xml``), which MuJoCo applies.
Such a file is read as one ``*.xml`` of the run folder (the layout is not the method's: not verified).

**Read through MuJoCo** (:mod:`spark_bench.asset.mjcf_model`, which :func:`spark_bench.data.load_object` uses
too): ``MjSpec.from_file`` then ``compile`` apply ``compiler
angle`` (degrees turned into radians), ``eulerseq``, ``meshdir``/``assetdir``, default classes, mesh
``scale``/``refquat``; ``mj_forward`` at ``qpos0`` gives the world-frame body poses, joint anchors
(``xanchor``) and axes (``xaxis``). Ranges are radians for hinges, metres (the model's units) for slides,
about ``qpos0`` (a joint's ``ref``). A hinge range in the other unit than the declared one is an
:class:`~spark_bench.errors.InputError` (:func:`.build.check_angle_unit`). Free and ball joints are
fixed at their rest pose (PhysX-Anything's free base: the object as placed); several hinge/slide joints
on one body become a chain through links without geometry. The visuals are the geoms of groups 0-2
(MuJoCo's viewer's default; group 3 is the collision convention), planes and height fields left out
(PhysX-Anything's floor); a body whose subtree has none (a flex's nodes) is left out. MJCF's world is
Z up (gravity ``0 0 -9.81``; all three methods build Z-up models): no rotation; the turn about Z, the
front and the scale stay open. Links and joints keep the file's names (:mod:`spark_bench.asset.mjcf_names`:
``worldbody`` for the world body, ``<body>:hinge<k>`` and the like for an element without one), and each joint
opens toward its upper limit as read from where ``qpos0`` sits in its range
(:mod:`spark_bench.asset.opening_direction`; the record's ``opening_direction``).

**Checks before MuJoCo opens a file** (:mod:`.files`): an ``<include>``, mesh, texture or other asset
path leaving the run folder, a missing include or asset, an include cycle, a file that is not
``<mujoco>`` XML.
"""

from __future__ import annotations

from pathlib import Path

from spark_bench.asset.mjcf_model import build_asset, compile_model, visual_geometry
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject
from spark_bench.formats.mjcf.files import ModelFiles, check_files, find_model

FORMAT = "mjcf"
PHYSX = "ziangcao0312/PhysX-Anything"
PARTICULATE = "RuiningLi/particulate"
REAL2CODE = "MandiZhao/real2code"

FACTS = [
    {"fact": "PhysX-Anything: <basepath>/<name>/basic.xml, angle radian, meshes ./objs/<k>/<k>.obj scaled to "
             "metres, base body at 0 0 1 with a freejoint, plane floor, hinge range = fractions x pi, slide "
             "range unscaled, CB = hinge + slide on one body, ball, free parts; Z up (sample.glb turned +90 "
             "deg about X)",
     "source": f"{PHYSX} 4_simready_gen.py generate_mjcf, reparent_by_group_info, __main__; 3_split.py"},
    {"fact": "Particulate: <output_dir>/mjcf_<timestamp>/model.xml + meshes/part_<pid>.obj, angle degree, "
             "hinge range converted from radians to degrees, body origin on the hinge axis (else the part's "
             "mean vertex), geoms group 0; Z up, unit box",
     "source": f"{PARTICULATE} particulate/export_utils.py export_mjcf; infer.py infer_single_mesh, "
               "infer_single_asset"},
    {"fact": "Real2Code: dm_control mjcf code, meshdir, angle radian, autolimits, body root > link_<k> with "
             "hinge/slide joints (world pos, axis, range [0, 1]); the inference writer is not public",
     "source": f"{REAL2CODE} data_utils/obb_helper_functions.py; data_utils/obb_utils.py "
               "get_mjcf_import_lines; data_utils/xml_utils.py get_offset_xml"},
    {"fact": "read by MuJoCo (MjSpec.from_file, compile, mj_forward at qpos0): angle unit, eulerseq, meshdir, "
             "default classes, mesh scale/refquat applied by MuJoCo; world-frame anchors (xanchor) and axes "
             "(xaxis); ranges in radians / model units about qpos0",
     "source": "MuJoCo 3.x/4.x (mujoco Python bindings: MjSpec, MjModel, MjData)"},
    {"fact": "visuals: geoms of groups 0-2 (MuJoCo viewer default), no planes or height fields; free and ball "
             "joints fixed at rest; several joints on a body: a chain through links without geometry; MJCF "
             "world Z up: no rotation, yaw, front and scale open",
     "source": "spark-bench (the reader's choices; MuJoCo's mjvOption.geomgroup default 1 1 1 0 0 0)"},
    {"fact": "names: bodies and joints keep the file's names (the world body: worldbody; unnamed: <body>:body<k>, "
             "<body>:hinge<k>, <body>:slide<k>, <body>:geom<k>); a joint whose qpos0 sits at its upper limit, or "
             "inside its range with the part leaving the object toward the lower one, is read about the opposite "
             "axis with its range negated (it opens toward its upper limit)",
     "source": "spark-bench (spark_bench.asset.mjcf_names, spark_bench.asset.opening_direction)"},
]


def relative(paths: list[Path], run_dir: Path) -> list[str]:
    """Each path relative to the run folder (in order, once)."""
    return list(dict.fromkeys(str(p.resolve().relative_to(run_dir)) for p in paths))


def read_run(run_dir: Path) -> ForeignObject:
    """One run folder holding an MJCF model (PhysX-Anything's ``basic.xml``, Particulate's
    ``mjcf_<timestamp>/model.xml``, or one ``*.xml``), read through MuJoCo (see the module docstring).

    :raises InputError: naming the file and the problem for every bad input
    """
    run_dir = Path(run_dir).resolve()
    model_path, layout, others = find_model(run_dir)
    files: ModelFiles = check_files(model_path, layout, run_dir)
    compiled = compile_model(model_path)
    geometry = visual_geometry(compiled, run_dir)
    if not geometry.meshes:
        raise InputError(model_path, "no visual geom (every geom is a plane, a height field or in groups 3-5)")
    asset, bodies = build_asset(compiled, geometry, run_dir.name)
    asset.source = str(model_path)
    flexes = int(compiled.model.nflex)
    record = {"format": FORMAT, "layout": layout,
              "files": relative([model_path, *files.includes, *files.assets], run_dir),
              "facts": list(FACTS),
              "format_frame": "MJCF world: Z up (no rotation applied)",
              "compiler": {"angle": "degree" if compiled.degree else "radian", "eulerseq": compiled.eulerseq,
                           **{k: v for k, v in files.compiler.items() if k not in ("angle", "eulerseq")}},
              "gravity": [float(v) for v in compiled.model.opt.gravity],
              "bodies": bodies, "skipped_geoms": geometry.skipped,
              "opening_direction": asset.meta.get("opening_direction", []),
              "not_read": [*(f"{p} (an older export)" for p in others),
                           *(f"{p} (texture)" for p in relative(files.textures, run_dir)),
                           *([f"{flexes} flex(es): deformable parts are not read"] if flexes else [])]}
    return ForeignObject(asset, record, articulated=True, open_questions=("yaw", "scale", "front"))
