"""The real size of a PartNet-Mobility object: how many metres one of its length units is.

PartNet-Mobility's meshes come from ShapeNet, normalized per object, not in metres: read as metres, every
object of ``../shared/partnet_dev`` is 1.6-2.7 m across its box diagonal (a microwave 1.6 m wide, a wooden
box 1.6 m long whose lid weighs 44 kg). Physics needs the real size (masses, the forces that open a part, what
a gripper can hold), so :func:`~spark_bench.data.readers.load_object` scales such an object by the factor
:func:`source_scale` gives, before anything else reads it; the benchmark frame (which normalizes the size
away) and so every metric are unchanged by it. Only a PartNet-Mobility folder (it has ``mobility_v2.json``,
the dataset's own joint annotation) is scaled; the rule, first that applies:

1. ``info.json`` beside the object with a positive ``scale``: the per-object scale of the keypoint
   annotation that partnet_dev's copies carry (``keypoints``, ``keypoint_descriptions``, ``axis``,
   ``joint_position_range``, ``scale``). The manipulation pipelines that write this annotation multiply the
   object and its keypoints by ``scale`` to place it in a tabletop robot scene (InternRobotics'
   InternDataEngine: ``keypoint * object_scale``). Its sizes are those of a tabletop scene: microwaves
   0.39-0.49 m wide, safes 0.24-0.61 m, wooden boxes 0.28-0.33 m, tables 0.38-0.65 m long (a side table, not
   a dining table), suitcases 0.26-0.32 m (a vanity case's size); ``benchmarks/results/real_size.md`` lists them per category.
2. Without it, of a category in :data:`CATEGORY_SCALE`: the median of that annotation's scales over
   partnet_dev's objects of the category.
3. Otherwise 1 (the lengths read as metres, as before): synth objects (written in metres), method outputs,
   prepared ground truths (normalized; their case records the way back to metres), and PartNet-Mobility
   categories no annotation covers (StorageFurniture, Oven, Camera, Bottle among the shared objects).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

#: The per-object scale file some PartNet-Mobility copies carry (rule 1 of the module docstring).
SIZE_ANNOTATION = "info.json"
#: What marks a PartNet-Mobility folder: the dataset's own joint annotation.
PARTNET_MOBILITY_MARK = "mobility_v2.json"
#: Median of partnet_dev's ``info.json`` scales per category (all 75 objects; ``benchmarks/measure_real_size.py``
#: prints the table from a folder of annotated objects). Rule 2 of the module docstring.
CATEGORY_SCALE: dict[str, float] = {
    "Box": 0.2, "Bucket": 0.18, "CoffeeMachine": 0.2, "Faucet": 0.2, "Microwave": 0.3, "Safe": 0.35,
    "Suitcase": 0.2, "Table": 0.35, "Toaster": 0.2, "Window": 0.35,
}
#: Scales outside this range are not a unit change but a broken file.
SCALE_RANGE = (1e-3, 1e3)


@dataclass(frozen=True)
class SourceScale:
    """Metres per length unit of an object folder, and which rule gave it.

    :param factor: metres per unit (1: the lengths are metres)
    :param rule: ``"info.json"``, ``"category <name>"`` or ``"as read"``
    """

    factor: float
    rule: str

    def record(self) -> dict:
        """As ``case.json`` stores it (``source_scale``)."""
        return {"metres_per_unit": self.factor, "rule": self.rule}


AS_READ = SourceScale(1.0, "as read")


def _is_number(value) -> bool:
    """A JSON number (not a boolean, which Python counts as an int)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def annotated_scale(path: Path) -> float | None:
    """The ``scale`` of an ``info.json`` keypoint annotation, or None when the file has none.

    :raises InputError: naming the file when it is not JSON, or its ``scale`` is not a number in
        :data:`SCALE_RANGE`
    """
    from spark_bench.errors import InputError

    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"malformed JSON: {exc}") from None
    if not isinstance(data, dict) or "scale" not in data:
        return None
    scale = data["scale"]
    if isinstance(scale, list) and len(scale) >= 3 and all(_is_number(s) for s in scale[:3]) \
            and scale[0] == scale[1] == scale[2]:  # the file's own values, not computed: equal means written equal
        scale = scale[0]  # [s, s, s(, 1)]: one uniform scale written per axis (2 and 2.0 alike)
    if not _is_number(scale) or not math.isfinite(scale) or not SCALE_RANGE[0] <= scale <= SCALE_RANGE[1]:
        raise InputError(path, f'"scale" must be one number in [{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}] '
                               f"(metres per unit of the object), got {scale!r}")
    return float(scale)


def source_scale(folder: str | Path, category: str) -> SourceScale:
    """Metres per length unit of the object in ``folder`` (the rule of the module docstring).

    :param folder: the object folder (the URDF's folder)
    :param category: its ``meta.json`` ``model_cat``
    """
    folder = Path(folder)
    if not (folder / PARTNET_MOBILITY_MARK).is_file():  # another method's info.json may mean anything
        return AS_READ
    scale = annotated_scale(folder / SIZE_ANNOTATION)
    if scale is not None:
        return SourceScale(scale, SIZE_ANNOTATION)
    if category in CATEGORY_SCALE:
        return SourceScale(CATEGORY_SCALE[category], f"category {category}")
    return AS_READ
