"""Options of the asset -> simulation conversion, as one plain dataclass shared by every module.

Defaults were chosen by measurement on the seven shared PartNet-Mobility objects and the ``synth``
dataset (see ``benchmarks/measure_convert.py`` and the module docstrings for the numbers).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

#: Densities in kg/m^3 of the materials objects are made of. Panels are modelled as solid hulls, so
#: wood and plastic are the panel material itself; appliances are hollow sheet-metal boxes whose parts
#: PartNet models as solid slabs, so they get an effective density (an oven door comes out ~15 kg).
MATERIAL_DENSITY = {
    "wood": 600.0,        # particle board / pine furniture panels
    "metal": 2700.0,      # solid metal parts (aluminium)
    "sheet_metal": 800.0,  # appliance casings, doors and racks: hollow sheet metal, modelled solid
    "plastic": 1050.0,    # ABS / polypropylene
    "glass": 2500.0,
    "ceramic": 2300.0,
    "default": 800.0,
}

#: Material of an object by PartNet-Mobility category (lower case); unknown categories use ``default``.
CATEGORY_MATERIAL = {
    "storagefurniture": "wood", "table": "wood", "door": "wood", "chair": "wood", "box": "wood",
    "oven": "sheet_metal", "microwave": "sheet_metal", "refrigerator": "sheet_metal",
    "dishwasher": "sheet_metal", "washingmachine": "sheet_metal", "safe": "sheet_metal", "trashcan": "plastic", "toilet": "ceramic",
    "bottle": "plastic", "camera": "plastic", "laptop": "plastic", "kettlebell": "metal",
    "bucket": "plastic", "kitchenpot": "metal", "faucet": "metal", "window": "glass",
    "dispenser": "plastic", "lighter": "plastic", "printer": "plastic", "phone": "plastic",
    "remote": "plastic", "stapler": "metal", "suitcase": "plastic",
}


@dataclass
class CoacdParams:
    """Parameters of a CoACD run (those that change its result; all enter the cache key).

    Defaults measured on the 46 parts of the seven shared objects that are not near-convex (CPU
    seconds for all 46 / mean one-sided hull error as a fraction of the part's diagonal / hulls):
    CoACD's own defaults 424 s / 0.0239 / 388; 60 MCTS iterations (depth 2, 12 nodes) 133 s /
    0.0249 / 361; 30 iterations 95 s / 0.0261 / 394; these defaults (15 iterations, 6 nodes,
    resolution 500, preprocessing at 40) 55 s / 0.0267 / 381; threshold 0.08 80 s / 0.0343 / 302.
    7.7 times faster than CoACD's defaults for 0.3 % of a part's size more hull error.

    :param threshold: concavity threshold (CoACD's default 0.05)
    :param preprocess_mode: CoACD's manifold preprocessing: ``auto``, ``on`` or ``off``; our input is
        already watertight, so ``off`` skips a second remesh
    :param preprocess_resolution: voxel resolution of CoACD's own preprocessing
    :param resolution: CoACD's sampling resolution for concavity
    :param mcts_iterations: Monte-Carlo tree search iterations per cut (CoACD default 150)
    :param mcts_depth: search depth (CoACD default 3)
    :param mcts_nodes: search width (CoACD default 20)
    :param max_convex_hull: hull budget per call, -1 for no limit (CoACD merges hulls down to it)
    :param seed: random seed (results are deterministic for a seed)
    """

    threshold: float = 0.05
    preprocess_mode: str = "auto"
    preprocess_resolution: int = 40
    resolution: int = 500
    mcts_iterations: int = 15
    mcts_depth: int = 2
    mcts_nodes: int = 6
    max_convex_hull: int = 16
    seed: int = 0

    @classmethod
    def coacd_defaults(cls) -> CoacdParams:
        """CoACD's own defaults (the reference the speed benchmark compares against)."""
        return cls(threshold=0.05, preprocess_mode="auto", preprocess_resolution=50, resolution=2000,
                   mcts_iterations=150, mcts_depth=3, mcts_nodes=20, max_convex_hull=-1, seed=0)

    def as_kwargs(self) -> dict:
        """Keyword arguments of ``coacd.run_coacd``."""
        return dict(threshold=self.threshold, preprocess_mode=self.preprocess_mode,
                    preprocess_resolution=self.preprocess_resolution, resolution=self.resolution,
                    mcts_iterations=self.mcts_iterations, mcts_max_depth=self.mcts_depth,
                    mcts_nodes=self.mcts_nodes, max_convex_hull=self.max_convex_hull, seed=self.seed)


@dataclass
class ConvertOptions:
    """How an :class:`~spark_bench.asset.model.ArticulatedAsset` becomes a simulation model.

    Geometry
    :param coacd: parameters of CoACD runs on non-convex parts
    :param convex_tolerance: a part is used as its own convex hull when the hull surface stays within
        this fraction of the link's bounding-box diagonal from the part (CoACD is skipped for it).
        Measured on 41083: at 0.01 the bevelled door and drawer frames (1.1-1.4 %) go to CoACD, 13
        calls and 62 CPU-seconds; at 0.02 none do, and every check still passes on all seven objects
    :param min_thickness: flat or thin parts are thickened to this fraction of the object's size
    :param max_part_faces: a closed (watertight) part mesh with more faces is simplified (quadric
        decimation, to this many) before its convexity test and CoACD. A case's ground truth is a watertight R=200 remesh with
        10^5-10^6 faces per link; CoACD skips its own remeshing on such manifold input and cuts the full
        mesh: 18 CPU-s for the 300k-face body of box 47645 and minutes for larger ones; at 5000 faces
        6 s, the mean distance from its hulls to the surface 0.9 % of the part's diagonal instead of
        0.5 % (``benchmarks/measure_sim_real.py`` reports the seconds per case). 0: never
    :param clearance: gap left between parts, as a fraction of the object's size: each generated hull
        shrinks by half of it (PartNet-Mobility parts are modelled with zero gap, so a door's edge grazes
        its frame; real furniture has 1-3 mm). Given primitives and convex meshes are not shrunk.
        Measured: without it both doors of 41083 jam at 2-10 % (their edges sweep 1.3 mm into the
        face frame); 0.001 (2 mm on that cabinet) frees them
    :param hull_budget: most convex hulls of a link as large as the object; a smaller link gets
        ``hull_budget * sqrt(link size / object size)`` (at least 4); beyond it, hulls are merged
    :param max_hull_vertices: vertices kept per hull (MuJoCo and PyBullet are fastest with few)
    :param workers: parallel processes for CoACD (0: one per CPU core, 1: serial)
    :param use_cache: reuse CoACD results from the content-hash cache
    :param decompose_visuals: a link with no ``<collision>`` gets hulls from its visual meshes

    Physics
    :param density: kg/m^3 for every link; None picks it from :data:`CATEGORY_MATERIAL`
    :param link_density: per-link density overrides, by link name
    :param joint_damping: damping of every hinge (N m s/rad) and slide (N s/m), scaled by the part's
        mass and size (see :mod:`spark_bench.sim.physical`); a URDF ``<dynamics damping>`` wins
    :param joint_armature: rotor inertia added to each joint, as a fraction of the part's own inertia
        about (or mass along) the joint
    :param joint_frictionloss: dry friction, as a fraction of the part's weight (slides) or of its
        weight times its size (hinges); a URDF ``<dynamics friction>`` wins
    :param friction: geom sliding friction coefficient
    :param exclude_overlap: a parent-child pair whose hulls overlap at rest by more than this fraction
        of the object's size does not collide (the overlap is by construction, not a real contact)

    Placement
    :param base_pos: position of the root link in the world
    :param base_quat: orientation (w, x, y, z) of the root link in the world
    """

    coacd: CoacdParams = field(default_factory=CoacdParams)
    convex_tolerance: float = 0.02
    min_thickness: float = 0.004
    max_part_faces: int = 5000
    clearance: float = 0.001
    hull_budget: int = 48
    max_hull_vertices: int = 64
    workers: int = 0
    use_cache: bool = True
    decompose_visuals: bool = True
    density: float | None = None
    link_density: dict[str, float] = field(default_factory=dict)
    joint_damping: float = 1.0
    joint_armature: float = 0.05
    joint_frictionloss: float = 0.02
    friction: float = 0.6
    exclude_overlap: float = 0.002
    base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def density_of(self, category: str, link: str) -> float:
        """Density (kg/m^3) of ``link`` of an object of ``category``."""
        if link in self.link_density:
            return float(self.link_density[link])
        if self.density is not None:
            return float(self.density)
        material = CATEGORY_MATERIAL.get(category.lower().replace(" ", ""), "default")
        return MATERIAL_DENSITY[material]

    def to_dict(self) -> dict:
        """Plain JSON-able dict (written beside the converted model)."""
        out = asdict(self)
        out["base_pos"] = [float(x) for x in np.asarray(self.base_pos)]
        out["base_quat"] = [float(x) for x in np.asarray(self.base_quat)]
        return out
