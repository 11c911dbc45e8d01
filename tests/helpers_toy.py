"""A tiny articulated cabinet built in code: the known asset of the joint-optimization tests and benchmark.

A box carcass, a door on a vertical hinge along its left front edge (opening outwards, axis ``down`` in
the paper's convention) and a drawer sliding out of the front, in the PartNet-Mobility layout and the
benchmark frame, with a camera like the dataset's (40 degree field of view, 4 units away).
"""

from __future__ import annotations

import json

import numpy as np
from helpers_boxes import box_between

from spark_bench.asset.model import ArticulatedAsset
from spark_bench.methods.ours.assemble import assemble_asset
from spark_bench.methods.ours.camera import Camera, look_at_camera
from spark_bench.methods.ours.geometry import PartGeometry
from spark_bench.methods.ours.structure import OBJECT_TO_WORLD, PriorJoint, PriorLink, PriorStructure


def toy_cabinet(door_angle: float = 1.2, drawer_travel: float = 0.45) -> ArticulatedAsset:
    """The cabinet; its joints' upper limits are the open values ``door_angle`` and ``drawer_travel``.

    Object frame (y up, front +z): carcass ``[-0.6, 0.6] x [-1, 1] x [-0.5, 0.4]``, door on the upper
    front with its hinge at ``x = -0.6, z = 0.4`` (where it meets the carcass), drawer in the lower front.
    """
    geometry = PartGeometry(
        meshes={
            "body": box_between((-0.6, -1.0, -0.5), (0.6, 1.0, 0.4), OBJECT_TO_WORLD),
            "door": box_between((-0.6, -0.1, 0.4), (0.6, 1.0, 0.47), OBJECT_TO_WORLD),
            "drawer": box_between((-0.55, -0.95, -0.4), (0.55, -0.2, 0.47), OBJECT_TO_WORLD),
        },
        labels={"body": "body", "door": "door", "drawer": "drawer"},
        source="toy",
    )
    prior = PriorStructure(
        links=[PriorLink("body", "body"), PriorLink("door", "door"), PriorLink("drawer", "drawer")],
        joints=[
            PriorJoint("joint_0", "revolute", "body", "door", axis="down", origin=[-0.6, 0.45, 0.40],
                       upper=door_angle),
            PriorJoint("joint_1", "prismatic", "body", "drawer", axis="front", origin=[0.0, -0.575, 0.47],
                       upper=drawer_travel),
        ],
        source="toy",
    )
    asset = assemble_asset(prior, geometry, name="toy_cabinet", category="StorageFurniture")
    asset.links["door"].label, asset.links["drawer"].label = "door", "drawer"
    return asset


#: A view from the front-right and well above: the door's swing is seen from the top, so its hinge is
#: determined by the silhouette. From low views a hinge shifted along the viewing direction, with a
#: slightly different opening angle, gives nearly the same silhouette (measured: 0.05 units of pivot for
#: 1e-4 of loss at 128 px from the direction (-0.80, 0.45, 0.40)).
HIGH_VIEW = (-0.55, -0.35, 0.75)


def toy_camera(size: int = 256, direction=HIGH_VIEW) -> Camera:
    """A camera 4 units from the center looking at it from ``direction`` (world: front -X, up +Z)."""
    direction = np.asarray(direction, dtype=float)
    return look_at_camera(4.0 * direction / np.linalg.norm(direction), size=size, fov_deg=40.0)


def write_toy_case(case_dir, asset: ArticulatedAsset | None = None, camera: Camera | None = None,
                   case_id: str = "toy_cabinet") -> None:
    """A benchmark case folder (docs/formats.md) for ``asset`` (default: :func:`toy_cabinet`).

    Label images (0 background, k + 1 = link k) come from the exact rasterizer; the input and open
    images are the masks drawn grey on white (enough for the offline backends).
    """
    from PIL import Image

    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data.case import BenchmarkCase
    from spark_bench.methods.ours.render import asset_label_image

    case = BenchmarkCase(case_dir)
    case.folder.mkdir(parents=True, exist_ok=True)
    asset = asset or toy_cabinet()
    camera = camera or toy_camera(256)
    write_object_folder(asset, case.gt_dir)
    for state, q in (("input", asset.rest_configuration()), ("open", asset.open_configuration())):
        # a label image as the format says (k + 1 = link k), not a 0/1 mask: a 0/1 image would say
        # that every object pixel is link 0's, and the per-part supervision would believe it
        image_path, seg_path = case.state_files(state)
        labels = asset_label_image(asset, q, camera)
        Image.fromarray(labels.astype(np.uint16)).save(seg_path)
        mask = labels > 0
        Image.fromarray(np.where(mask, 120, 255).astype(np.uint8)).convert("RGB").save(image_path)
    joints = []
    frames = asset.joint_frames()
    for joint in asset.movable_joints():
        point, direction = frames[joint.name]
        joints.append({"name": joint.name, "type": joint.type, "parent": joint.parent, "child": joint.child,
                       "axis": direction.tolist(), "origin": point.tolist(), "lower": joint.lower,
                       "upper": joint.upper, "label": asset.links[joint.child].label})
    focal = float(camera.intrinsics[1, 1])
    camera_to_world = np.linalg.inv(camera.world_to_camera)
    case.camera_path.write_text(json.dumps({
        "width": camera.width, "height": camera.height,
        "fov_deg": float(np.degrees(2 * np.arctan(camera.height / 2 / focal))),
        "distance": float(np.linalg.norm(camera_to_world[:3, 3])),
        "intrinsics": camera.intrinsics.tolist(), "world_to_camera": camera.world_to_camera.tolist(),
        "camera_to_world": camera_to_world.tolist(), "position": camera_to_world[:3, 3].tolist(),
        "convention": "opencv"}))
    case.write_record({"id": case_id, "category": asset.category, "source": "toy", "links": list(asset.links),
                       "joints": joints, "normalization": {"center": [0, 0, 0], "scale": 1.0},
                       "image_size": camera.width, "view_seed": 0})
