"""Does an object fit where a step puts it?

:func:`fit_radius` sizes the disc an object's origin must end in on a surface or in a receptacle
(and refuses an object that is larger or heavier than the destination takes); :func:`check_hole_fit`
refuses an object too wide for a rack's holes, naming the holders it does fit.
"""

from __future__ import annotations

from pipette_cli.language.assets import Vocabulary
from pipette_cli.taskgen.measure import AssetGeometry, r
from pipette_cli.taskgen.plan import PlanError
from pipette_cli.taskgen.resolve import diameter, fits, holders_that_fit, hole

RECEPTACLES = ("cuvette_slot", "rotor_center", "cup_center", "block_center", "drawer_center")
"""Sites that hold an object with a little play (its radius may exceed the bare room by 1.5 mm)."""
SURFACE_SIZE = {
    "pan_center": "pan_size",
    "platform_center": "platform_size",
    "plate_center": "plate_size",
    "shelf_0_center": "shelf_size",
    "shelf_1_center": "shelf_size",
    "top_center": "top_size",
    "center": "inner_size",
    "drawer_center": "plate_pocket",
    "block_center": "block_size",
    "cuvette_slot": "cuvette_size",
}
"""Site -> the semantics key with the (x, y) size of the surface or receptacle at it."""


def fit_radius(igeom: AssetGeometry, dgeom: AssetGeometry, site: str, *, item: str, dest: str) -> float:
    """Radius of the disc the item's origin must end in on ``dgeom``'s ``site``.

    Args:
        igeom: The object put there.
        dgeom: Where it goes.
        site: The site of ``dgeom`` it goes on or into (``opening``: dropped in).
        item: The object's human name, for messages.
        dest: The destination's human name, for messages.

    Raises:
        PlanError: the object does not fit, or weighs more than the destination's capacity.
    """
    sem = dgeom.semantics
    size_key = SURFACE_SIZE.get(site) if site != "center" or "inner_size" in sem else None
    size = sem.get(size_key) if size_key else None
    if site == "inside_bottom":
        size = [sem.get("outer_diameter", 0.05) - 0.004] * 2
    if size is None:
        hx, hy = dgeom.half_xy
        size = [2 * hx, 2 * hy]
    half = 0.5 * min(float(size[0]), float(size[1]))
    extent = sorted(float(v) for v in (igeom.high[:2] - igeom.low[:2]))
    room_axes = sorted(float(v) for v in size[:2])
    if site == "opening":
        room = half - 0.5 * extent[1]
    elif site in RECEPTACLES:
        room = min(0.5 * (a - e) for a, e in zip(room_axes, extent, strict=True)) + 0.0015  # a slot holds it with play
    else:
        room = min(0.5 * (a - e) for a, e in zip(room_axes, extent, strict=True))
    if room < 0.0:
        raise PlanError(
            f"impossible request: the {item} ({extent[1] * 1000:.0f} x {extent[0] * 1000:.0f} mm) "
            f"does not fit the {dest}'s {site.replace('_', ' ')} "
            f"({room_axes[1] * 1000:.0f} x {room_axes[0] * 1000:.0f} mm); choose a smaller object or a larger one to put it on"
        )
    capacity = sem.get("capacity_kg")
    mass = float(igeom.semantics.get("mass", 0.0))
    if capacity is not None and mass > float(capacity):
        raise PlanError(
            f"impossible request: the {item} weighs {mass:.2f} kg, over the {capacity} kg capacity of the {dest}"
        )
    low = 0.01 if site in RECEPTACLES else 0.005
    if site.startswith("shelf_"):  # anywhere on a shelf is in the instrument (place_on sets an object down
        return r(max(low, room), 4)  # at the front of a deep shelf where the arm cannot reach in further)
    return r(max(low, min(0.5 * half, room)), 4)


def check_hole_fit(vocab: Vocabulary, item_asset: str, holder_asset: str, *, item: str, dest: str) -> None:
    """Refuse putting ``item_asset`` into the holes of ``holder_asset`` when it is too wide.

    Args:
        vocab: The asset vocabulary (diameters and hole sizes).
        item_asset: The object's asset id.
        holder_asset: The rack's asset id.
        item: The object's human name, for messages.
        dest: The rack's human name, for messages.

    Raises:
        PlanError: the object is wider than the holes (with the holders that fit it).
    """
    if fits(vocab, item_asset, holder_asset) is not False:
        return
    d, h = diameter(vocab, item_asset), hole(vocab, holder_asset)
    if d is None or h is None:  # fits() is False only when both are known
        raise PlanError(f"the {item} or the holes of the {dest} have no diameter in the asset library")
    holders = holders_that_fit(vocab, item_asset)
    hint = f"; holders that fit: {', '.join(holders)}" if holders else ""
    raise PlanError(
        f"impossible request: the {item} is {d * 1000:.1f} mm wide, the holes of the {dest} are {h * 1000:.1f} mm{hint}"
    )
