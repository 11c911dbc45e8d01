"""The articulated-asset model, URDF I/O, forward kinematics and mesh operations."""

from spark_bench.asset.joint_type import MOVABLE_TYPES, JointType
from spark_bench.asset.model import (
    JOINT_TYPES,
    ArticulatedAsset,
    Collision,
    Joint,
    Link,
    Visual,
)
from spark_bench.asset.ops import normalize_asset, scale_asset, translate_asset
from spark_bench.asset.urdf import load_urdf, write_object_folder, write_urdf

__all__ = [
    "JOINT_TYPES", "MOVABLE_TYPES", "ArticulatedAsset", "Collision", "Joint", "JointType", "Link", "Visual",
    "load_urdf", "normalize_asset", "scale_asset", "translate_asset", "write_object_folder", "write_urdf",
]
