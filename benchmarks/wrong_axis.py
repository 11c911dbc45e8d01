"""A wrong joint axis to plan from: the true one turned by 90 degrees. The opening score's planner given it
shows what a reconstruction with a wrong axis scores (``measure_suction``, ``measure_fronts``)."""

from __future__ import annotations

import numpy as np


def turned(axis: np.ndarray, about: np.ndarray) -> np.ndarray:
    """``axis`` turned by 90 degrees about the unit direction ``about``."""
    return np.cross(about, axis) + about * float(about @ axis)


def wrong_axis(axis: np.ndarray, joint_type: str, outward: np.ndarray) -> np.ndarray:
    """The true axis turned by 90 degrees: a drawer's about the vertical (or, for a vertical drawer, about the
    face's first in-plane direction), a door's or lid's about the face's outward direction."""
    if joint_type == "prismatic":
        about = np.array([0.0, 0.0, 1.0])
        if abs(float(axis @ about)) > 0.9:
            about = np.cross(axis, [1.0, 0.0, 0.0])
        return turned(axis, about / np.linalg.norm(about))
    return turned(axis, outward)
