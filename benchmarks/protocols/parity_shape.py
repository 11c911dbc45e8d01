"""Parity of the shape protocols (freeart3d, partcrafter, singapo, cage) with the papers' own evaluation code.

The same prediction / ground-truth pairs (``spark-bench data synth`` objects, two ``../shared/partnet_dev``
objects, and perturbations of them) are scored by spark-bench's protocol modules and by the papers' own
functions, which run in their own virtual environment on their own code (never copied here), and the
largest difference per metric is printed. The papers' code draws random samples; both sides draw them from
generators seeded alike (trimesh's shared generator, ``np.random.seed``), so deterministic code agrees to
rounding. Not run: SINGAPO's ``CD`` and CAGE's ``ID`` (CUDA-only: PyTorch3D on ``.cuda()`` tensors),
FreeArt3D's CLIP similarity (Blender renders).

Setup (once)::

    python3.11 -m venv /tmp/paper_venv
    /tmp/paper_venv/bin/pip install numpy scipy trimesh networkx==3.4.2 numpy-quaternion scikit-learn \\
        open3d loguru multipledispatch matplotlib opencv-python-headless packaging tqdm omegaconf psutil \\
        pyyaml huggingface_hub safetensors
    /tmp/paper_venv/bin/pip install --no-deps accelerate  # PartCrafter's typing_utils imports it
    apt-get install libusb-1.0-0  # Open3D's wheel links it
    # FreeArt3D's eval_utils/utils_3d.py imports torch: let the paper venv see spark-bench's (CPU) torch
    echo /work/venv/lib/python3.11/site-packages > /tmp/paper_venv/lib/python3.11/site-packages/zz.pth
    # the papers' code, each in its own folder (git archive of the fetched mirrors):
    #   /tmp/papers/freeart3d (eval_utils, evaluate_partnet.py)  PeterZs/FreeArt3D @ 0320aebd
    #   /tmp/papers/singapo (metrics, objects, scripts)           3dlg-hcvc/singapo @ 2199ef8c
    #   /tmp/papers/cage (metrics, objects)                        3dlg-hcvc/cage @ fb4a70c9
    #   /tmp/papers/partcrafter (src/utils)                        YumengHe/PartCrafter @ 432a0625

Run (spark-bench venv)::

    spark-bench data synth --out /tmp/synth4 --n 4
    python benchmarks/protocols/parity_shape.py --synth /tmp/synth4 --freeart3d-cases 0   # three papers
    python benchmarks/protocols/parity_shape.py --only freeart3d --cases partnet/103135 --freeart3d-cases 1
    python benchmarks/protocols/parity_shape.py --synth /tmp/synth4 --fixtures tests/metrics/fixtures/protocols_shape

FreeArt3D's pipeline is slow on spark-bench's side (120 starts x 4 ICP runs x 6 states in Python: about
15 minutes per object on two busy cores), hence ``--freeart3d-cases`` (the cases with the fewest faces).

``--paper-side NAME DIR`` is the half that runs in the paper venv.
"""

from __future__ import annotations

import argparse
import ast
import copy
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

SEED = 0
PARTNET = Path(__file__).resolve().parents[2] / ".." / "shared" / "partnet_dev"
PARTNET_OBJECTS = ("100247", "1370", "103135")
PAPERS = ("singapo", "cage", "partcrafter", "freeart3d")


# ======================================== paper side (paper venv) ========================================
def _paper_singapo(root: Path, case: dict) -> dict:
    sys.path.insert(0, str(root))
    from metrics.aor import AOR
    from metrics.iou_cdist import IoU_cDist
    from objects.dict_utils import compute_overall_bbox_size, rescale_object, zero_center_object
    from scripts.graph_pred.eval import get_hash

    gen, gt = case["pred_dict"], case["gt_dict"]
    # the first lines of metrics/cd.py's CD (the rest is CUDA-only): its rescale of the caller's dictionary
    gen_c, gt_c = copy.deepcopy(gen), copy.deepcopy(gt)
    zero_center_object(gen_c)
    zero_center_object(gt_c)
    rescale_object(gen, compute_overall_bbox_size(gen_c) / compute_overall_bbox_size(gt_c))
    np.random.seed(case["seed"])
    aor = AOR(gen)
    scores = IoU_cDist(gen, gt, compare_handles=True, iou_include_base=True)
    return {**{k: float(v) for k, v in scores.items()}, "AOR": None if aor == -1 else float(aor),
            "hash_pred": get_hash(case["pred_dict"]), "hash_gt": get_hash(gt)}


def _paper_cage(root: Path, case: dict) -> dict:
    sys.path[:0] = [str(root), str(root / "metrics")]
    from metrics.aid import AID
    from metrics.aor import AOR

    np.random.seed(case["seed"])
    aid = AID(copy.deepcopy(case["pred_dict"]), copy.deepcopy(case["gt_dict"]), 5)
    aor = AOR(copy.deepcopy(case["pred_dict"]))
    return {"AID": float(aid), "AOR": None if aor == -1 else float(aor)}


def _set_trimesh_generator(seed: int) -> None:
    import trimesh.util

    trimesh.util._RANDOM_DEFAULT = np.random.default_rng(seed)


def _mesh(triangles):
    """A trimesh mesh of (F, 3, 3) triangles, vertices unshared (as spark-bench samples them)."""
    import trimesh

    triangles = np.asarray(triangles, dtype=np.float64)
    return trimesh.Trimesh(triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3), process=False)


def _paper_partcrafter(root: Path, case: dict, arrays) -> dict:
    sys.path.insert(0, str(root))
    import trimesh
    from src.utils.data_utils import normalize_mesh
    from src.utils.metric_utils import compute_cd_and_f_score, compute_IoU_for_scene

    pred, gt = normalize_mesh(_mesh(arrays["pc_pred"])), normalize_mesh(_mesh(arrays["pc_gt"]))
    _set_trimesh_generator(case["seed"])
    cd, f = compute_cd_and_f_score(pred, gt, num_samples=case["n_samples"], threshold=0.1)
    out = {"chamfer_distance": float(cd), "f_score": None if np.isnan(f) else float(f)}
    n_parts = case["pc_parts"]
    if n_parts > 1:
        scene = trimesh.Scene([_mesh(arrays[f"pc_part{i}"]) for i in range(n_parts)])
        out["iou"] = float(compute_IoU_for_scene(normalize_mesh(scene).dump()))
    return out


def _function_from(path: Path, name: str, namespace: dict):
    """One function of a script that cannot be imported (Blender at import time), defined from its source."""
    tree = ast.parse(path.read_text())
    node = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    exec(compile(ast.Module([node], []), str(path), "exec"), namespace)
    return namespace[name]


def _paper_freeart3d(root: Path, case: dict, arrays) -> dict:
    """The steps of ``evaluate_partnet.py``'s main loop (rendering and CLIP left out), on its functions."""
    sys.path.insert(0, str(root))
    import tqdm
    import trimesh
    from eval_utils.joints import Joint, eval_joint
    from eval_utils.neucon_eval_utils import eval_mesh
    from eval_utils.utils_3d import Rt_to_pose, open3d_icp_api, rotz_np, transform_points

    align = _function_from(root / "evaluate_partnet.py", "auto_align_mesh_with_scale_and_rotz",
                           {"np": np, "tqdm": tqdm, "trimesh": trimesh, "rotz_np": rotz_np,
                            "transform_points": transform_points, "Rt_to_pose": Rt_to_pose,
                            "open3d_icp_api": open3d_icp_api})
    _set_trimesh_generator(case["seed"])
    joints = {side: {name: Joint(info, method="gt") for name, info in case[f"{side}_joints"].items()}
              for side in ("pred", "gt")}
    results: dict[str, list] = {}
    for qpos_id in range(case["n_states"]):
        gt_mesh, pred_mesh = _mesh(arrays[f"fa_gt{qpos_id}"]), _mesh(arrays[f"fa_pred{qpos_id}"])
        gt_scale = 1 / gt_mesh.extents.max()
        gt_mesh.apply_scale(1 / gt_mesh.extents.max())
        gt_centroid = gt_mesh.centroid
        gt_mesh.apply_translation(-gt_mesh.centroid)
        pred_scale = 1 / pred_mesh.extents.max()
        pred_mesh.apply_scale(1 / pred_mesh.extents.max())
        pred_centroid = pred_mesh.centroid
        pred_mesh.apply_translation(-pred_mesh.centroid)
        pred_mesh, scale, final_rotz, final_tsfm = align(gt_mesh, pred_mesh, name="", scale_min=0.5, scale_max=1.5)
        rotz = Rt_to_pose(rotz_np(np.deg2rad(final_rotz))[0])
        if qpos_id == 0:
            for joint in joints["gt"].values():
                joint.apply_scale(gt_scale)
                joint.apply_translation(-gt_centroid)
            for joint in joints["pred"].values():
                joint.apply_scale(pred_scale)
                joint.apply_translation(-pred_centroid)
                joint.apply_transform(np.array(rotz))
                joint.apply_scale(np.array(scale))
                joint.apply_transform(np.array(final_tsfm))
        for key, value in eval_mesh(pred_mesh, gt_mesh, threshold=.05 * 1.0, down_sample=None).items():
            results.setdefault(key, []).append(float(value))
    mean = {key: float(np.mean(values)) for key, values in results.items()}
    axis, pivot = [], []
    for pred_name, gt_name in case["pairs"]:
        errors = eval_joint(joints["pred"][pred_name], joints["gt"][gt_name])
        axis.append(errors["joint_axis_err"])
        if joints["gt"][gt_name].type == "revolute":
            pivot.append(errors["joint_orig_err"])
    axis, pivot = [v for v in axis if not np.isnan(v)], [v for v in pivot if not np.isnan(v)]
    return {"chamfer_distance": mean["dist1"] + mean["dist2"],
            "f_score": None if np.isnan(mean["fscore"]) else mean["fscore"],
            "axis_err": float(np.mean(axis)) if axis else None, "pivot_err": float(np.mean(pivot)) if pivot else None,
            "dist1": mean["dist1"], "dist2": mean["dist2"], "precision": mean["prec"], "recall": mean["recal"]}


def paper_side(name: str, folder: Path, papers: Path) -> None:
    """Run paper ``name``'s code on every case of ``folder``; write ``<case>/paper_<name>.json``."""
    import warnings

    warnings.filterwarnings("ignore")
    for case_dir in sorted(p for p in folder.iterdir() if p.is_dir()):
        case = json.loads((case_dir / "case.json").read_text())
        if name not in case["protocols"]:
            continue
        arrays = np.load(case_dir / "arrays.npz")
        if name in ("singapo", "cage"):
            result = {"singapo": _paper_singapo, "cage": _paper_cage}[name](papers / name, case)
        else:
            result = {"partcrafter": _paper_partcrafter, "freeart3d": _paper_freeart3d}[name](papers / name, case, arrays)
        (case_dir / f"paper_{name}.json").write_text(json.dumps(result))


def paper_fixtures(folder: Path, papers: Path) -> None:
    """Fill in the papers' numbers of the small fixtures (``fixture_*.json``) of ``folder``."""
    import warnings

    warnings.filterwarnings("ignore")

    class Sampled:  # a "mesh" whose samples are given: the papers' functions call mesh.sample(n)
        def __init__(self, points):
            self.points = np.asarray(points, dtype=np.float64)

        def sample(self, n):
            return self.points

    sys.path.insert(0, str(papers / "freeart3d"))
    from eval_utils.joints import Joint, eval_joint
    from eval_utils.neucon_eval_utils import eval_mesh
    from eval_utils.utils_3d import open3d_icp_api

    path = folder / "fixture_freeart3d.json"
    fixture = json.loads(path.read_text())
    for case in fixture["icp"]:
        result = open3d_icp_api(np.array(case["source"]), np.array(case["target"]), case["threshold"],
                                init_Rt=np.array(case["initial"]), return_tsfm_only=False)
        case["paper"] = {"transformation": np.asarray(result.transformation).tolist(), "fitness": result.fitness}
    for case in fixture["eval_mesh"]:
        metrics = eval_mesh(Sampled(case["pred"]), Sampled(case["gt"]), threshold=.05, down_sample=None)
        case["paper"] = {k: (None if np.isnan(v) else float(v)) for k, v in metrics.items()}
    for case in fixture["eval_joint"]:
        pred, gt = Joint(case["pred"], method="gt"), Joint(case["gt"], method="gt")
        pred.apply_transform(np.array(case["transform"]))
        errors = eval_joint(pred, gt)
        case["paper"] = {k: (None if np.isnan(v) else float(v)) for k, v in errors.items()}
    path.write_text(json.dumps(fixture))

    sys.path.insert(0, str(papers / "partcrafter"))
    from src.utils.metric_utils import compute_cd_and_f_score

    path = folder / "fixture_partcrafter.json"
    fixture = json.loads(path.read_text())
    for case in fixture["cd_f"]:
        cd, f = compute_cd_and_f_score(Sampled(case["pred"]), Sampled(case["gt"]), num_samples=1, threshold=0.1)
        case["paper"] = {"chamfer_distance": float(cd), "f_score": None if np.isnan(f) else float(f)}
    path.write_text(json.dumps(fixture))

    for name in ("singapo", "cage"):
        path = folder / f"fixture_{name}.json"
        fixture = json.loads(path.read_text())
        for case in fixture["cases"]:
            runner = _paper_singapo if name == "singapo" else _paper_cage
            case["paper"] = runner(papers / name, {**copy.deepcopy(case), "seed": case["seed"]})
        path.write_text(json.dumps(fixture))
        for module in [m for m in sys.modules if m.split(".")[0] in ("metrics", "objects", "scripts", "iou")]:
            del sys.modules[module]  # the two papers' packages have the same names
        sys.path[:] = [p for p in sys.path if not p.startswith(str(papers / name))]


# ======================================== spark side (spark-bench venv) ========================================
def moved_pivot(asset, offset_length: float):
    """A copy of ``asset`` whose first revolute joint's pivot is moved by ``offset_length`` (world units)
    perpendicular to its axis, its geometry at rest unchanged (the child's meshes and joints compensated)."""
    out = asset.copy()
    joint = next(j for j in out.movable_joints() if j.type == "revolute")
    rest = out.link_poses(out.rest_configuration())
    parent = rest[joint.parent]
    axis_world = parent[:3, :3] @ joint.origin[:3, :3] @ np.asarray(joint.axis, float)
    side = np.cross(axis_world, [1.0, 0.0, 0.0] if abs(axis_world[0]) < 0.9 else [0.0, 1.0, 0.0])
    side *= offset_length / np.linalg.norm(side)
    motion = joint.motion(joint.rest_value)
    new_origin = joint.origin.copy()
    new_origin[:3, 3] += parent[:3, :3].T @ side
    compensate = np.linalg.inv(motion) @ np.linalg.inv(new_origin) @ joint.origin @ motion
    joint.origin = new_origin
    for visual in out.links[joint.child].visuals:
        visual.mesh.vertices = visual.mesh.vertices @ compensate[:3, :3].T + compensate[:3, 3]
    for below in out.joints.values():
        if below.parent == joint.child:
            below.origin = compensate @ below.origin
    return out


def scaled_moved(asset, scale: float = 1.3, offset=(0.1, -0.05, 0.02)):
    """A copy of ``asset`` scaled by ``scale`` about the origin and moved by ``offset``."""
    from spark_bench.asset.ops import similarity_asset

    matrix = np.eye(4) * scale
    matrix[3, 3], matrix[:3, 3] = 1.0, offset
    return similarity_asset(asset, matrix)


def build_cases(synth: Path | None, n_freeart3d: int, only: list[str] | None = None,
                names: list[str] | None = None) -> list[tuple[str, object, object, tuple]]:
    """``(name, pred, gt, protocols)``: self-pairs and perturbations of synth and PartNet objects; FreeArt3D's
    slow pipeline on the ``n_freeart3d`` self / pivot cases with the fewest faces.

    :param synth: a folder of synth objects (None: PartNet objects only)
    :param n_freeart3d: how many cases FreeArt3D runs on
    :param only: the protocols to run (default: all four)
    :param names: keep the cases whose name contains one of these (default: all)
    """
    from spark_bench.data import load_object

    objects = [(f"synth/{p.name}", load_object(p)) for p in sorted(synth.iterdir()) if p.is_dir()] if synth else []
    objects += [(f"partnet/{o}", load_object(PARTNET / o)) for o in PARTNET_OBJECTS if (PARTNET / o).exists()]
    cases = []
    for name, asset in objects:
        cases.append((f"{name}/self", asset, asset))
        cases.append((f"{name}/scaled", scaled_moved(asset), asset))
        if any(j.type == "revolute" for j in asset.movable_joints()):
            cases.append((f"{name}/pivot", moved_pivot(asset, 0.05 * float(np.ptp(asset.bounds(), 0).max())), asset))
    if names:
        cases = [c for c in cases if any(part in c[0] for part in names)]
    faces = {c[0]: sum(len(v.mesh.faces) for link in c[2].links.values() for v in link.visuals) for c in cases}
    heavy = sorted((c[0] for c in cases if c[0].endswith(("/self", "/pivot"))), key=lambda n: (faces[n], n))
    heavy = set(heavy[:n_freeart3d])
    out = [(n, p, g, PAPERS if n in heavy else PAPERS[:3]) for n, p, g in cases]
    if only:
        out = [(n, p, g, tuple(x for x in protocols if x in only)) for n, p, g, protocols in out]
    return [case for case in out if case[3]]


def _write_case(folder: Path, pred, gt, protocols, ours: dict) -> None:
    """The inputs of the papers' functions for one case: ``case.json`` and ``arrays.npz``."""
    from spark_bench.metrics.geometry import posed_triangles
    from spark_bench.metrics.protocols import freeart3d, partcrafter
    from spark_bench.metrics.protocols.parts import asset_parts, object_dict, part_triangles

    folder.mkdir(parents=True, exist_ok=True)
    arrays = {"pc_pred": posed_triangles(pred, pred.rest_configuration()),
              "pc_gt": posed_triangles(gt, gt.rest_configuration())}
    parts = [t for t in (part_triangles(pred, p, pred.rest_configuration()) for p in asset_parts(pred)) if len(t)]
    arrays.update({f"pc_part{i}": t for i, t in enumerate(parts)})
    case = {"seed": SEED, "protocols": list(protocols), "pred_dict": object_dict(pred), "gt_dict": object_dict(gt),
            "n_samples": partcrafter.N_SAMPLES, "pc_parts": len(parts), "n_states": freeart3d.N_STATES}
    if "freeart3d" in protocols:
        for qpos_id in range(freeart3d.N_STATES):
            fraction = (freeart3d.N_STATES - 1 - qpos_id) / (freeart3d.N_STATES - 1)
            arrays[f"fa_pred{qpos_id}"] = freeart3d.state_triangles(pred, fraction)
            arrays[f"fa_gt{qpos_id}"] = freeart3d.state_triangles(gt, fraction)
        for side, asset in (("pred", pred), ("gt", gt)):
            case[f"{side}_joints"] = {name: {"type": line.type, "range": [0.0, 0.0],
                                             "axis": {"origin": line.origin.tolist(), "direction": line.direction.tolist()}}
                                      for name, line in freeart3d.joint_lines(asset).items()}
        note = next(n for n in ours["freeart3d"]["notes"] if n.startswith("joint pairs"))
        pairs = note.split(": ", 1)[1]
        case["pairs"] = [p.split("->") for p in pairs.split(", ")] if pairs else []
    (folder / "case.json").write_text(json.dumps(case))
    np.savez(folder / "arrays.npz", **arrays)


def _box_points(rng, n, size=(1.0, 0.6, 0.4), center=(0.0, 0.0, 0.0)):
    import trimesh

    from spark_bench.metrics.protocols.parts import sample_trimesh_way

    mesh = trimesh.creation.box(extents=size)
    return np.round(sample_trimesh_way(mesh.vertices[mesh.faces], n, rng) + np.asarray(center), 6)


def make_fixtures(folder: Path, synth: Path | None) -> None:
    """Write the fixtures' inputs (small, deterministic); the paper side adds the papers' numbers."""
    from spark_bench.data import load_object
    from spark_bench.metrics.protocols.parts import object_dict

    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(7)
    turn = np.eye(4)
    c, s_ = np.cos(0.17), np.sin(0.17)
    turn[:2, :2] = [[c, -s_], [s_, c]]
    turn[:3, 3] = [0.03, -0.02, 0.01]
    source = _box_points(rng, 200)
    target = np.round(_box_points(rng, 200) @ turn[:3, :3].T + turn[:3, 3], 6)
    start = np.eye(4)
    start[:3, 3] = [0.01, 0.0, 0.0]
    icp = [{"source": source.tolist(), "target": target.tolist(), "threshold": t, "initial": i.tolist()}
           for t, i in ((0.08, np.eye(4)), (0.05, start), (0.3, np.eye(4)))]
    eval_mesh = [{"pred": _box_points(rng, 300).tolist(), "gt": _box_points(rng, 300, center=(0.03, 0, 0)).tolist()},
                 {"pred": _box_points(rng, 300).tolist(), "gt": _box_points(rng, 300, center=(5.0, 0, 0)).tolist()}]
    moved = turn.tolist()

    def joint(kind, origin, direction):
        return {"type": kind, "range": [0.0, 1.0], "axis": {"origin": origin, "direction": direction}}

    eval_joint = [{"pred": joint("revolute", [0.1, 0.2, 0.0], [0.0, 0.05, 1.0]),
                   "gt": joint("revolute", [0.0, 0.2, 0.0], [0.0, 0.0, 2.0]), "transform": moved},
                  {"pred": joint("revolute", [0.1, 0.0, 0.0], [0.0, 0.0, 1.0]),
                   "gt": joint("revolute", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), "transform": np.eye(4).tolist()},
                  {"pred": joint("prismatic", [0.1, 0.0, 0.0], [1.0, 0.1, 0.0]),
                   "gt": joint("prismatic", [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]), "transform": moved}]
    (folder / "fixture_freeart3d.json").write_text(json.dumps(
        {"source": "PeterZs/FreeArt3D @ 0320aebd: open3d_icp_api, eval_mesh, Joint.apply_transform + eval_joint",
         "icp": icp, "eval_mesh": eval_mesh, "eval_joint": eval_joint}))
    cd_f = [{"pred": _box_points(rng, 300).tolist(), "gt": _box_points(rng, 300, center=(0.05, 0, 0)).tolist()},
            {"pred": _box_points(rng, 300).tolist(), "gt": _box_points(rng, 300, center=(3.0, 0, 0)).tolist()}]
    (folder / "fixture_partcrafter.json").write_text(json.dumps(
        {"source": "YumengHe/PartCrafter @ 432a0625: compute_cd_and_f_score on given samples", "cd_f": cd_f}))
    assets = [load_object(PARTNET / o) for o in PARTNET_OBJECTS if (PARTNET / o).exists()]
    if synth:
        assets += [load_object(p) for p in sorted(synth.iterdir()) if p.is_dir()][:2]
    pairs = []
    for asset in assets:
        pairs += [(asset, asset), (scaled_moved(asset), asset)]
        if any(j.type == "revolute" for j in asset.movable_joints()):
            pairs.append((moved_pivot(asset, 0.05 * float(np.ptp(asset.bounds(), 0).max())), asset))
    cases = [{"seed": k, "pred_dict": object_dict(p), "gt_dict": object_dict(g)} for k, (p, g) in enumerate(pairs)]
    for name in ("singapo", "cage"):
        (folder / f"fixture_{name}.json").write_text(json.dumps(
            {"source": "the paper's own functions on these object dictionaries after np.random.seed(seed)",
             "cases": cases}))


def _ours(pred, gt, protocols) -> dict:
    from spark_bench.metrics.protocols import protocol_module

    out = {}
    for name in protocols:
        result = protocol_module(name).score(pred, gt, seed=SEED)
        out[name] = {"metrics": result.metrics, "notes": result.notes}
    return out


def _compare(ours: dict, paper: dict, name: str) -> dict[str, float]:
    """``{metric: |ours - paper|}`` over the metrics the paper side computed (None on both sides: 0)."""
    out = {}
    for key, value in paper.items():
        if key.startswith("hash_"):
            continue
        mine = ours[name]["metrics"].get(key)
        if value is None or mine is None:
            out[key] = 0.0 if value is None and mine is None else float("inf")
        else:
            out[key] = abs(float(mine) - float(value))
    if name == "singapo":  # graph accuracy is CAGE's metric, computed with SINGAPO's get_hash
        out["graph_acc (cage)"] = abs(ours["cage"]["metrics"]["graph_acc"] - float(paper["hash_pred"] == paper["hash_gt"]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paper-side", nargs=2, metavar=("NAME", "DIR"))
    parser.add_argument("--paper-fixtures", type=Path, help="(paper venv) fill in the fixtures of this folder")
    parser.add_argument("--fixtures", type=Path, help="write the small test fixtures here (and stop)")
    parser.add_argument("--papers", type=Path, default=Path("/tmp/papers"))
    parser.add_argument("--paper-python", default="/tmp/paper_venv/bin/python")
    parser.add_argument("--synth", type=Path, help="a folder of `spark-bench data synth` objects")
    parser.add_argument("--freeart3d-cases", type=int, default=3, help="cases FreeArt3D's slow pipeline runs on")
    parser.add_argument("--work", type=Path, help="keep the cases here (default: a temporary folder)")
    parser.add_argument("--only", nargs="+", choices=PAPERS, help="run these protocols only")
    parser.add_argument("--cases", nargs="+", help="keep the cases whose name contains one of these")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args()
    if args.paper_side:
        paper_side(args.paper_side[0], Path(args.paper_side[1]), args.papers)
        return
    if args.paper_fixtures:
        paper_fixtures(args.paper_fixtures, args.papers)
        return
    if args.fixtures:
        make_fixtures(args.fixtures, args.synth)
        subprocess.run([args.paper_python, __file__, "--paper-fixtures", str(args.fixtures), "--papers",
                        str(args.papers)], check=True)
        return
    work = args.work or Path(tempfile.mkdtemp(prefix="parity_shape_"))
    report = {}
    for name, pred, gt, protocols in build_cases(args.synth, args.freeart3d_cases, args.only, args.cases):
        ours = _ours(pred, gt, protocols)
        _write_case(work / name.replace("/", "__"), pred, gt, protocols, ours)
        report[name] = {"ours": ours}
        print(f"scored {name} ({', '.join(protocols)})", flush=True)
    for paper in args.only or PAPERS:
        subprocess.run([args.paper_python, __file__, "--paper-side", paper, str(work), "--papers", str(args.papers)],
                       check=True)
    worst: dict[tuple[str, str], tuple[float, str]] = {}
    for name, entry in report.items():
        folder = work / name.replace("/", "__")
        for paper in PAPERS:
            path = folder / f"paper_{paper}.json"
            if not path.exists():
                continue
            entry[f"paper_{paper}"] = json.loads(path.read_text())
            for metric, diff in _compare(entry["ours"], entry[f"paper_{paper}"], paper).items():
                if diff >= worst.get((paper, metric), (-1.0, ""))[0]:
                    worst[(paper, metric)] = (diff, name)
    print(f"\n{'protocol':12s} {'metric':18s} {'largest |ours - paper|':>24s}  case")
    for (paper, metric), (diff, name) in sorted(worst.items()):
        print(f"{paper:12s} {metric:18s} {diff:24.3e}  {name}")
    if args.json:
        args.json.write_text(json.dumps({"cases": report, "worst": {f"{p}/{m}": v for (p, m), v in worst.items()}},
                                        indent=1, default=float))


if __name__ == "__main__":
    main()
