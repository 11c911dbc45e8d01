"""MuJoCo offscreen rendering of an :class:`ArticulatedAsset`: RGB and per-link segmentation.

The scene is built once per asset with ``mujoco.MjSpec``: one mocap body per link (so a configuration
is just a set of body poses from forward kinematics, no joints and no recompilation), one mesh geom
per link visual with its colour, several directional lights (a soft stand-in for the environment
lighting of SPARK's renders) plus the headlight, and a flat neutral sky as the background. The one
camera of the model is moved to the requested :class:`~spark_bench.data.camera.CameraView`; its
projection is exactly the view's OpenCV intrinsics (``tests/test_render.py`` checks this).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

from spark_bench.asset.mesh import drop_degenerate_faces
from spark_bench.asset.model import ArticulatedAsset, Configuration
from spark_bench.data.camera import CameraView
from spark_bench.mujoco_gl import mujoco_module

#: Background colour of the renders (a neutral grey: white and black parts both stand out), RGB in [0, 1].
BACKGROUND = (0.78, 0.78, 0.78)
#: Directional lights ``(direction, diffuse intensity, casts shadow)``: key, fill, rim and top lights.
#: No shadows: MuJoCo's shadow map speckles surfaces at grazing angles (an open oven door), and the
#: environment lighting these lights stand in for casts none to speak of.
LIGHTS = (
    ((0.6, 0.5, -0.8), 0.45, False),
    ((0.4, -0.7, -0.5), 0.25, False),
    ((-0.7, 0.3, -0.4), 0.15, False),
    ((0.0, 0.0, -1.0), 0.20, False),
)
HEADLIGHT = {"ambient": 0.22, "diffuse": 0.28, "specular": 0.05}
CAMERA_NAME = "view"


@dataclass
class Rendering:
    """One rendered view.

    :param rgb: ``(H, W, 3)`` uint8 colour image
    :param segmentation: ``(H, W)`` uint16 labels: 0 background, ``k + 1`` for link ``links[k]``
    :param links: the link names the labels index
    """

    rgb: np.ndarray
    segmentation: np.ndarray
    links: list[str]

    def mask(self, link: str) -> np.ndarray:
        """Boolean mask of one link."""
        return self.segmentation == self.links.index(link) + 1


def _clean_for_mujoco(mesh: trimesh.Trimesh) -> trimesh.Trimesh | None:
    """The mesh without zero-area faces (MuJoCo rejects degenerate meshes); None when nothing is left."""
    cleaned = drop_degenerate_faces(mesh.vertices, mesh.faces)
    return None if cleaned is None else trimesh.Trimesh(*cleaned, process=False)


def _rotation_to_quat(rotation: np.ndarray) -> np.ndarray:
    mujoco = mujoco_module()
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).reshape(9))
    return quat


def mujoco_camera_quat(view: CameraView) -> np.ndarray:
    """MuJoCo camera orientation (x right, y up, looking along -z) of an OpenCV view."""
    cam_to_world = view.camera_to_world[:3, :3]
    return _rotation_to_quat(cam_to_world @ np.diag([1.0, -1.0, -1.0]))


def _scene_spec(width: int, height: int, background=BACKGROUND):
    """The empty scene: lights, sky, camera and offscreen buffer; bodies are added by the caller."""
    mujoco = mujoco_module()
    spec = mujoco.MjSpec()
    spec.modelname = "spark_bench_render"
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    glob = spec.visual.global_
    glob.offwidth, glob.offheight = int(width), int(height)
    spec.visual.quality.offsamples = 4
    spec.visual.quality.shadowsize = 2048
    spec.visual.map.znear, spec.visual.map.zfar = 0.01, 50.0
    head = spec.visual.headlight
    head.ambient = [HEADLIGHT["ambient"]] * 3
    head.diffuse = [HEADLIGHT["diffuse"]] * 3
    head.specular = [HEADLIGHT["specular"]] * 3
    # fix the model's scale so near/far planes do not depend on the object (benchmark frame: [-1, 1]^3)
    spec.stat.center = [0.0, 0.0, 0.0]
    spec.stat.extent = 2.0
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT, rgb1=list(background), rgb2=list(background),
                     width=8, height=8)
    for direction, intensity, shadow in LIGHTS:
        light = spec.worldbody.add_light()
        light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        light.dir = list(np.asarray(direction) / np.linalg.norm(direction))
        light.pos = list(-3.0 * np.asarray(direction) / np.linalg.norm(direction))
        light.diffuse = [intensity] * 3
        light.specular = [0.08] * 3
        light.ambient = [0.0] * 3
        light.castshadow = bool(shadow)
    camera = spec.worldbody.add_camera(name=CAMERA_NAME)
    camera.fovy = 40.0
    return spec


class AssetRenderer:
    """Renders one asset at any configuration and view; compiled once, reused for every image.

    :param asset: the asset (any frame; the benchmark frame fits the default camera)
    :param width: largest image width that will be asked for
    :param height: largest image height (default: ``width``)
    :param links: link order of the segmentation labels (default: all links in file order)
    :param background: sky colour, RGB in [0, 1]
    """

    def __init__(self, asset: ArticulatedAsset, width: int = 512, height: int | None = None,
                 links: Sequence[str] | None = None, background=BACKGROUND):
        mujoco = mujoco_module()
        self.asset = asset
        self.width, self.height = int(width), int(height or width)
        self.links = list(links) if links is not None else list(asset.links)
        unknown = set(self.links) - set(asset.links)
        if unknown:
            raise KeyError(f"{asset.name}: no link named {sorted(unknown)}")
        spec = _scene_spec(self.width, self.height, background)
        geom_label: dict[str, int] = {}
        self._bodies: list[str] = []
        for index, name in enumerate(self.links):
            link = asset.links[name]
            visuals = [(k, v, _clean_for_mujoco(v.mesh)) for k, v in enumerate(link.visuals)]
            visuals = [(k, v, m) for k, v, m in visuals if m is not None]
            if not visuals:
                continue
            body = spec.worldbody.add_body(name=f"link:{name}", mocap=True)
            self._bodies.append(name)
            for k, visual, mesh in visuals:
                tag = f"{index}_{k}"
                spec_mesh = spec.add_mesh(name=f"mesh_{tag}")
                spec_mesh.uservert = mesh.vertices.astype(np.float32).reshape(-1).tolist()
                spec_mesh.userface = mesh.faces.astype(np.int32).reshape(-1).tolist()
                spec_mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
                spec_mesh.maxhullvert = 4  # never used for contacts: keep the hull tiny
                rgba = [float(c) for c in visual.rgba[:3]] + [1.0]
                spec.add_material(name=f"mat_{tag}", rgba=rgba, specular=0.15, shininess=0.25, reflectance=0.0)
                body.add_geom(name=f"geom_{tag}", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"mesh_{tag}",
                              material=f"mat_{tag}", contype=0, conaffinity=0)
                geom_label[f"geom_{tag}"] = index + 1
        try:
            self.model = spec.compile()
        except Exception as exc:  # MuJoCo raises ValueError with its compiler message
            raise ValueError(f"{asset.name}: MuJoCo cannot build the render scene: {exc}") from None
        self.data = mujoco.MjData(self.model)
        self._geom_label = np.zeros(self.model.ngeom, dtype=np.uint16)
        for geom_name, label in geom_label.items():
            self._geom_label[self.model.geom(geom_name).id] = label
        self._mocap = {name: int(self.model.body_mocapid[self.model.body(f"link:{name}").id])
                       for name in self._bodies}
        self._camera = self.model.camera(CAMERA_NAME).id
        self._renderer = None

    def _get_renderer(self, width: int, height: int):
        mujoco = mujoco_module()
        if width > self.width or height > self.height:
            raise ValueError(f"image {width}x{height} exceeds the renderer's {self.width}x{self.height}")
        r = self._renderer
        if r is None or r.width != width or r.height != height:
            if r is not None:
                r.close()
            self._renderer = mujoco.Renderer(self.model, height=height, width=width)
        return self._renderer

    def pose(self, q: Configuration | None = None) -> None:
        """Place every link body at its forward-kinematics pose for configuration ``q``."""
        poses = self.asset.link_poses(q)
        for name, mocap in self._mocap.items():
            self.data.mocap_pos[mocap] = poses[name][:3, 3]
            self.data.mocap_quat[mocap] = _rotation_to_quat(poses[name][:3, :3])

    def set_view(self, view: CameraView) -> None:
        """Move the model's camera to ``view`` (same pose and vertical field of view)."""
        self.model.cam_pos[self._camera] = view.position
        self.model.cam_quat[self._camera] = mujoco_camera_quat(view)
        self.model.cam_fovy[self._camera] = view.fov_deg

    def render(self, view: CameraView, q: Configuration | None = None, segmentation: bool = True) -> Rendering:
        """RGB (and per-link labels) of the asset at ``q`` (default: rest) seen from ``view``.

        :param view: the camera; its image size must fit the renderer's
        :param q: joint values by name; missing joints at rest
        :param segmentation: also render the label image (otherwise it is all zeros)
        """
        mujoco = mujoco_module()
        self.pose(q)
        self.set_view(view)
        mujoco.mj_forward(self.model, self.data)
        renderer = self._get_renderer(view.width, view.height)
        renderer.update_scene(self.data, camera=self._camera)
        rgb = renderer.render().copy()
        labels = np.zeros((view.height, view.width), dtype=np.uint16)
        if segmentation:
            renderer.enable_segmentation_rendering()
            try:
                renderer.update_scene(self.data, camera=self._camera)
                ids = renderer.render()
            finally:
                renderer.disable_segmentation_rendering()
            objid, objtype = ids[..., 0], ids[..., 1]
            is_geom = (objtype == int(mujoco.mjtObj.mjOBJ_GEOM)) & (objid >= 0) & (objid < len(self._geom_label))
            labels[is_geom] = self._geom_label[objid[is_geom]]
        return Rendering(rgb=rgb, segmentation=labels, links=list(self.links))

    def close(self) -> None:
        """Free the OpenGL context."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> AssetRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def render_asset(asset: ArticulatedAsset, view: CameraView, q: Configuration | None = None,
                 links: Sequence[str] | None = None) -> Rendering:
    """One-off render of ``asset`` at ``q`` from ``view`` (builds and frees a renderer)."""
    with AssetRenderer(asset, view.width, view.height, links=links) as renderer:
        return renderer.render(view, q)
