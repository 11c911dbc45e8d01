"""Procedural articulated objects in the PartNet-Mobility on-disk format.

``generate_dataset(out, n, seed)`` writes ``n`` objects round-robin over :data:`CATEGORIES`;
``generate_object(category, seed, out, object_id)`` writes one. Every object is built from convex
primitives (boxes, cylinders, frustums), so its collision geometry is convex by construction, its
visual meshes are watertight unions, and the generator verifies that no part touches another at rest
or anywhere along its joint's range (:mod:`spark_bench.data.synth.clearance`).
"""

from spark_bench.data.synth.generate import (
    CATEGORIES,
    GENERATOR_VERSION,
    build_object,
    generate_dataset,
    generate_object,
    object_seed,
)

__all__ = ["CATEGORIES", "GENERATOR_VERSION", "build_object", "generate_dataset", "generate_object", "object_seed"]
