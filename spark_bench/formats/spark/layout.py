"""SPARK's output folder as SPARK's public code writes it: names, stages, and which file each stage writes.

Read from the code, not guessed. The SPARK code is the public copy ``mebam1/spark`` (its ``run.py`` is
the one SPARK's README describes); its joint optimizer is ``URDFoptimizer/`` of ``YumengHe/PartCrafter``.

**run.py** has no command-line flags: module constants configure it (``RUNALL = True``, ``NAMES``,
``INPUT_DIR = "./image"``, ``OUTPUT_DIR = "./output"``, ``CSV_PATH =
"./VLMguidance/partnet-mobility-data-analysis.csv"``, ``SEED = 42``, ``IMAGE_GEN_TEMPERATURE = 1.0``,
``IMAGE_GEN_SEED = None``, ``CUDA_DEVICE = "0"``, ``INFERENCE_SEED = 0``, ``GUIDANCE_SCALE = 1``,
``INFERENCE_TAG = f"FT5_G1_{INFERENCE_SEED}"``, ``NUM_INFERENCE_STEPS = 1000``, flags ``step1`` ..
``step9`` and ``step8b``). Every script path is relative (``python VLMguidance/generate_json.py``), so it
runs with SPARK's folder as working directory. Every image ``image/<name>.{png,jpeg,jpg}`` becomes
``output/<name>_<RUN_TIMESTAMP>/`` (``time.strftime("%Y%m%d_%H%M%S")``, one timestamp for the whole
run), with the image copied there as ``input.png``. Every stage is ``subprocess.run(cmd)`` without
``check``: ``run.py`` exits 0 whatever fails, and the only sign of a failed stage is its missing output.

The stages (:data:`STAGES`), their scripts and real flags, and what they write into the run folder RUN:

1. ``structure`` (step1) ``VLMguidance/generate_json.py --input RUN/input.png --output RUN/metadata.json
   --csv CSV --seed 42``: ``metadata.json`` = ``{"object_name", "num_parts", "parts": [{"label": "link0",
   "name", "parent": "base", "joint_type": "fixed", "axis": "0 0 0", "limit_lower", "limit_upper"},
   {"label": "link1", "parent": "link0", "joint_type": "revolute"|"prismatic", "axis": "0 -1 0", ...}]}``.
   Its prompt fixes the frame: "Camera/image axes: +x right, +y up, +z front (toward camera)"; axes are
   one of the six canonical vectors; revolute limits in radians, prismatic in metres, ``limit_lower`` 0.
2. ``axes`` (step2) ``VLMguidance/repredict_axis.py --input RUN --image input.png --single``: rewrites
   ``metadata.json`` in place (joint types and axes; exit 1 on failure). It leaves no file of its own,
   so its failure cannot be seen from the files.
3. ``urdf`` (step3) ``VLMguidance/generate_urdf.py --input-dir RUN --single [--mesh-dir D
   --mesh-pattern P --mesh-map F --absolute-mesh-paths]``: ``mobility.urdf``, written before any mesh
   exists: an empty ``<link name="base"/>``; one link per part named by its label (``link0`` the body);
   joints ``{parent}_to_{label}``; origins ``xyz="0 0 0" rpy="0 0 0"`` unless the metadata gives
   ``origin_xyz``/``origin_rpy`` (no PartNet-Mobility root rotation); ``<axis>`` only on movable joints;
   ``<limit lower upper effort="100" velocity="1.0"/>`` on revolute and prismatic ones; visuals
   ``<mesh filename="part_{index:02d}.glb"/>`` relative to RUN (the index is N of a label ``linkN``),
   where no mesh ever is; no ``<collision>``.
4. ``part_prompts`` (step4) ``VLMguidance/generate_prompt_part.py --input RUN``: ``prompt_part.json``
   ``{"object_name", "reference_image": "input.png", "prompts": {label: text}}``.
5. ``part_images`` (step5) ``VLMguidance/generate_image_part.py --input RUN --part LABEL --temperature T
   [--seed S]`` per prompt label: ``LABEL.png`` (``link0.png``, ...).
6. ``inference`` (step6) ``scripts/inference/part_images.py --image_folder RUN --output_dir RUN/inference
   --tag TAG --seed 0 --num_inference_steps 1000 --guidance_scale 1 --render`` with
   ``CUDA_VISIBLE_DEVICES`` and ``PYTHONPATH`` = SPARK's folder: reads ``link{i}.png`` for i < num_parts
   and ``input.png`` (global image); writes ``inference/TAG/part_{i:02}.glb``, ``object.glb``, renders.
   A part the model returns as None becomes a one-vertex degenerate mesh (no surface).
7. ``clean`` (step7) ``src/utils/clean_mesh.py --in_mesh part_NN.glb --out_mesh part_NN_cleaned.glb
   --keep_largest --merge_tol 1e-5 --target_faces 200000`` per ``inference/TAG/part_*.glb``.
8. ``open_prompt`` (step8) ``VLMguidance/generate_prompt_open.py --input RUN``: ``prompt_open.json``.
9. ``open_image`` (step8b) ``VLMguidance/generate_image_open.py --input RUN --temperature T [--seed S]``:
   ``open.png``.
10. ``retexture`` (step9, first half) ``VLMguidance/generate_texture.py --image RUN/input.png --model
    part_NN_cleaned.glb --outdir inference/TAG/part_NN_cleaned_texture`` (Meshy): a GLB somewhere under
    that folder (``<task id>/``).
11. ``align_texture`` (step9, second half) ``VLMguidance/align_glb.py --reference part_NN_cleaned.glb
    --target <first textured GLB> --output inference/TAG/part_NN_cleaned_textured_aligned.glb``: the
    textured mesh scaled (largest box side) and centred onto the cleaned one.

``optimize`` is not a ``run.py`` stage: ``URDFoptimizer/optimize_urdf_joint_v4.py --urdf U --joint-name J
--opened-img open.png --closed-img input.png [--out-urdf O]`` fits the pivot of one revolute joint to
the open image's silhouette and writes ``<urdf stem>_optimized.urdf`` (``update_urdf_joint_and_child``):
the joint origin's xyz becomes the fitted pivot ``t`` and the child's visual (and collision) origin
``-t`` (so the rest pose is unchanged), written by ElementTree (two-space indent, ``%.8f``). It treats
the parent link as the world (identity), renders from (0, 0, 4) looking down -Z (front +Z towards the
camera), and loads meshes where the URDF points (``FileNotFoundError`` otherwise). The fork's
``outputs/test*/`` hold real input/output URDFs of it in PartNet-Mobility style (``link_k``, ``joint_k``,
a root joint ``rpy="1.570796326794897 0 -1.570796326794897"``, visuals with collisions). The newer
``run_articulation.py`` of ``mebam1/spark`` writes ``mobility_refined.urdf`` instead.

**Frames.** PartCrafter's meshes live in its normalized space (``normalize_mesh``: box centred, largest
side 2), Y up, front +Z: PartNet-Mobility's mesh convention (the fork's ``outputs/test3/readme.md``:
front +z, up +y, right +x). The VLM's image frame (+x right, +y up, +z towards the camera) is taken to be
that same frame, so SPARK's joints and meshes share one frame. PartNet-Mobility's root joint
``rpy="1.570796 0 -1.570796"`` maps it to ours (Z up, front -X): :data:`SPARK_TO_PARTNET`.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# ----- run.py's constants and folder names ---------------------------------------------------------
IMAGE_DIR = "image"
OUTPUT_DIR = "output"
IMAGE_EXTENSIONS = (".png", ".jpeg", ".jpg")
CSV_PATH = "./VLMguidance/partnet-mobility-data-analysis.csv"
SEED = 42
IMAGE_GEN_TEMPERATURE = 1.0
CUDA_DEVICE = "0"
INFERENCE_SEED = 0
GUIDANCE_SCALE = 1
NUM_INFERENCE_STEPS = 1000
DEFAULT_TAG = f"FT5_G1_{INFERENCE_SEED}"
TIMESTAMP_FORMAT = "%Y%m%d_%H%M%S"
#: ``<name>_<YYYYmmdd_HHMMSS>``: the name may itself contain underscores.
RUN_NAME = re.compile(r"^(?P<name>.+)_(?P<stamp>\d{8}_\d{6})$")

# ----- files of a run folder ---------------------------------------------------------------------------
INPUT = "input.png"
METADATA = "metadata.json"
URDF = "mobility.urdf"
PROMPT_PART = "prompt_part.json"
PROMPT_OPEN = "prompt_open.json"
OPEN = "open.png"
INFERENCE_DIR = "inference"
OPTIMIZED_SUFFIX = "_optimized.urdf"
REFINED_URDF = "mobility_refined.urdf"
BASE_LINK = "base"
#: Written by :mod:`spark_bench.methods.ours.run_spark` into the run folders it makes.
DRIVER_RECORD = "spark_bench_driver.json"

#: A part's mesh files in the order the reader prefers them: ``(variant, file name pattern)``.
MESH_VARIANTS = (
    ("textured_aligned", "{stem}_cleaned_textured_aligned.glb"),
    ("cleaned", "{stem}_cleaned.glb"),
    ("raw", "{stem}.glb"),
)
_VARIANT_SUFFIXES = ("_cleaned_textured_aligned", "_cleaned")

#: SPARK's frame (Y up, front +Z) to PartNet-Mobility's world (Z up, front -X): the rotation of the
#: PartNet-Mobility root joint ``rpy="1.570796 0 -1.570796"`` (columns: the images of SPARK's x, y, z).
SPARK_TO_PARTNET = np.array([[0.0, 0.0, -1.0],
                             [-1.0, 0.0, 0.0],
                             [0.0, 1.0, 0.0]])


def part_stem(index: int) -> str:
    """``part_NN``: PartCrafter's mesh of part ``index`` (``export_mesh_outputs``)."""
    return f"part_{int(index):02d}"


def base_stem(filename: str) -> str:
    """The part stem of a mesh file name: ``part_00`` for ``part_00_cleaned_textured_aligned.glb``."""
    stem = Path(filename).stem
    for suffix in _VARIANT_SUFFIXES:
        if stem.endswith(suffix):
            return stem[: -len(suffix)]
    return stem


def link_index(label: str, position: int) -> int:
    """The mesh index of a part, as ``generate_urdf.py`` computes it: N of a label ``linkN``, else the
    part's position in ``metadata.json``."""
    if "link" in label:
        digits = label.replace("link", "")
        if digits.isdigit():
            return int(digits)
    return position


def joint_name(parent: str, label: str) -> str:
    """``generate_urdf.py``'s joint name."""
    return f"{parent}_to_{label}"


def texture_dir(stem: str) -> str:
    """Meshy's download folder of a cleaned part (inside ``inference/TAG/``)."""
    return f"{stem}_cleaned_texture"


def run_folder_name(name: str, stamp: str) -> str:
    """``<name>_<stamp>``, the folder ``run.py`` makes for image ``<name>``."""
    return f"{name}_{stamp}"


def parse_run_name(folder_name: str) -> tuple[str, str] | None:
    """``(image name, timestamp)`` of a run folder name, or None when it is not one."""
    match = RUN_NAME.match(folder_name)
    return (match["name"], match["stamp"]) if match else None


# ----- stages and their outputs ------------------------------------------------------------------------
@dataclass(frozen=True)
class Stage:
    """One SPARK stage.

    :param name: our name for it
    :param step: the ``run.py`` flag that enables it (empty: not a ``run.py`` stage)
    :param script: the script, relative to SPARK's folder
    :param writes: what it writes, for messages
    """

    name: str
    step: str
    script: str
    writes: str


STAGES = (
    Stage("structure", "step1", "VLMguidance/generate_json.py", METADATA),
    Stage("axes", "step2", "VLMguidance/repredict_axis.py", f"{METADATA} (in place)"),
    Stage("urdf", "step3", "VLMguidance/generate_urdf.py", URDF),
    Stage("part_prompts", "step4", "VLMguidance/generate_prompt_part.py", PROMPT_PART),
    Stage("part_images", "step5", "VLMguidance/generate_image_part.py", "link{i}.png"),
    Stage("inference", "step6", "scripts/inference/part_images.py", f"{INFERENCE_DIR}/TAG/part_NN.glb"),
    Stage("clean", "step7", "src/utils/clean_mesh.py", f"{INFERENCE_DIR}/TAG/part_NN_cleaned.glb"),
    Stage("open_prompt", "step8", "VLMguidance/generate_prompt_open.py", PROMPT_OPEN),
    Stage("open_image", "step8b", "VLMguidance/generate_image_open.py", OPEN),
    Stage("retexture", "step9", "VLMguidance/generate_texture.py", f"{INFERENCE_DIR}/TAG/part_NN_cleaned_texture/**/*.glb"),
    Stage("align_texture", "step9", "VLMguidance/align_glb.py",
          f"{INFERENCE_DIR}/TAG/part_NN_cleaned_textured_aligned.glb"),
    Stage("optimize", "", "URDFoptimizer/optimize_urdf_joint_v4.py", "mobility_optimized.urdf"),
)
STAGE_NAMES = tuple(s.name for s in STAGES)
#: What ``run.py`` runs with every step flag on (``optimize`` is not one of its stages).
RUN_PY_STAGES = tuple(s.name for s in STAGES if s.step)
#: Group names accepted wherever stages are named.
STAGE_GROUPS = {"texture": ("retexture", "align_texture"), "open": ("open_prompt", "open_image")}


def stage(name: str) -> Stage:
    """The stage called ``name`` (KeyError otherwise)."""
    for s in STAGES:
        if s.name == name:
            return s
    raise KeyError(name)


def read_metadata(run_dir: Path) -> dict | None:
    """``metadata.json`` as a dict, or None when it is absent or unreadable."""
    try:
        data = json.loads((Path(run_dir) / METADATA).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def part_labels(metadata: dict | None) -> list[str]:
    """The part labels of ``metadata.json`` in file order (``link0``, ``link1``, ...)."""
    parts = (metadata or {}).get("parts")
    if not isinstance(parts, list):
        return []
    return [str(p.get("label", f"link{i}")) if isinstance(p, dict) else f"link{i}" for i, p in enumerate(parts)]


def num_parts(metadata: dict | None) -> int:
    """``num_parts`` as ``part_images.py`` reads it (``generate_json.py`` sets it to ``len(parts)``)."""
    value = (metadata or {}).get("num_parts")
    try:
        return int(value)
    except (TypeError, ValueError):
        return len(part_labels(metadata))


def stage_outputs(run_dir: Path, name: str, tag: str = DEFAULT_TAG, metadata: dict | None = None) -> list[Path]:
    """The files stage ``name`` must leave in ``run_dir`` (empty when that cannot be told from files:
    ``axes`` edits ``metadata.json`` in place; per-part stages need ``metadata.json``'s part count).

    :param metadata: ``metadata.json`` if already read
    """
    run_dir = Path(run_dir)
    metadata = read_metadata(run_dir) if metadata is None else metadata
    parts = range(num_parts(metadata))
    tag_dir = run_dir / INFERENCE_DIR / tag
    simple = {"structure": METADATA, "urdf": URDF, "part_prompts": PROMPT_PART, "open_prompt": PROMPT_OPEN,
              "open_image": OPEN}
    if name in simple:
        return [run_dir / simple[name]]
    if name == "part_images":  # what the inference stage reads (get_part_image_paths)
        return [run_dir / f"link{i}.png" for i in parts]
    if name == "inference":
        return [tag_dir / f"{part_stem(i)}.glb" for i in parts]
    if name == "clean":
        return [tag_dir / f"{part_stem(i)}_cleaned.glb" for i in parts]
    if name == "retexture":  # a folder holding some GLB
        return [tag_dir / texture_dir(part_stem(i)) for i in parts]
    if name == "align_texture":
        return [tag_dir / f"{part_stem(i)}_cleaned_textured_aligned.glb" for i in parts]
    if name == "optimize":
        return [run_dir / (Path(URDF).stem + OPTIMIZED_SUFFIX)]
    if name == "axes":
        return []
    raise KeyError(name)


def output_present(path: Path) -> bool:
    """Whether a stage output is there: a non-empty file, or (``retexture``) a folder with a GLB in it."""
    path = Path(path)
    if path.is_dir():
        return any(path.rglob("*.glb"))
    return path.is_file() and path.stat().st_size > 0


@dataclass
class RunDiagnosis:
    """Which ``run.py`` stages left their outputs in a run folder.

    :param failed_stage: the first stage (``run.py`` order) whose output is missing, or None
    :param missing: stage name -> the missing outputs (relative to the run folder)
    :param done: the stages whose outputs are all present
    """

    failed_stage: str | None
    missing: dict[str, list[str]] = field(default_factory=dict)
    done: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"failed_stage": self.failed_stage, "missing": self.missing, "done": self.done}


def diagnose(run_dir: Path, tag: str = DEFAULT_TAG, stages=RUN_PY_STAGES) -> RunDiagnosis:
    """Tell from the files present which stage of a run failed (``run.py`` exits 0 regardless).

    :param run_dir: the run folder
    :param tag: the inference tag (``inference/<tag>/``)
    :param stages: the stages expected to have run, in order
    """
    run_dir = Path(run_dir)
    metadata = read_metadata(run_dir)
    out = RunDiagnosis(None)
    if not (run_dir / INPUT).is_file():
        out.failed_stage = "input"
        out.missing["input"] = [INPUT]
    for name in stages:
        if name == "axes":
            continue
        if metadata is None and name not in ("structure", "urdf", "part_prompts", "open_prompt", "open_image"):
            missing = [METADATA]  # a per-part stage cannot be checked without the part count
        else:
            missing = [str(p.relative_to(run_dir)) for p in stage_outputs(run_dir, name, tag, metadata)
                       if not output_present(p)]
            if not missing and not stage_outputs(run_dir, name, tag, metadata):
                missing = [f"{METADATA} (lists no parts)"]
        if missing:
            out.missing[name] = missing
            out.failed_stage = out.failed_stage or name
        else:
            out.done.append(name)
    return out
