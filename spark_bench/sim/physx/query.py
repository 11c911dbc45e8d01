"""PhysX's own contact queries on part-parent pairs that the articulation does not collide.

An articulation built without carrier links (:func:`~spark_bench.sim.physx.build.build_object`, ``carriers=False``:
the way SAPIEN's URDF loader builds it) lets a part pass through its parent. :class:`PairQuery` holds a free copy
of each such link's shapes in a scene of its own (gravity off, nothing jointed), places the copies where the
articulation's links are and lets PhysX's narrow phase find their contacts: the same contact generation as the
articulation's own, on the pair it filters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spark_bench.sim.physx import sapien_module
from spark_bench.sim.physx.build import PhysxObject


@dataclass
class PairContact:
    """The deepest contact of one queried pair.

    :param parent: the parent's group
    :param child: the child's group
    :param depth: penetration (m; negative: apart by that much, within the contact offset)
    :param shapes: ``(child's (link, hull), parent's (link, hull))`` of the deepest contact
    """

    parent: str
    child: str
    depth: float
    shapes: tuple


def _copy_shape(shape, material):
    """A free copy of an articulation link's PhysX shape (its cooked hull, box or sphere)."""
    physx = sapien_module().physx
    if isinstance(shape, physx.PhysxCollisionShapeBox):
        out = physx.PhysxCollisionShapeBox(half_size=np.asarray(shape.half_size, float).tolist(), material=material)
    elif isinstance(shape, physx.PhysxCollisionShapeSphere):
        out = physx.PhysxCollisionShapeSphere(radius=float(shape.radius), material=material)
    else:
        out = physx.PhysxCollisionShapeConvexMesh(vertices=np.asarray(shape.get_vertices(), np.float32),
                                                  scale=[1.0, 1.0, 1.0], material=material)
    out.local_pose = shape.local_pose
    out.set_contact_offset(shape.contact_offset)
    out.set_rest_offset(0.0)
    return out


class PairQuery:
    """Contact queries on the pairs of ``obj.filtered``.

    :param obj: the loaded object
    """

    def __init__(self, obj: PhysxObject):
        sapien = sapien_module()
        self.obj = obj
        self.scene = sapien.Scene([sapien.physx.PhysxCpuSystem()])
        self.scene.set_timestep(obj.timestep)
        material = sapien.physx.PhysxMaterial(0.0, 0.0, 0.0)
        self.bodies: dict[str, object] = {}
        for group in sorted({g for pair in obj.filtered for g in pair}):
            body = sapien.physx.PhysxRigidDynamicComponent()
            for shape in obj.links[group].component.collision_shapes:
                body.attach(_copy_shape(shape, material))
            body.disable_gravity = True
            entity = sapien.Entity()
            entity.name = group
            entity.add_component(body)
            self.scene.add_entity(entity)
            self.bodies[group] = body

    def contacts(self, pairs: list[tuple[str, str]] | None = None) -> list[PairContact]:
        """The deepest contact of each pair (of ``pairs``, default every queried pair) where the articulation's
        links are now; pairs farther apart than the contact offset are left out."""
        wanted = set(pairs if pairs is not None else self.obj.filtered)
        for group, body in self.bodies.items():
            body.entity.set_pose(self.obj.links[group].component.entity_pose)
            body.set_linear_velocity([0.0, 0.0, 0.0])
            body.set_angular_velocity([0.0, 0.0, 0.0])
        self.scene.step()
        best: dict[tuple[str, str], PairContact] = {}
        for contact in self.scene.physx_system.get_contacts():
            names = tuple(b.entity.name for b in contact.bodies)
            pair = names if names in wanted else names[::-1] if names[::-1] in wanted else None
            if pair is None or not contact.points:
                continue
            depth = -min(float(p.separation) for p in contact.points)
            parent_first = names == pair
            owners = [self._owner(b, s) for b, s in zip(contact.bodies, contact.shapes)]
            shapes = (owners[1], owners[0]) if parent_first else (owners[0], owners[1])
            if pair not in best or depth > best[pair].depth:
                best[pair] = PairContact(pair[0], pair[1], depth, shapes)
        return sorted(best.values(), key=lambda c: -c.depth)

    def _owner(self, body, shape) -> tuple[str, int]:
        group = self.obj.links[body.entity.name]
        return group.shapes[list(body.collision_shapes).index(shape)]
