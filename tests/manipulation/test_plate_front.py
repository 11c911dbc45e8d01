"""A sliding plate (a window's sash) whose front is no face to take it by is grasped by its broad face:
what counts as a plate, when a face is covered by the rest of the object, and a synth sliding window
opened with the suction cup on its sash's outer face (the true joint opens it, a wrong axis does not)."""

from __future__ import annotations

import numpy as np
import trimesh
from helpers_boxes import box_mesh

import spark_bench  # noqa: F401  (registers the environments)
from spark_bench.manipulation.plate_front import SLIDING_RATIO, face_covered, plate_normal, plate_outward

Y = np.array([0.0, 1.0, 0.0])


def _points(mesh):
    return np.asarray(mesh.sample(4000, seed=0))


def test_a_sash_is_a_plate_and_a_shallow_drawer_is_not():
    sash = _points(box_mesh((0.04, 0.5, 1.0)))  # 40 mm thick, 0.5 m along its slide
    normal = plate_normal(sash, Y)
    assert normal is not None and abs(normal @ [1.0, 0.0, 0.0]) > 0.99
    drawer = _points(box_mesh((0.45, 0.4, 0.1)))  # sliding along x: 0.1 m tall, 0.45 m deep
    assert plate_normal(drawer, np.array([1.0, 0.0, 0.0])) is None
    # the rule's edge: thickness over travel-direction extent
    assert plate_normal(_points(box_mesh((0.8 * 0.5 * SLIDING_RATIO, 0.5, 1.0))), Y) is not None
    assert plate_normal(_points(box_mesh((1.2 * 0.5 * SLIDING_RATIO, 0.5, 1.0))), Y) is None


def test_a_face_is_covered_only_where_the_object_stands_in_front_of_it():
    sash = box_mesh((0.04, 0.5, 1.0))
    jamb = box_mesh((0.1, 0.05, 1.2), center=(0.0, 0.3, 0.0))  # 25 mm beyond the sash's +y edge
    points = _points(sash)
    assert face_covered(points, Y, jamb, clear=0.5)
    assert not face_covered(points, -Y, jamb, clear=0.5)
    assert not face_covered(points, Y, jamb, clear=0.02)  # farther than the rays go
    assert not face_covered(points, Y, None, clear=0.5)


def test_the_broad_face_away_from_the_object_and_clear_is_chosen():
    sash = box_mesh((0.04, 0.5, 1.0), center=(-0.03, 0.0, 0.0))
    frame = trimesh.util.concatenate([box_mesh((0.12, 0.05, 1.2), center=(0.0, 0.3, 0.0)),
                                      box_mesh((0.12, 0.05, 1.2), center=(0.0, -0.3, 0.0))])
    points = _points(sash)
    out = plate_outward(sash, points, Y, frame, np.zeros(3), clear=0.5)
    assert out is not None and out @ [-1.0, 0.0, 0.0] > 0.99  # the sash sits in the frame's front half
    glass = box_mesh((0.01, 1.2, 1.2), center=(-0.1, 0.0, 0.0))  # something right in front of that face
    covered = trimesh.util.concatenate([frame, glass])
    out = plate_outward(sash, points, Y, covered, np.zeros(3), clear=0.5)
    assert out is not None and out @ [1.0, 0.0, 0.0] > 0.99
    drawer = box_mesh((0.45, 0.4, 0.1))
    assert plate_outward(drawer, _points(drawer), np.array([1.0, 0.0, 0.0]), frame, np.zeros(3), 0.5) is None


def test_a_sliding_windows_sash_is_opened_by_its_outer_face(tmp_path):
    """Synth window 5017 slides its sash sideways; its leading edge lies behind the frame's jamb (the
    gripper's way in runs into the window body). The sash is taken by its outer face: nothing to pinch
    there, so ``auto`` puts the cup on it and drags it along the slide by friction."""
    from spark_bench.data.synth import generate_object
    from spark_bench.envs import make_env
    from spark_bench.manipulation.grasp import find_grasp
    from spark_bench.opening.episodes import ground_truth_joint, open_with_ground_truth, open_with_joint

    folder = str(generate_object("Window", 5017, tmp_path, "Window_5017"))
    env = make_env("SparkDrawer-v0", asset=folder, joint="joint_0", end_effector="auto", max_episode_steps=200)
    scene = env.unwrapped.scene
    grasp = find_grasp(scene.asset, "joint_0")
    axis, pivot, joint_type = ground_truth_joint(env)
    assert grasp.broad_face and grasp.declined == "no_handle" and abs(grasp.outward @ axis) < 0.05
    assert scene.end_effector == "suction" and scene.grasp.reason is None
    np.testing.assert_allclose(scene.grasp.outward, grasp.outward, atol=1e-9)  # the cup on the same face
    assert scene.grasp.broad_face and scene.grasp.source == "suction"
    assert open_with_ground_truth(env, seed=0, max_steps=200).success
    # pulled straight out of the face (the slide turned 90 degrees about the vertical) the sash stays
    wrong = np.cross([0.0, 0.0, 1.0], axis)
    assert not open_with_joint(env, wrong, pivot, joint_type, seed=0, max_steps=200).success
    env.close()
