"""How stored records (``train.json``, the generalist's record, transfer scores) name an asset: by its path
and a content hash, never by its Python repr.

:func:`asset_content_hash` is a SHA-256 over what the simulation is built from: every link's name, label,
visual and collision geometry (vertices, faces, primitive sizes and poses) and every joint's type,
links, origin, axis and limits, in a fixed order. Two loads of the same files hash alike; any change of
geometry or articulation changes the hash. An in-memory asset (a prediction moved into the ground truth's
frame) hashes by the same rule, so a record can name it too.
"""

from __future__ import annotations

import hashlib

import numpy as np

from spark_bench.asset.model import ArticulatedAsset


def _update_array(digest, array) -> None:
    a = np.ascontiguousarray(np.asarray(array))
    if a.dtype.kind == "f":
        a = a.astype(np.float64)
    elif a.dtype.kind in "iub":
        a = a.astype(np.int64)
    digest.update(f"{a.shape}".encode())
    digest.update(a.tobytes())


def asset_content_hash(asset: ArticulatedAsset) -> str:
    """SHA-256 (hex) of the asset's links and joints (see the module docstring)."""
    digest = hashlib.sha256()
    for name in sorted(asset.links):
        link = asset.links[name]
        digest.update(f"link\0{name}\0{link.label}\0{link.semantic_joint}\n".encode())
        for visual in link.visuals:
            _update_array(digest, visual.mesh.vertices)
            _update_array(digest, visual.mesh.faces)
        for collision in link.collisions:
            digest.update(f"collision\0{collision.kind}\n".encode())
            _update_array(digest, collision.origin)
            _update_array(digest, collision.size)
            if collision.mesh is not None:
                _update_array(digest, collision.mesh.vertices)
                _update_array(digest, collision.mesh.faces)
    for name in sorted(asset.joints):
        joint = asset.joints[name]
        digest.update(f"joint\0{name}\0{joint.type}\0{joint.parent}\0{joint.child}\n".encode())
        _update_array(digest, joint.origin)
        _update_array(digest, joint.axis)
        _update_array(digest, [joint.lower, joint.upper])
    return digest.hexdigest()


def asset_record(asset) -> dict | None:
    """``{"path", "sha256"}`` naming ``asset`` as the environments take it (a folder, URDF, benchmark case,
    ``procedural:<seed>``, an :class:`ArticulatedAsset`, or None for the default cabinet).

    ``path`` is the resolved folder (a benchmark case's ground truth, the default cabinet's cache folder),
    ``procedural:<seed>``, or for an in-memory asset the file it was read from (None if none).
    """
    from spark_bench.envs.assets import load_asset

    loaded, key = load_asset(asset)
    path = key or (str(loaded.source) if loaded.source else None)
    return {"path": path, "sha256": asset_content_hash(loaded)}
