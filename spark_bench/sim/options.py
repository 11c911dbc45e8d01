"""Options of the asset -> simulation conversion, as one plain dataclass shared by every module.

Defaults were chosen by measurement on the seven shared PartNet-Mobility objects and the ``synth``
dataset (see ``benchmarks/measure_convert.py`` and the module docstrings for the numbers).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np


@dataclass(frozen=True)
class Material:
    """What a part is made of.

    :param density: kg/m^3 of the material itself
    :param wall: thickness (m) of the walls a part of this material is built from, None for a solid
        part: a closed part is a shell of this thickness over its outer surface, never more than its
        solid (:func:`spark_bench.sim.physical.shell_fraction`)
    """

    density: float
    wall: float | None = None


#: Materials objects are made of. PartNet-Mobility models a suitcase, a microwave or a chest lid as a
#: closed solid, but the real part is a shell: a thin-walled part is not a solid block. Sources (the
#: table in ``benchmarks/results/masses.md`` checks the rule against real products' masses):
#:
#: - wood: particle board 620-660 kg/m^3 (swisskrono.pl technical data), pine ~500; cabinet bodies,
#:   doors and shelves of 18 mm board (thehousemag.com/?p=10126)
#: - plastic: ABS 1020-1080 kg/m^3 (24kjx.com.cn/news/915-en.html); injection-moulded walls 1.2-3.0 mm
#:   for ABS, 1.0-2.5 mm for PP (gudmould.com/news/2169.html): 2.5 mm
#: - sheet_metal: steel 7850 kg/m^3; appliance shells of 0.5-1.0 mm cold-rolled sheet
#:   (foodequipmentparts.net, steelgalvanized.com), doubled by a door's inner panel, glass and liner:
#:   1.5 mm of steel per unit of outer surface gives a 60 x 50 x 6 cm oven door 8.6 kg (cited 15-30 lb)
#: - steel_plate: safes, bodies of at least 3 mm steel, doors 6 mm or more (safes4less.com.au)
#: - glass: 2500 kg/m^3, 4 mm float glass 10 kg/m^2 (hnsaluminium.co.uk)
#: - metal, ceramic: solid (a faucet lever, a kettlebell; a toilet's fixed bowl)
MATERIALS = {
    "wood": Material(600.0, 0.018),
    "plastic": Material(1050.0, 0.0025),
    "sheet_metal": Material(7850.0, 0.0015),
    "steel_plate": Material(7850.0, 0.003),
    "glass": Material(2500.0, 0.004),
    "metal": Material(2700.0),
    "ceramic": Material(2300.0),
    "default": Material(800.0),
}

#: Material of an object by PartNet-Mobility category (lower case); unknown categories use ``default``.
CATEGORY_MATERIAL = {
    "storagefurniture": "wood", "table": "wood", "door": "wood", "chair": "wood", "box": "wood",
    "oven": "sheet_metal", "microwave": "sheet_metal", "refrigerator": "sheet_metal",
    "dishwasher": "sheet_metal", "washingmachine": "sheet_metal", "safe": "steel_plate", "trashcan": "plastic",
    "toilet": "ceramic", "bottle": "plastic", "camera": "plastic", "laptop": "plastic", "kettlebell": "metal",
    "bucket": "plastic", "kitchenpot": "metal", "faucet": "metal", "window": "glass",
    "dispenser": "plastic", "lighter": "plastic", "printer": "plastic", "phone": "plastic",
    "remote": "plastic", "stapler": "metal", "suitcase": "plastic",
}

#: Material of the moving parts where it differs from the body's: a ceramic toilet's seat and lid are
#: plastic. (Only which links move is used, so a prediction gets the same rule as the ground truth.)
MOVING_PART_MATERIAL = {"toilet": "plastic"}


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
    :param exact_boxes: a non-convex part that is an orthogonal polyhedron is cut exactly into boxes
        (:mod:`spark_bench.sim.boxes`) instead of going to CoACD (conv-8); False gives conv-7's CoACD hulls
    :param workers: parallel processes for CoACD (0: one per CPU core, 1: serial)
    :param use_cache: reuse CoACD results from the content-hash cache
    :param decompose_visuals: a link with no ``<collision>`` gets hulls from its visual meshes

    Physics
    :param density: kg/m^3 of every link, as solid parts; None picks each link's :class:`Material` from
        :data:`CATEGORY_MATERIAL` (:meth:`material_of`)
    :param link_density: per-link density overrides (solid), by link name
    :param joint_damping: damping of every hinge (N m s/rad) and slide (N s/m), scaled by the part's
        mass and size (see :mod:`spark_bench.sim.physical`); a URDF ``<dynamics damping>`` wins
    :param joint_armature: rotor inertia added to each joint, as a fraction of the part's own inertia
        about (or mass along) the joint
    :param joint_frictionloss: dry friction, as a fraction of the part's weight (slides) or of its
        weight times its size (hinges); a URDF ``<dynamics friction>`` wins
    :param friction: geom sliding friction coefficient
    :param trim_overlap: a hull of a part and a hull of its parent that overlap at rest by more than this
        fraction of the object's size are cut apart (a hull's bulge, not a real contact:
        :mod:`spark_bench.sim.rest_trim`); a pair no cut resolves (an overlap by construction) does not collide
        at all; shallower overlaps collide as they are

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
    exact_boxes: bool = True
    workers: int = 0
    use_cache: bool = True
    decompose_visuals: bool = True
    density: float | None = None
    link_density: dict[str, float] = field(default_factory=dict)
    joint_damping: float = 1.0
    joint_armature: float = 0.05
    joint_frictionloss: float = 0.02
    friction: float = 0.6
    trim_overlap: float = 0.0
    base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def material_of(self, category: str, link: str, moving: bool = False) -> Material:
        """The :class:`Material` of ``link`` of an object of ``category``: a density given in the options
        makes a solid part of that density; otherwise the category's material (:data:`CATEGORY_MATERIAL`,
        :data:`MOVING_PART_MATERIAL` for a ``moving`` link).

        :param category: PartNet-Mobility category (any case and spacing)
        :param link: link name
        :param moving: whether a joint moves the link
        """
        if link in self.link_density:
            return Material(float(self.link_density[link]))
        if self.density is not None:
            return Material(float(self.density))
        key = category.lower().replace(" ", "")
        name = MOVING_PART_MATERIAL.get(key) if moving else None
        return MATERIALS[name or CATEGORY_MATERIAL.get(key, "default")]

    def to_dict(self) -> dict:
        """Plain JSON-able dict (written beside the converted model)."""
        out = asdict(self)
        out["base_pos"] = [float(x) for x in np.asarray(self.base_pos)]
        out["base_quat"] = [float(x) for x in np.asarray(self.base_quat)]
        return out
