"""What every foreign format's tests share: runs written from a benchmark's ground truths; what they check of
a refused run (one ``InputError``, one line, naming the file); the comparison with the ground truth."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from spark_bench.asset.transforms import axis_angle_matrix
from spark_bench.data.case import Benchmark
from spark_bench.errors import InputError


def write_runs(bench: Path, runs: Path, write_run: Callable[[Path, object], object]) -> Benchmark:
    """One run per case of the benchmark ``bench``, in ``runs/<case id>``, written by ``write_run`` from the
    case's ground truth. Returns the benchmark.

    :param bench: the benchmark folder
    :param runs: the folder of the runs
    :param write_run: the format's writer, called as ``write_run(run folder, ground truth)``
    """
    benchmark = Benchmark(bench)
    for case in benchmark.cases():
        write_run(runs / case.id, case.load_gt())
    return benchmark


def refused(read_run: Callable[[Path], object], run: Path, *words: str, file: str | None = None) -> InputError:
    """The :class:`InputError` ``read_run(run)`` raises, after checking that its message is one line holding
    every one of ``words`` and, with ``file``, that it names a path ending so.

    :param read_run: the format's reader
    :param run: the run folder
    :param words: what the message must say
    :param file: the end of the path the error must name (None: not checked)
    """
    with pytest.raises(InputError) as info:
        read_run(run)
    message = str(info.value)
    assert "\n" not in message and all(w in message for w in words), message
    if file is not None:
        assert str(info.value.path).endswith(file), message
    return info.value


def quarter_turn(imported, gt) -> np.ndarray:
    """The quarter turn about Z the footprint squaring may leave: the one bringing the imported vertices
    onto the ground truth's (the same meshes; a cabinet's box alone cannot tell a half turn)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(gt.mesh().vertices)
    turns = [axis_angle_matrix([0, 0, 1], k * math.pi / 2) for k in range(4)]
    errors = [tree.query(imported.mesh().vertices @ t.T)[0].max() for t in turns]
    return turns[int(np.argmin(errors))]


def assert_matches_ground_truth(imported, gt, labels: dict[str, str], tol: float) -> dict:
    """Bounds, joint types, axes (up to sign) and pivots of ``imported`` against ``gt`` (up to the quarter
    turn :func:`quarter_turn`). Returns the imported joint of each ground-truth joint.

    :param imported: the object read back (benchmark frame)
    :param gt: the ground truth it was written from
    :param labels: ground-truth child link -> the imported link's label
    :param tol: bounds and pivot tolerance (axes: 1e-6)
    """
    turn = quarter_turn(imported, gt)
    got_points = imported.mesh().vertices @ turn.T
    assert np.abs(np.stack([got_points.min(0), got_points.max(0)]) - gt.bounds()).max() < tol
    by_label = {imported.links[j.child].label: j for j in imported.movable_joints()}
    got_frames, gt_frames = imported.joint_frames(), gt.joint_frames()
    out = {}
    for joint in gt.movable_joints():
        mine = by_label[labels[joint.child]]
        assert mine.type == joint.type
        point, direction = gt_frames[joint.name]
        got_point, got_direction = (turn @ v for v in got_frames[mine.name])
        assert np.linalg.norm(np.cross(got_direction, direction)) < 1e-6  # the same line, up to sign
        if joint.type == "revolute":  # the pivot: on the ground truth's hinge line
            assert np.linalg.norm(np.cross(got_point - point, direction)) < tol
        out[joint.name] = mine
    return out
