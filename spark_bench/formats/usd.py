"""USD (OpenUSD with UsdPhysics): one articulated object per ``.usd``/``.usda``/``.usdc`` file, as
Infinigen-Sim, the URDF -> USD converters and the asset sets made for Isaac Sim / Isaac Lab (ArtVIP,
RoboVerse, DRAWER) write it; read with ``usd-core`` (:mod:`spark_bench.asset.usd_model`, which
:func:`spark_bench.data.load_object` uses too).

``spark-bench import usd --runs DIR``: a case's run is ``DIR/<case id>/`` holding one USD file (the newest
when there are several), or the file ``DIR/<case id>.usd`` (``.usda``, ``.usdc``, ``.usdz``). Every layer and
asset the stage references must lie inside the run folder (the file's folder for a single file).

The facts (:data:`FACTS`), each with where it comes from, are listed in ``docs/formats.md``.
"""

from __future__ import annotations

from pathlib import Path

from spark_bench.asset.usd_model import read_usd
from spark_bench.errors import InputError
from spark_bench.formats import RUN_FILE_SUFFIXES as FORMAT_RUN_FILES
from spark_bench.formats.foreign import ForeignObject

FORMAT = "usd"
#: What a case's run may be besides a folder: ``DIR/<case id><suffix>`` (:mod:`spark_bench.formats.runs`).
RUN_FILE_SUFFIXES = FORMAT_RUN_FILES[FORMAT]
INFINIGEN = "princeton-vl/infinigen"
CONVERTER = "newton-physics/urdf-usd-converter"
ISAAC_IMPORTER = "isaac-sim/urdf-importer-extension"
USD = "PixarAnimationStudios/OpenUSD"

FACTS = [
    {"fact": "stage metadata: metersPerUnit scales lengths (prismatic limits too), upAxis Y is turned to Z up "
             "(+90 deg about X), kilogramsPerUnit scales masses",
     "source": f"{USD} pxr/usd/usdGeom/metrics.h (GetStageUpAxis, GetStageMetersPerUnit); "
               "pxr/usd/usdPhysics/metrics.h (GetStageKilogramsPerUnit)"},
    {"fact": "joint axis is a token X/Y/Z of the joint frame; the direction is carried by localRot0/localRot1, "
             "the position by localPos0/localPos1 in each body's space; body0 parent, body1 child",
     "source": f"{USD} pxr/usd/usdPhysics/schema.usda (PhysicsJoint, PhysicsRevoluteJoint, "
               f"PhysicsPrismaticJoint); {INFINIGEN} infinigen/core/sim/exporters/usd_exporter.py _add_joints"},
    {"fact": "revolute limits are degrees, prismatic limits stage units; a revolute joint without limits is "
             "continuous",
     "source": f"{USD} pxr/usd/usdPhysics/schema.usda (physics:lowerLimit, physics:upperLimit); {CONVERTER} "
               "urdf_usd_converter/_impl/link.py physics_joints (math.degrees of the URDF limits)"},
    {"fact": "bodies are the prims with RigidBodyAPI; the articulation root carries ArticulationRootAPI; a "
             "fixed joint with no body0 welds the root to the world (fixed base)",
     "source": f"{CONVERTER} urdf_usd_converter/_impl/link.py convert_link, physics_joints (root_joint); "
               f"{INFINIGEN} infinigen/core/sim/exporters/usd_exporter.py _add_joints (root_joint)"},
    {"fact": "geometry: UsdGeom.Mesh (and Cube/Sphere/Cylinder/Capsule) prims below each body down to the next "
             "body; CollisionAPI prims are collision shapes (physics:approximation convexHull), the rest the "
             "visuals; MassAPI physics:mass kept where authored",
     "source": f"{INFINIGEN} usd_exporter.py _add_mesh (visual/, collision/ with CollisionAPI); {CONVERTER} "
               "urdf_usd_converter/_impl/link.py apply_inertial (MassAPI)"},
    {"fact": "Isaac Sim's URDF importer: one joint prim under each parent link, root_joint (fixed, no body0) to "
             "the world, PhysxSchema (PhysxArticulationAPI, PhysxJointAPI) beside UsdPhysics, a PhysicsDriveAPI "
             "position drive on every joint (a URDF continuous joint: an unlimited revolute joint with that drive, "
             "read as continuous), limits in degrees with negative ranges, visuals/ and collisions/ under each "
             "link, Looks/ with MDL shaders (OmniPBR.mdl, resolved from Isaac's library: a warning); binary crate "
             "0.7.0 (usd-core reads it; its deprecation message is not shown)",
     "source": f"{ISAAC_IMPORTER} source/extensions/omni.importer.urdf/plugins/import/UrdfImporter.cpp "
               "(AddSingleJoint, addJoint, addLinksAndJoints); GenSim2/GenSim2 assets/articulated_objs/*/*/mobility/"},
    {"fact": "which way a joint opens: read from where the stage draws it in its range (a range ending at the drawn "
             "pose opens toward its other end; drawn inside the range: the limit where the part leaves the rest "
             "of the object), the joint turned to open toward its upper limit",
     "source": "spark-bench (spark_bench.asset.opening_direction)"},
    {"fact": "refused, naming the prim: D6 (generic PhysicsJoint), spherical and distance joints; a drive that "
             "actuates (stiffness or target velocity) on a joint without limits, other than Isaac's importer's; an "
             "unlimited prismatic joint; instanced prims; meshes without points or faces; metersPerUnit or "
             "kilogramsPerUnit not a positive finite number; a sublayer, reference or payload that cannot be "
             "composed where the articulation needs what it holds (elsewhere a warning); look-only files "
             "(materials, shaders, textures) that do not resolve are a warning",
     "source": "spark-bench (what an articulated object's joints and parts can be)"},
]


def find_stage(run: Path) -> Path:
    """The USD file of a run: the run itself when it is a file, else the only (or newest) USD file in it.

    :raises InputError: a folder without a USD file
    """
    if run.is_file():
        return run
    files = sorted(p for p in run.iterdir() if p.suffix.lower() in RUN_FILE_SUFFIXES and p.is_file())
    if not files:
        raise InputError(run, f"no USD file ({', '.join(RUN_FILE_SUFFIXES)}) in the run folder")
    return max(files, key=lambda p: (p.stat().st_mtime, p.name))


def check_inside(stage_file: Path, run_dir: Path) -> list[str]:
    """Every layer and asset the stage references, relative to the run folder.

    :raises InputError: naming the stage when one lies outside the run folder
    """
    from pxr import UsdUtils

    from spark_bench.asset.usd_stage import quiet_usd, read_stage
    from spark_bench.formats.urdf import OUTSIDE_HINT

    with quiet_usd():  # what does not resolve is read_usd's to answer (a warning or an error naming it)
        try:
            layers, assets, _ = UsdUtils.ComputeAllDependencies(str(stage_file))
            failed = False
        except Exception:  # pxr raises Tf errors of its own type (a sublayer that is not USD)
            failed = True
        if failed:  # the layers the stage composes, opened as read_usd opens it (a file usd-core refuses: named)
            stage = read_stage(stage_file).stage  # held: a layer's handle expires with its stage
            layers, assets = stage.GetUsedLayers(), []
        files = [Path(layer.realPath) for layer in layers if layer.realPath] + [Path(a) for a in assets]
    out = []
    for file in files:
        resolved = file.resolve()
        if not resolved.is_relative_to(run_dir):
            raise InputError(stage_file, f"references {file}, which leaves the run folder {OUTSIDE_HINT}")
        out.append(str(resolved.relative_to(run_dir)))
    return list(dict.fromkeys(out))


def read_run(run_dir: Path) -> ForeignObject:
    """One run (a folder holding a USD file, or the file itself) read into our frame (Z up, metres).

    :raises InputError: naming the file and the prim for every bad input
    """
    run_dir = Path(run_dir).resolve()
    stage_file = find_stage(run_dir)
    base = stage_file.parent if run_dir.is_file() else run_dir
    files = check_inside(stage_file, base)
    asset = read_usd(stage_file)
    asset.name = run_dir.stem if run_dir.is_file() else run_dir.name
    usd = asset.meta.get("usd", {})
    record = {"format": FORMAT, "files": files, "facts": list(FACTS),
              "format_frame": f"USD stage: upAxis {usd.get('up_axis')} (turned to Z up), metersPerUnit "
                              f"{usd.get('meters_per_unit')} (lengths in metres)",
              "masses": {name: link.annotations["mass"] for name, link in asset.links.items()
                         if "mass" in link.annotations},
              "not_read": ["materials and textures (display colours only)", "drives' stiffness and damping",
                           "collision shapes (the metrics use visuals)", *asset.warnings],
              "opening_direction": asset.meta.get("opening_direction", [])}
    return ForeignObject(asset, record, articulated=bool(asset.movable_joints()),
                         open_questions=("yaw", "scale", "front"))
