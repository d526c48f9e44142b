"""How the gripper takes an object, in numbers: the margins the grasp planner keeps, and the width
across an object where it would hold it (:func:`held_width`), for checks made before any scene
exists (``pipette new-task`` refusing a plate wider than the gripper opens).
"""

from __future__ import annotations

import numpy as np

GRIP_MARGIN = 0.006
"""Metres the open gripper must exceed the object's width by."""
PALM_MARGIN = 0.008
"""Metres kept between the object's top and the palm."""
FINGERTIP_LIFT = 0.012
"""Lowest tcp height above the supporting surface for a straight-down grasp (fingertips' reach)."""
FLAT = 0.03
"""Objects lower than this and than they are wide are pinched at the rim rather than taken around
an axis (unless long; see :func:`flat`)."""
LONG = 2.5
"""A low object whose footprint is this many times longer than wide (a syringe, tweezers, a rod
lying on the bench) is taken across its long axis from above, not pinched at a rim."""
ROUND = 0.006
"""Metres within which a flat object's footprint sides count as equal: round (a dish), not a plate."""
GRASP_SLAB = 0.008
"""Metres above and below the grasp height whose collision boxes count for the width held."""


def flat(height: float, footprint: np.ndarray) -> bool:
    """Whether an object ``height`` tall with ``footprint`` (its two horizontal sizes) is flat: lower
    than :data:`FLAT` and than it is wide (a dish, a plate, a slide), not a small upright tube (a
    0.2 mL PCR tube, 23 mm tall and 7 mm across, is taken around its axis)."""
    return bool(height < FLAT and height < float(np.min(footprint)))


def held_width(
    boxes: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    *,
    finger_depth: float,
    grasp_z: float | None = None,
    lying: bool = False,
) -> float | None:
    """Metres across an object where the grasp planner would take it, from its resting collision
    boxes (rows ``x0 y0 z0 x1 y1 z1``) and bounds; None for a flat round object (a dish), which is
    pinched across a chord near its rim as narrow as the gripper needs. A flat rectangle (a plate,
    a slide) is pinched across a whole side, its narrower one at best; a lying object is taken
    across its long axis; an upright one around its axis at ``grasp_z`` (its grasp site's height,
    else 60 % up), kept within the fingers' reach of its top and above the fingertips' lift."""
    footprint = high[:2] - low[:2]
    if flat(float(high[2] - low[2]), footprint):
        return None if abs(float(footprint[0] - footprint[1])) < ROUND else float(min(footprint))
    if lying:
        return float(min(footprint))
    top, bottom = float(high[2]), float(low[2])
    z = grasp_z if grasp_z is not None else bottom + 0.6 * (top - bottom)
    z = min(max(z, top - (finger_depth - PALM_MARGIN), bottom + FINGERTIP_LIFT), top - 0.004)
    slab = boxes[(boxes[:, 2] <= z + GRASP_SLAB) & (boxes[:, 5] >= z - GRASP_SLAB)]
    if not len(slab):
        slab = boxes
    return float(min(slab[:, 3:5].max(axis=0) - slab[:, 0:2].min(axis=0)))


def fits_gripper(width: float, max_opening: float) -> bool:
    """Whether an object ``width`` across fits the open gripper with its margin."""
    return width <= max_opening - GRIP_MARGIN
