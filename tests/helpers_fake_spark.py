"""A fake SPARK, written by the tests with SPARK's real layout, names, frame and failure behaviour.

:func:`write_fake_run` writes what SPARK's ``run.py`` leaves in ``output/<case id>_<YYYYmmdd_HHMMSS>/``
for a ground-truth object: ``metadata.json`` (the VLM's structure, axes as canonical image-frame
vectors), ``mobility.urdf`` exactly as ``generate_urdf.py`` writes it (empty ``base``, ``link0`` the
body, joints ``{parent}_to_{label}``, origins zero, visuals ``part_NN.glb`` beside the URDF where no
mesh is), the prompts and part images, ``open.png``, and ``inference/<TAG>/part_NN.glb``,
``part_NN_cleaned.glb``, ``part_NN_cleaned_texture/<task>/model.glb`` and
``part_NN_cleaned_textured_aligned.glb``; optionally ``mobility_optimized.urdf`` as
``optimize_urdf_joint_v4.py`` writes it (joint origin ``t``, child visual origin ``-t``). The meshes are
the ground truth's parts mapped into SPARK's frame (Y up, front +Z) by a turn about the up axis, a scale
and a shift, in another order than the ground truth's. Stages can be left out, and single GLBs deleted,
as a failed SPARK stage leaves them (``run.py`` still exits 0).

:func:`write_fake_checkout` writes a SPARK checkout whose stage scripts, at SPARK's real paths, parse
SPARK's real flags (a wrong flag fails like the real script) and copy their outputs from such a run.
"""

from __future__ import annotations

import json
import math
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.mesh import merge_meshes
from spark_bench.asset.transforms import transform_points
from spark_bench.formats.spark import layout
from spark_bench.metrics.geometry import part_links

TAG = layout.DEFAULT_TAG
STAMP = "20250101_120000"


def rotation_z(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])


def to_spark(yaw_deg: float = 0.0, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 from our frame (Z up, front -X) to a SPARK frame (Y up, front +Z) turned by ``-yaw`` about up:
    importing it (``SPARK_TO_PARTNET``) gives our object turned by ``-yaw`` about Z, scaled and shifted."""
    out = np.eye(4)
    out[:3, :3] = scale * layout.SPARK_TO_PARTNET.T @ rotation_z(-yaw_deg)
    out[:3, 3] = offset
    return out


def axis_text(direction) -> str:
    """An axis as ``metadata.json`` writes it (``"0 -1 0"``); canonical vectors stay integers."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    rounded = np.round(d)
    if np.allclose(d, rounded, atol=1e-9):
        d = rounded
    return " ".join(f"{v:g}" if v != 0 else "0" for v in d)


def generate_urdf_text(metadata: dict) -> str:
    """``VLMguidance/generate_urdf.py``'s ``generate_urdf_content`` for the default mesh pattern."""
    lines = ['<?xml version="1.0"?>', f'<robot name="{metadata.get("object_name", "object")}">',
             '  <link name="base"/>', '']
    for i, part in enumerate(metadata["parts"]):
        label = part.get("label", f"link{i}")
        parent = part.get("parent", "base")
        joint_type = part.get("joint_type", "fixed")
        index = layout.link_index(label, i)
        lines += [f'  <link name="{label}">', '    <visual>', '      <geometry>',
                  f'        <mesh filename="part_{index:02d}.glb"/>', '      </geometry>',
                  '      <origin xyz="0 0 0" rpy="0 0 0"/>', '    </visual>', '  </link>', '',
                  f'  <joint name="{parent}_to_{label}" type="{joint_type}">', f'    <parent link="{parent}"/>',
                  f'    <child link="{label}"/>', '    <origin xyz="0 0 0" rpy="0 0 0"/>']
        if joint_type in ("revolute", "prismatic", "continuous"):
            lines.append(f'    <axis xyz="{part.get("axis", "0 0 0")}"/>')
            if joint_type in ("revolute", "prismatic"):
                lines.append(f'    <limit lower="{part.get("limit_lower", "0")}" upper="{part.get("limit_upper", "0")}"'
                             ' effort="100" velocity="1.0"/>')
        lines += ['  </joint>', '']
    lines.append('</robot>')
    return "\n".join(lines)


def optimize_joint(urdf: Path, joint_name: str, delta, out: Path) -> None:
    """``optimize_urdf_joint_v4.py``'s ``update_urdf_joint_and_child`` (joint origin rpy is zero here)."""
    tree = ET.parse(urdf)
    root = tree.getroot()
    joint = root.find(f"./joint[@name='{joint_name}']")
    jorigin = joint.find("origin")
    xyz = np.array([float(v) for v in jorigin.attrib.get("xyz", "0 0 0").split()]) + np.asarray(delta)
    jorigin.attrib["xyz"] = f"{xyz[0]:.8f} {xyz[1]:.8f} {xyz[2]:.8f}"
    child = root.find(f"./link[@name='{joint.find('child').attrib['link']}']")
    for element in [child.find("visual")] + child.findall("collision"):
        if element is None:
            continue
        origin = element.find("origin")
        if origin is None:
            origin = ET.SubElement(element, "origin")
        v = np.array([float(x) for x in origin.attrib.get("xyz", "0 0 0").split()]) - np.asarray(delta)
        origin.attrib["xyz"] = f"{v[0]:.8f} {v[1]:.8f} {v[2]:.8f}"
    ET.indent(tree, space="  ", level=0)
    tree.write(out, encoding="utf-8", xml_declaration=True)


def write_glb(path: Path, mesh: trimesh.Trimesh) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(file_type="glb"))


def spark_parts(gt, order: list[str] | None = None) -> list[tuple[str | None, list[str]]]:
    """SPARK's parts of ``gt`` as ``(gt joint or None for the body, gt links)``, body first, then the
    movable joints in ``order`` (default: reversed, so the order differs from the ground truth's)."""
    joints = [j.name for j in gt.movable_joints()]
    order = list(reversed(joints)) if order is None else list(order)
    moving = {link for name in joints for link in part_links(gt, name)}
    body = [name for name in gt.links if name not in moving and gt.links[name].has_geometry]
    return [(None, body)] + [(name, part_links(gt, name)) for name in order]


def write_fake_run(runs_dir: Path, case_id: str, gt, *, case=None, stamp: str = STAMP, yaw_deg: float = 0.0,
                   scale: float = 0.8, offset=(0.05, -0.1, 0.02), order=None, stages=layout.RUN_PY_STAGES,
                   optimized: bool = True, delete: tuple[str, ...] = (), tag: str = TAG,
                   folder: Path | None = None) -> Path:
    """Write one fake SPARK run of ``gt`` (see the module docstring).

    :param case: the :class:`~spark_bench.data.case.BenchmarkCase` whose images are copied (else blank)
    :param stages: the stages whose outputs exist (a stage left out is one that failed or was off)
    :param optimized: also write ``mobility_optimized.urdf`` with the true pivots
    :param delete: files to remove afterwards (relative to the run), as a failed stage leaves them
    :param folder: write here instead of ``runs_dir/<case id>_<stamp>`` (a fake checkout's canned run)
    :returns: the run folder
    """
    run = Path(folder) if folder is not None else Path(runs_dir) / layout.run_folder_name(case_id, stamp)
    run.mkdir(parents=True, exist_ok=True)
    matrix = to_spark(yaw_deg, scale, offset)
    world = gt.link_meshes()
    frames = gt.joint_frames()

    def image(target: Path, source=None) -> None:
        if source is not None and Path(source).is_file():
            shutil.copyfile(source, target)
        else:
            from PIL import Image
            Image.new("RGB", (8, 8), "white").save(target)

    image(run / layout.INPUT, case.input_image if case else None)
    parts, meta_parts, pivots = spark_parts(gt, order), [], {}
    for i, (joint_name, _) in enumerate(parts):
        label = f"link{i}"
        if joint_name is None:
            meta_parts.append({"label": label, "name": "body", "parent": "base", "joint_type": "fixed",
                               "axis": "0 0 0", "limit_lower": "0", "limit_upper": "0"})
            continue
        joint = gt.joints[joint_name]
        point, direction = frames[joint_name]
        upper = joint.upper * (scale if joint.type == "prismatic" else 1.0)
        meta_parts.append({"label": label, "name": gt.links[joint.child].label or "part", "parent": "link0",
                           "joint_type": joint.type, "axis": axis_text(matrix[:3, :3] @ direction),
                           "limit_lower": "0", "limit_upper": repr(float(upper))})
        pivots[f"link0_to_{label}"] = transform_points(matrix, point[None])[0].tolist()
    metadata = {"object_name": gt.category or "StorageFurniture", "num_parts": len(parts), "parts": meta_parts}
    if "structure" in stages:
        (run / layout.METADATA).write_text(json.dumps(metadata, indent=2))
    if "urdf" in stages:
        (run / layout.URDF).write_text(generate_urdf_text(metadata))
        if optimized:
            source = run / layout.URDF
            for name, pivot in pivots.items():
                if gt.joints[parts[int(name.split("link")[-1])][0]].type == "revolute":
                    out = run / "mobility_optimized.urdf"
                    optimize_joint(source, name, pivot, out)
                    source = out
    if "part_prompts" in stages:
        prompts = {p["label"]: f"an isolated {p['name']}, front view, white background" for p in meta_parts}
        (run / layout.PROMPT_PART).write_text(json.dumps({"object_name": metadata["object_name"],
                                                          "reference_image": "input.png", "prompts": prompts}))
    if "part_images" in stages:
        for p in meta_parts:
            image(run / f"{p['label']}.png")
    tag_dir = run / layout.INFERENCE_DIR / tag
    for i, (_, links) in enumerate(parts):
        mesh = merge_meshes([world[n] for n in links if n in world])
        mesh = trimesh.Trimesh(transform_points(matrix, mesh.vertices), mesh.faces, process=False)
        stem = layout.part_stem(i)
        if "inference" in stages:
            write_glb(tag_dir / f"{stem}.glb", mesh)
        if "clean" in stages:
            write_glb(tag_dir / f"{stem}_cleaned.glb", mesh)
        if "retexture" in stages:
            write_glb(tag_dir / layout.texture_dir(stem) / "0191a2b3" / "model.glb", mesh)
        if "align_texture" in stages:
            write_glb(tag_dir / f"{stem}_cleaned_textured_aligned.glb", mesh)
    if "open_prompt" in stages:
        (run / layout.PROMPT_OPEN).write_text(json.dumps({"prompt": "the same object with every part opened"}))
    if "open_image" in stages:
        image(run / layout.OPEN, case.open_image if case else None)
    (run / "pivots.json").write_text(json.dumps(pivots))  # the fake optimizer's answers (not SPARK's)
    for name in delete:
        (run / name).unlink()
    return run


# ----- a fake SPARK checkout ---------------------------------------------------------------------------------
_PRELUDE = '''import argparse, json, os, shutil, sys
from pathlib import Path
CANNED = Path(__file__).resolve().parents[{depth}] / "canned"
def canned(run):  # the canned run folder of this run's case
    name = Path(run).resolve().name
    return CANNED / name.rsplit("_", 2)[0]
def copy(src, dst):
    if Path(src).is_file():
        Path(dst).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)
p = argparse.ArgumentParser()
'''

SCRIPTS = {
    "VLMguidance/generate_json.py": '''
p.add_argument("--input", required=True); p.add_argument("--output"); p.add_argument("--csv", required=True)
p.add_argument("--seed", type=int); a = p.parse_args()
assert Path(a.csv).is_file(), "run from SPARK's folder: the CSV path is relative"
copy(canned(Path(a.input).parent) / "metadata.json", a.output)
''',
    "VLMguidance/repredict_axis.py": '''
p.add_argument("--input", required=True); p.add_argument("--image", default="rendering.png")
p.add_argument("--single", action="store_true"); p.add_argument("--seed", type=int); a = p.parse_args()
sys.exit(0 if (Path(a.input) / "metadata.json").is_file() else 1)
''',
    "VLMguidance/generate_urdf.py": '''
p.add_argument("--input-dir", required=True); p.add_argument("--single", action="store_true")
p.add_argument("--mesh-dir"); p.add_argument("--mesh-pattern", default="part_{index:02d}.glb")
p.add_argument("--mesh-map"); p.add_argument("--quiet", action="store_true"); a = p.parse_args()
run = Path(a.input_dir)
if (run / "metadata.json").is_file():
    text = (canned(run) / "mobility.urdf").read_text()
    if a.mesh_dir:
        for i in range(64):
            rel = os.path.relpath(Path(a.mesh_dir) / a.mesh_pattern.format(index=i), run)
            text = text.replace(f'"part_{i:02d}.glb"', '"' + rel + '"')
    (run / "mobility.urdf").write_text(text)
''',
    "VLMguidance/generate_prompt_part.py": '''
p.add_argument("--input", required=True); p.add_argument("--output", default="prompt_part.json"); a = p.parse_args()
copy(canned(a.input) / "prompt_part.json", Path(a.input) / a.output)
''',
    "VLMguidance/generate_image_part.py": '''
p.add_argument("--input", required=True); p.add_argument("--part", required=True)
p.add_argument("--temperature", type=float); p.add_argument("--seed", type=int); a = p.parse_args()
copy(canned(a.input) / f"{a.part}.png", Path(a.input) / f"{a.part}.png")
''',
    "scripts/inference/part_images.py": '''
for flag in ("--image_folder", "--output_dir", "--tag"): p.add_argument(flag, required=True)
p.add_argument("--seed", type=int); p.add_argument("--num_inference_steps", type=int)
p.add_argument("--guidance_scale", type=float); p.add_argument("--render", action="store_true"); a = p.parse_args()
assert os.environ.get("CUDA_VISIBLE_DEVICES") is not None
assert os.getcwd() in os.environ.get("PYTHONPATH", "").split(":")
src = canned(a.image_folder) / "inference" / a.tag
out = Path(a.output_dir) / a.tag
out.mkdir(parents=True, exist_ok=True)
for mesh in sorted(src.glob("part_*.glb")):
    if mesh.stem[5:].isdigit():
        copy(mesh, out / mesh.name)
''',
    "src/utils/clean_mesh.py": '''
p.add_argument("--in_mesh", required=True); p.add_argument("--out_mesh", required=True)
p.add_argument("--keep_largest", action="store_true"); p.add_argument("--merge_tol", type=float)
p.add_argument("--target_faces", type=int); a = p.parse_args()
copy(canned(Path(a.in_mesh).parents[2]) / "inference" / Path(a.in_mesh).parent.name / Path(a.out_mesh).name,
     a.out_mesh)
''',
    "VLMguidance/generate_prompt_open.py": '''
p.add_argument("--input", required=True); p.add_argument("--output", default="prompt_open.json")
p.add_argument("--seed", type=int); a = p.parse_args()
copy(canned(a.input) / "prompt_open.json", Path(a.input) / a.output)
''',
    "VLMguidance/generate_image_open.py": '''
p.add_argument("--input", required=True); p.add_argument("--temperature", type=float)
p.add_argument("--seed", type=int); a = p.parse_args()
copy(canned(a.input) / "open.png", Path(a.input) / "open.png")
''',
    "VLMguidance/generate_texture.py": '''
p.add_argument("--image", required=True); p.add_argument("--model", required=True)
p.add_argument("--outdir", default="./meshy_output"); a = p.parse_args()
src = canned(Path(a.model).parents[2]) / "inference" / Path(a.model).parent.name / Path(a.outdir).name
for mesh in sorted(src.glob("**/*.glb")):
    copy(mesh, Path(a.outdir) / mesh.relative_to(src))
''',
    "VLMguidance/align_glb.py": '''
p.add_argument("--reference", required=True); p.add_argument("--target", required=True)
p.add_argument("--output", required=True); a = p.parse_args()
copy(canned(Path(a.output).parents[2]) / "inference" / Path(a.output).parent.name / Path(a.output).name, a.output)
''',
    "URDFoptimizer/optimize_urdf_joint_v4.py": '''
p.add_argument("--urdf", required=True); p.add_argument("--joint-name"); p.add_argument("--opened-img")
p.add_argument("--closed-img"); p.add_argument("--out-urdf"); p.add_argument("--iters", type=int); a = p.parse_args()
import xml.etree.ElementTree as ET
sys.path.insert(0, str(CANNED.parent)); from fake_optimizer import optimize_joint
run = Path(a.urdf).parent
for m in ET.parse(a.urdf).getroot().iter("mesh"):  # the real script loads them where the URDF points
    if not (run / m.get("filename")).is_file():
        raise FileNotFoundError(f"Mesh file not found: {run / m.get('filename')}")
pivots = json.loads((canned(run) / "pivots.json").read_text())
out = a.out_urdf or str(Path(a.urdf).with_suffix("")) + "_optimized.urdf"
optimize_joint(Path(a.urdf), a.joint_name, pivots[a.joint_name], Path(out))
''',
}


def write_fake_checkout(spark_dir: Path) -> Path:
    """A SPARK checkout with fake stage scripts (module docstring); canned runs go in ``canned/<case id>/``."""
    spark_dir = Path(spark_dir)
    for rel, body in SCRIPTS.items():
        path = spark_dir / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(_PRELUDE.format(depth=len(Path(rel).parts) - 1) + body)
    (spark_dir / "run.py").write_text('INPUT_DIR = "./image"\nOUTPUT_DIR = "./output"\nINFERENCE_TAG = "FT5_G1_0"\n')
    (spark_dir / layout.CSV_PATH).write_text("Category,Min Parts,Max Parts,Average Parts,Part Names\n")
    source = Path(__file__).read_text()
    start, end = source.index("def optimize_joint"), source.index("def write_glb")
    (spark_dir / "fake_optimizer.py").write_text("from pathlib import Path\nimport xml.etree.ElementTree as ET\n"
                                                 "import numpy as np\n\n\n"
                                                 + source[start:end])
    (spark_dir / "canned").mkdir(exist_ok=True)
    return spark_dir
