"""An articulated asset seen at its rest configuration, each link's world mesh computed once: the grasp
planner (:mod:`spark_bench.manipulation.grasp`) merges the same links' meshes many times per joint, and a real
object's visual meshes hold 10^5-10^6 vertices."""

from __future__ import annotations

from spark_bench.asset.model import ArticulatedAsset


class RestMeshes:
    """An asset seen at rest, each link's world mesh computed once (the planner merges the same links'
    meshes many times: a real object's visual meshes hold 10^5-10^6 vertices). Everything but
    :meth:`mesh` is the asset's own.

    :param asset: the object
    """

    def __init__(self, asset: ArticulatedAsset):
        self.asset = asset
        self._links = asset.link_meshes()
        self._merged: dict[tuple, object] = {}

    def __getattr__(self, name):
        if name.startswith("__") or name in ("asset", "_links", "_merged"):  # copy/pickle probes, no recursion
            raise AttributeError(name)
        return getattr(self.asset, name)

    def mesh(self, q=None, links=None):
        """The given links (default all) merged, world frame at rest (at ``q``, when given, computed afresh)."""
        from spark_bench.asset.mesh import merge_meshes

        if q is not None:
            return self.asset.mesh(q, links)
        key = tuple(links) if links is not None else None
        if key not in self._merged:
            names = self._links if links is None else [name for name in links if name in self._links]
            self._merged[key] = merge_meshes([self._links[name] for name in names])
        return self._merged[key]
