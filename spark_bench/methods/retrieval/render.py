"""Many small renders of many objects on one OpenGL context.

:class:`~spark_bench.data.render.AssetRenderer` opens an OpenGL context per object: right for a case
(two large images), too slow for a gallery (hundreds of objects, a hundred small views each; the
context costs as much as sixty views). :class:`GalleryRenderer` builds each object's scene with
``AssetRenderer`` (same scene, lights, colours and camera model, so the renders are the dataset's),
but draws it with MuJoCo's low-level calls on one context per process, without multisampling.
"""

from __future__ import annotations

import os

import numpy as np

from spark_bench.mujoco_gl import mujoco_module

_CONTEXT: dict[str, object] = {}


def _gl_context(width: int, height: int):
    """This process's OpenGL context (made current), created on first use."""
    mujoco_module()  # sets MUJOCO_GL before the first import of mujoco
    from mujoco import gl_context  # mujoco >= 3.2 (also mujoco.rendering.classic.gl_context in 4.x)

    context = _CONTEXT.get("gl")
    if context is None or _CONTEXT.get("pid") != os.getpid():  # a forked child needs its own
        context = gl_context.GLContext(max(width, 512), max(height, 512))
        _CONTEXT.update(gl=context, pid=os.getpid())
    context.make_current()
    return context


class GalleryRenderer:
    """RGB renders of one asset at rest from any view, on the process's shared OpenGL context.

    :param asset: the asset (benchmark frame)
    :param size: largest image side that will be asked for
    """

    def __init__(self, asset, size: int):
        from spark_bench.data.render import AssetRenderer

        mujoco = mujoco_module()
        self.scene_builder = AssetRenderer(asset, size)  # compiles the scene; never opens a context
        self.model, self.data = self.scene_builder.model, self.scene_builder.data
        self.model.vis.quality.offsamples = 0
        _gl_context(size, size)
        self._pid = os.getpid()
        self.context = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_100.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self.context)
        self.scene = mujoco.MjvScene(self.model, maxgeom=max(100, 2 * self.model.ngeom + 10))
        self.option = mujoco.MjvOption()
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED.value
        self.camera.fixedcamid = self.scene_builder._camera
        self.scene_builder.pose(None)
        self._light_dir = self.model.light_dir.copy()
        self._light_pos = self.model.light_pos.copy()
        mujoco.mj_forward(self.model, self.data)

    def render(self, view, light_turn_deg: float = 0.0) -> np.ndarray:
        """``(H, W, 3)`` uint8 image of the asset at rest from ``view``
        (:class:`~spark_bench.data.camera.CameraView`).

        :param light_turn_deg: turn the scene's lights by this angle about world Z. A render of the
            object turned by ``yaw`` is the render of the unturned object from the camera turned by
            ``-yaw`` *with the lights turned by* ``-yaw`` too: pass ``-yaw`` here to light it as the
            turned object is lit
        """
        mujoco = mujoco_module()
        if self.context is None or self._pid != os.getpid():
            raise RuntimeError("GalleryRenderer used after close() or in a forked process")
        _gl_context(view.width, view.height)
        c, s = np.cos(np.radians(light_turn_deg)), np.sin(np.radians(light_turn_deg))
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self.model.light_dir[:] = self._light_dir @ turn.T
        self.model.light_pos[:] = self._light_pos @ turn.T
        self.scene_builder.set_view(view)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL.value, self.scene)
        rect = mujoco.MjrRect(0, 0, view.width, view.height)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self.context)
        mujoco.mjr_render(rect, self.scene, self.context)
        rgb = np.empty((view.height, view.width, 3), dtype=np.uint8)
        mujoco.mjr_readPixels(rgb, None, rect, self.context)
        return np.flipud(rgb)

    def close(self) -> None:
        """Free the scene's GPU buffers (the shared context stays)."""
        if self.context is not None and self._pid == os.getpid():
            _gl_context(1, 1)
            self.context.free()
        self.context = None

    def __enter__(self) -> GalleryRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["GalleryRenderer"]
