"""The check picture: the object at rest and at the end of each joint's sweep, visuals on top and
collision hulls below, as one PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spark_bench.mujoco_gl import mujoco_module
from spark_bench.sim.bounds import model_bounds

#: Camera: in front of the object (its front faces -X), a little to the side and above.
AZIMUTH, ELEVATION, DISTANCE = 25.0, -22.0, 1.35
FRAME = 320


def _frame(renderer, model, data, camera, group: int) -> np.ndarray:
    mujoco = mujoco_module()
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[group] = 1
    renderer.update_scene(data, camera=camera, scene_option=option)
    return renderer.render().copy()


def open_poses(model) -> list[tuple[str, float]]:
    """``(joint, open value)`` of every hinge and slide: its upper limit, a quarter turn when unlimited."""
    mujoco = mujoco_module()
    out = []
    for j in range(model.njnt):
        if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            value = float(model.jnt_range[j, 1]) if model.jnt_limited[j] else float(np.pi / 2)
            out.append((model.joint(j).name, value))
    return out


def render_check_strip(spec, out: Path, frame: int = FRAME) -> Path:
    """Write ``out`` (PNG): top row the visual meshes, bottom row the collision hulls, one column for
    the rest pose and one per hinge or slide at its open value (the others at rest).

    :param spec: the object's ``MjSpec`` (from :func:`spark_bench.sim.build_spec`, or read from a
        ``model.xml``); not modified
    :param out: PNG path
    :param frame: pixel size of each square frame
    """
    from PIL import Image

    from spark_bench.sim.mjcf import COLLISION_GROUP, VISUAL_GROUP

    mujoco = mujoco_module()
    render_spec = spec.copy()
    render_spec.visual.global_.offwidth = frame
    render_spec.visual.global_.offheight = frame
    light = render_spec.worldbody.add_light(name="check_strip_light")
    light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    light.dir = [0.4, 0.3, -1.0]
    model = render_spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo, hi = model_bounds(model, data)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = 0.5 * (lo + hi)
    camera.distance = DISTANCE * float(np.linalg.norm(hi - lo))
    camera.azimuth, camera.elevation = AZIMUTH, ELEVATION
    poses = [{}] + [{name: value} for name, value in open_poses(model)]
    rows = {VISUAL_GROUP: [], COLLISION_GROUP: []}
    with mujoco.Renderer(model, height=frame, width=frame) as renderer:
        for q in poses:
            mujoco.mj_resetData(model, data)
            for name, value in q.items():
                data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
            mujoco.mj_forward(model, data)
            for group in rows:
                rows[group].append(_frame(renderer, model, data, camera, group))
    image = np.concatenate([np.concatenate(rows[g], axis=1) for g in (VISUAL_GROUP, COLLISION_GROUP)], axis=0)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(image).save(out)
    return out
