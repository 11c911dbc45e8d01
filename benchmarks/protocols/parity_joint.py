"""Parity of the joint protocols with the papers' own evaluation code, on the same prediction/ground-truth
pairs: Articulate-Anything, URDF-Anything, Real2Code.

The papers' functions are run from their repositories (``git show COMMIT:PATH`` of a bare mirror that
``fetch`` brought, ``--mirrors``; never copied into this repository), executed with their other imports
stubbed: the functions compared use NumPy and SciPy only, so no separate virtual environment is needed.

- Articulate-Anything ``articulate_anything/utils/metric.py``: ``compute_joint_diff``,
  ``compute_joint_diff_score``, ``adjust_result_for_prismatic``, fed the joint-state dictionaries
  ``URDF.get_joint_states`` would write (strings of ``str(float)``);
- URDF-Anything ``scripts/eval_metric.py``: ``eval_root`` on one JSON file per pair (its rates rounded
  to 4 decimals), and its per-joint functions unrounded;
- Real2Code ``eval_utils/joint_eval.py``: ``permute_joint_error``; ``shape_complete/eval.py``:
  ``chamfer_distance`` with meshes whose ``sample`` returns fixed points (its own sampling is unseeded).

Pairs: ``spark-bench data synth --n 6`` objects and a few ``/work/shared/partnet_dev`` objects, each
against itself and against perturbations with known answers (every joint's axis turned by 0.2 and 0.3 rad,
its pivot moved by 0.03 and 0.15 file units perpendicular to the axis, half-way between two
perpendiculars, its type swapped). Prints the largest
difference per metric and, with ``--fixtures DIR``, writes the pairs' joints and the papers' numbers as the
test fixtures of ``tests/metrics/test_protocols_joint.py``.

Run: ``python -m benchmarks.protocols.parity_joint --synth /tmp/synth [--partnet N] [--fixtures DIR]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import types
from pathlib import Path
from unittest import mock

import numpy as np

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data import load_object
from spark_bench.metrics.protocols import articulate_anything as aa
from spark_bench.metrics.protocols import real2code as r2c
from spark_bench.metrics.protocols import urdf_anything as ua
from spark_bench.metrics.protocols.joints import joint_records, match_joints, record_to_dict
from spark_bench.metrics.sampling import sample_triangles

PAPERS = {
    "aa": ("vlongle+articulate-anything", "1edb4b4a80e9679234e36873d91c52e0759d670c",
           "articulate_anything/utils/metric.py"),
    "ua": ("LZVSDY+URDF-Anything_CODE", "6d77613f2b601cddb86d164a19411e447a1ea559", "scripts/eval_metric.py"),
    "r2c_joint": ("MandiZhao+real2code", "ecd50d27df34773ea82ec55c7af73ce33136c6fb", "eval_utils/joint_eval.py"),
    "r2c_shape": ("MandiZhao+real2code", "ecd50d27df34773ea82ec55c7af73ce33136c6fb", "shape_complete/eval.py"),
}
#: Imports of the papers' files that the compared functions never use.
STUBBED = ("articulate_anything", "articulate_anything.api", "articulate_anything.api.odio_urdf",
           "articulate_anything.utils", "articulate_anything.utils.utils", "articulate_anything.utils.partnet_utils",
           "dm_control", "dm_control.mujoco", "dm_control.mjcf", "openai", "requests", "natsort", "torch",
           "torch.nn", "torch.utils", "torch.utils.data", "wandb", "einops", "kaolin", "kaolin.ops",
           "kaolin.ops.mesh", "kaolin.io", "kaolin.io.obj", "kaolin.ops.conversions", "open3d", "tqdm",
           "shape_complete", "shape_complete.models", "shape_complete.dataset", "shape_complete.datagen", "mujoco")
PIVOT_MOVES = (0.03, 0.15)
AXIS_TURNS = (0.2, 0.3)
CD_POINTS = 100


def load_paper(key: str, mirrors: Path) -> types.ModuleType:
    """Execute one paper file from its mirror at the commit read, with :data:`STUBBED` imports stubbed."""
    repo, commit, path = PAPERS[key]
    source = subprocess.check_output(["git", "--git-dir", str(mirrors / repo / "repo"), "show", f"{commit}:{path}"])
    module = types.ModuleType(f"paper_{key}")
    with mock.patch.dict(sys.modules, {name: mock.MagicMock() for name in STUBBED}):
        exec(compile(source, f"{repo}@{commit[:8]}:{path}", "exec"), module.__dict__)
    return module


# ----- the pairs -------------------------------------------------------------------------------------
def _perpendicular(axis: np.ndarray) -> np.ndarray:
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    out = np.cross(axis, helper)
    return out / np.linalg.norm(out)


def perturbed(asset, kind: str, amount: float = 0.0):
    """A copy of ``asset`` with every movable joint's axis turned by ``amount`` rad (``axis``), its pivot
    moved by ``amount`` file units perpendicular to the axis (``pivot``), or its type swapped (``type``)."""
    out = asset.copy()
    units = 1.0
    if kind == "pivot":
        from spark_bench.metrics.protocols.joints import file_units_per_length

        units = file_units_per_length(asset)
    for joint in out.movable_joints():
        axis = np.asarray(joint.axis, dtype=float) / np.linalg.norm(joint.axis)
        if kind == "axis":
            joint.axis = axis_angle_matrix(_perpendicular(axis), amount) @ axis
        elif kind == "pivot":
            joint.origin = joint.origin.copy()
            # half-way between two perpendiculars, so that the papers' fixed-direction fallback for
            # parallel axes (it measures along a x (1, 0, 0) only) sees part of the move
            perpendicular = _perpendicular(axis) + np.cross(axis, _perpendicular(axis))
            joint.origin[:3, 3] += joint.origin[:3, :3] @ perpendicular * (amount / units / np.sqrt(2))
        elif kind == "type":
            joint.type = "prismatic" if joint.is_rotational else "revolute"
            joint.lower, joint.upper = (0.0, 0.3) if joint.type == "prismatic" else (0.0, np.pi / 2)
    return out


def pairs(synth: Path | None, n_partnet: int):
    """``(label, pred, gt)`` for every object and perturbation."""
    folders = sorted(p for p in synth.iterdir() if p.is_dir()) if synth else []
    partnet = Path("/work/shared/partnet_dev")
    if partnet.is_dir():
        folders += sorted(p for p in partnet.iterdir() if p.is_dir())[:n_partnet]
    for folder in folders:
        gt = load_object(folder)
        if not gt.movable_joints():
            continue
        yield f"{folder.name}/self", gt, gt
        for turn in AXIS_TURNS:
            yield f"{folder.name}/axis{turn}", perturbed(gt, "axis", turn), gt
        for move in PIVOT_MOVES:
            yield f"{folder.name}/pivot{move}", perturbed(gt, "pivot", move), gt
        yield f"{folder.name}/type", perturbed(gt, "type"), gt


# ----- each paper on one pair ------------------------------------------------------------------------
def _state(record) -> dict:
    """A joint as ``URDF.get_joint_states`` writes it."""
    return {"joint_type": record.type,
            "joint_origin": {"xyz": " ".join(map(str, record.world_point)),
                             "orientation": " ".join(map(str, record.world_quaternion))},
            "joint_axis": " ".join(map(str, record.world_axis)),
            "joint_limit": {"lower": record.lower, "upper": record.upper}}


def _nan_to_none(value):
    return None if value is None or (isinstance(value, float) and np.isnan(value)) else float(value)


def paper_aa(paper, gt_records, p_by_name, matched) -> list[dict]:
    """Per scored ground-truth joint: the paper's diff and final failure reason."""
    gt_state = {g.name: _state(g) for g in gt_records}
    pred_state = {p.name: _state(p) for p in p_by_name.values()}
    out = []
    for g in gt_records:
        if g.type not in aa.SCORED_TYPES or g.name not in matched:
            continue
        diff = paper.compute_joint_diff(gt_state, pred_state, matched, g.name)
        s, reason = paper.compute_joint_diff_score(diff)
        result = paper.adjust_result_for_prismatic({"failure_reason": reason, "score": s}, g.type, True, True)
        out.append({"gt": g.name, "joint_axis": _nan_to_none(diff["joint_axis"]),
                    "xyz": _nan_to_none(diff["joint_origin"]["xyz"]),
                    "orientation": _nan_to_none(diff["joint_origin"]["orientation"]),
                    "direction_diff": _nan_to_none(diff["joint_limit"]["direction_diff"]),
                    "range_diff": _nan_to_none(diff["joint_limit"]["range_diff"]),
                    "joint_type": bool(diff["joint_type"]), "reason": result["failure_reason"]})
    return out


def paper_aa_links(paper, poses: list[dict]) -> dict:
    """``average_link_difference`` (names as given, ``allow_equivalent=False``), ``reduce_link_diff`` and
    ``is_success`` on the same box centres and orientations; its ``link_data_to_np`` (an array conversion in
    a stubbed module) is replaced by the conversion it performs."""
    paper.link_data_to_np = lambda data: {k: {kk: np.asarray(vv) for kk, vv in v.items()} for k, v in data.items()}
    pred = {e["link"]: {k: np.asarray(v).tolist() for k, v in e["pred"].items()} for e in poses}
    gt = {e["link"]: {k: np.asarray(v).tolist() for k, v in e["gt"].items()} for e in poses}
    record = {"poses": [{"link": e["link"], "pred": pred[e["link"]], "gt": gt[e["link"]]} for e in poses]}
    if not poses:
        return {**record, "position_diff": None, "orientation_diff": None, "average_diff": None, "success": None,
                "orientation_is_nan": False}
    with np.errstate(invalid="ignore"):
        reduced = paper.reduce_link_diff(paper.average_link_difference(pred, gt, allow_equivalent=False))
    return {**record, "orientation_is_nan": bool(np.isnan(reduced["orientation_diff"])), "position_diff": _nan_to_none(reduced["position_diff"]),
            "orientation_diff": _nan_to_none(reduced["orientation_diff"]),
            "average_diff": _nan_to_none(reduced["average_diff"]),
            "success": float(paper.is_success(reduced["average_diff"], aa.LINK_CUTOFF, "average_diff"))}


def _ua_joint(record, joint_id: str) -> dict:
    return {"id": joint_id, "type": record.type, "axis": record.local_axis.tolist(),
            "origin": {"xyz": record.local_xyz.tolist(), "rpy": record.local_rpy.tolist()}}


def paper_ua(paper, gt_records, p_by_name, matched) -> dict:
    """``eval_root``'s articulation block and the per-joint values of its functions, unrounded."""
    ids = {pred: gt for gt, pred in matched.items()}
    gt_joints = [_ua_joint(g, g.name) for g in gt_records]
    pred_joints = [_ua_joint(p, ids.get(p.name, f"extra_{p.name}")) for p in p_by_name.values()]
    with tempfile.TemporaryDirectory() as root:
        Path(root, "case.json").write_text(json.dumps(
            {"answer": {"joints": gt_joints}, "pred_answers": json.dumps({"joints": pred_joints})}))
        block = paper.eval_root(root)["articulation"]
    per_joint = []
    for g in gt_records:
        if g.name not in matched:
            continue
        p = p_by_name[matched[g.name]]
        a_gt = paper.axis_world_from_rpy(g.local_axis.tolist(), g.local_rpy.tolist())
        a_pred = paper.axis_world_from_rpy(p.local_axis.tolist(), p.local_rpy.tolist())
        xyz = (paper.revolute_origin_axisline_distance(g.local_xyz, a_gt, p.local_xyz, a_pred)
               if g.type == "revolute" else float(np.linalg.norm(g.local_xyz - p.local_xyz)))
        per_joint.append({"gt": g.name, "axis": paper.axis_angle_error_rad(a_gt, a_pred), "xyz": xyz,
                          "orientation": paper.quat_angle_distance_rad(paper.rpy_to_quat_xyzw(g.local_rpy.tolist()),
                                                                       paper.rpy_to_quat_xyzw(p.local_rpy.tolist()))})
    rates = block["rates"]
    return {"rates": {"type_correct": rates["type_correct"], "axis_within": rates["axis_within"],
                      "origin_within": rates["origin_within"],
                      "joint_success_rate": rates["success(type&axis&origin)"], "missing_rate": block["missing_rate"]},
            "means": {"axis_angle_error_rad": _nan_to_none(block["axis_angle_error_rad"]["mean"]),
                      "origin_xyz_error": _nan_to_none(block["origin_xyz_error"]["mean"]),
                      "origin_orientation_error_rad": _nan_to_none(block["origin_orientation_error_rad"]["mean"]),
                      "origin_combined_error": _nan_to_none(block["origin_combined_error"]["mean"])},
            "per_joint": per_joint}


def paper_r2c(paper, gt_records, p_records) -> dict:
    """``permute_joint_error``: per ground-truth joint (zipped) the paired prediction and its errors."""
    def as_mujoco(r):
        return {"name": r.name, "type": r2c.MUJOCO_TYPE[r.type], "axis": r.world_axis.tolist(),
                "pos": r.world_point.tolist()}

    with np.errstate(invalid="ignore"):
        errors, perm = paper.permute_joint_error([as_mujoco(p) for p in p_records], [as_mujoco(g) for g in gt_records])
    return {"pairs": [p["name"] for p in perm],
            "errors": [{"type": e["type"], "rot": _nan_to_none(e["rot"]), "pos": _nan_to_none(e["pos"]),
                        "rot_is_nan": e["rot"] is not None and bool(np.isnan(e["rot"]))} for e in errors]}


class _FixedSample:
    """Stands in for a trimesh mesh in Real2Code's ``chamfer_distance``: ``sample`` returns fixed points."""

    def __init__(self, points: np.ndarray):
        self.points = points

    def sample(self, n: int) -> np.ndarray:
        return self.points


def paper_chamfer(paper, gt, pred, seed: int = 0) -> dict:
    """Real2Code's ``chamfer_distance`` on :data:`CD_POINTS` fixed samples of each whole object at rest."""
    from spark_bench.metrics.geometry import posed_triangles
    from spark_bench.metrics.protocols.joints import file_units_per_length

    g = sample_triangles(posed_triangles(gt, gt.rest_configuration()) * file_units_per_length(gt), CD_POINTS, seed)
    p = sample_triangles(posed_triangles(pred, pred.rest_configuration()) * file_units_per_length(pred),
                         CD_POINTS, seed + 1)
    chamfer, chamfer_norm = paper.chamfer_distance(_FixedSample(g), _FixedSample(p), num_points=CD_POINTS)
    return {"gt_points": g.tolist(), "pred_points": p.tolist(), "chamfer": float(chamfer),
            "chamfer_norm": float(chamfer_norm)}


# ----- comparison ------------------------------------------------------------------------------------
class Differences:
    """The largest |ours - paper| per metric, and the count of values the paper gives as NaN."""

    def __init__(self):
        self.largest: dict[str, float] = {}
        self.nan: dict[str, int] = {}
        self.mismatched: dict[str, int] = {}

    def number(self, metric: str, ours: float | None, paper: float | None, nan_means: float | None = None) -> None:
        if paper is None and nan_means is not None:  # the paper's NaN, which ours gives as nan_means
            self.nan[metric] = self.nan.get(metric, 0) + 1
            paper = nan_means
        if ours is None or paper is None:
            self.same(metric, ours is None and paper is None)
            return
        self.largest[metric] = max(self.largest.get(metric, 0.0), abs(float(ours) - float(paper)))

    def same(self, metric: str, equal: bool) -> None:
        self.mismatched[metric] = self.mismatched.get(metric, 0) + (not equal)

    def report(self) -> str:
        lines = [f"{'metric':<34} {'largest |ours - paper|':>24}  paper NaN"]
        for metric in sorted(self.largest):
            lines.append(f"{metric:<34} {self.largest[metric]:>24.3g}  {self.nan.get(metric, 0)}")
        for metric in sorted(self.mismatched):
            lines.append(f"{metric:<34} {self.mismatched[metric]:>18d} differ")
        return "\n".join(lines)


def compare_pair(papers: dict, label: str, pred, gt, diffs: Differences) -> dict:
    """Both sides on one pair; returns the fixture record."""
    gt_records, p_records = joint_records(gt), joint_records(pred)
    p_by_name = {p.name: p for p in p_records}
    matched = match_joints(pred, gt)
    record = {"case": label, "gt": [record_to_dict(g) for g in gt_records],
              "pred": [record_to_dict(p) for p in p_records], "matched": matched}

    record["aa"] = paper_aa(papers["aa"], gt_records, p_by_name, matched)
    by_gt = {g.name: g for g in gt_records}
    for entry in record["aa"]:
        g = by_gt[entry["gt"]]
        ours = aa.joint_diff(g, p_by_name[matched[g.name]])
        diffs.number("aa joint_axis", ours["joint_axis"], entry["joint_axis"])
        diffs.number("aa origin xyz", ours["joint_origin"]["xyz"], entry["xyz"])
        diffs.number("aa origin orientation", ours["joint_origin"]["orientation"], entry["orientation"], 0.0)
        diffs.number("aa limit direction_diff", ours["joint_limit"]["direction_diff"], entry["direction_diff"])
        diffs.number("aa limit range_diff", ours["joint_limit"]["range_diff"], entry["range_diff"])
        diffs.same("aa failure reason", aa.failure_reason(ours, g.type) == entry["reason"])

    placed = [(g, p_by_name[matched[g.name]]) for g in gt_records if g.name in matched and g.type in aa.SCORED_TYPES]
    record["aa_links"] = paper_aa_links(papers["aa"], aa.link_poses(pred, gt, placed))
    ours_links = aa.link_placement(aa.link_poses(pred, gt, placed))
    nan = record["aa_links"]["orientation_is_nan"]
    diffs.number("aa link position_diff", ours_links["link_position_diff"], record["aa_links"]["position_diff"])
    for key in ("orientation_diff", "average_diff"):  # its NaN is 0 here, plus the positions' share
        diffs.number(f"aa link {key}", ours_links[f"link_{key}"], record["aa_links"][key],
                     ours_links[f"link_{key}"] if nan else None)
    if not nan:  # its NaN < 0.05 is False: a link compared with itself can fail there
        diffs.same("aa link success", ours_links["link_placement_success"] == record["aa_links"]["success"])

    record["ua"] = paper_ua(papers["ua"], gt_records, p_by_name, matched)
    ours_ua = ua.articulation_metrics([(g, p_by_name.get(matched.get(g.name, ""))) for g in gt_records],
                                      len(p_records))
    for key, value in record["ua"]["rates"].items():
        diffs.number(f"ua {key} (4 decimals)", round(ours_ua[key], 4), value)
    for key, value in record["ua"]["means"].items():
        diffs.number(f"ua {key}", ours_ua[key], value)
    for entry in record["ua"]["per_joint"]:
        ours = ua.joint_entry(by_gt[entry["gt"]], p_by_name[matched[entry["gt"]]])
        diffs.number("ua joint axis", ours["axis_err"], entry["axis"])
        diffs.number("ua joint xyz", ours["xyz"], entry["xyz"])
        diffs.number("ua joint orientation", ours["orientation"], entry["orientation"])

    record["r2c"] = paper_r2c(papers["r2c_joint"], gt_records, p_records)
    ours_r2c = r2c.best_permutation(p_records, gt_records)
    diffs.same("r2c permutation", [p.name for p, _, _ in ours_r2c] == record["r2c"]["pairs"][:len(ours_r2c)])
    for (_, _, ours), paper in zip(ours_r2c, record["r2c"]["errors"]):
        diffs.same("r2c type", ours["type"] == paper["type"])
        diffs.number("r2c rot (deg)", ours["rot"], paper["rot"], 0.0 if ours["rot"] is not None else None)
        diffs.number("r2c pos", ours["pos"], paper["pos"])
    return record


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--synth", type=Path, help="a folder of `spark-bench data synth --n 6` objects")
    parser.add_argument("--partnet", type=int, default=3, help="how many /work/shared/partnet_dev objects")
    parser.add_argument("--mirrors", type=Path, default=Path("/work/.mirror"), help="folder of the fetched mirrors")
    parser.add_argument("--fixtures", type=Path, help="write cases.json and chamfer.json here")
    args = parser.parse_args(argv)
    papers = {key: load_paper(key, args.mirrors) for key in PAPERS}
    diffs, records, chamfers = Differences(), [], []
    for label, pred, gt in pairs(args.synth, args.partnet):
        records.append(compare_pair(papers, label, pred, gt, diffs))
        if label.endswith(("pivot0.15", "self")) and len(chamfers) < 3:
            entry = {"case": label, **paper_chamfer(papers["r2c_shape"], gt, pred)}
            ours = r2c.squared_chamfer(np.asarray(entry["gt_points"]), np.asarray(entry["pred_points"]))
            diffs.number("r2c chamfer", ours[0], entry["chamfer"])
            diffs.number("r2c chamfer_norm", ours[1], entry["chamfer_norm"])
            chamfers.append(entry)
    print(f"{len(records)} pairs")
    print(diffs.report())
    if args.fixtures:
        args.fixtures.mkdir(parents=True, exist_ok=True)
        (args.fixtures / "cases.json").write_text(json.dumps(records, separators=(",", ":")) + "\n")
        (args.fixtures / "chamfer.json").write_text(json.dumps(chamfers, separators=(",", ":")) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
