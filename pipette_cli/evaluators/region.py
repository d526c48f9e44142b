"""``region_hold`` and ``stable_placement``: an object rests inside a region (paper A.8).

The region is the intersection of per-axis bounds on the object's position (closed
intervals, see :class:`~pipette_cli.specs.base.BoundSpec`) and an optional horizontal disc.
The disc's centre is ``state.position(within.center)`` read on every update (so a moving
platform is followed); its radius is ``within.radius``, or ``radius_scale`` times half the
shorter side of ``state.bbox_xy(within.radius_from_bbox)`` read once at reset.

``stable_placement`` adds rest: ``|z_t - z_{t-1}| <= max_dz_per_step`` between consecutive
updates (the first update compares with the height at reset).

Unmet reasons (reported at the timeout): ``"out_of_region"`` (outside the x/y bounds or the
disc), else ``"too_low"`` / ``"too_high"`` (only the z bound), else ``"unstable"``
(stable_placement moving). ``max_tilt_deg`` fails at once with ``"tilted"``. With ``released``, the
region counts only while the robot touches the object nowhere (``"held"``): an object carried
through the region, or held where it goes, is not yet placed; nor is one carried tilted (a lid
by its handle) fallen: the tilt fails only once the robot has let go.
"""

from __future__ import annotations

import numpy as np

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, bound_gap, position, tilt_deg, up_axis
from pipette_cli.specs.evaluators import RegionHoldSpec, StablePlacementSpec

AXES = ("x", "y", "z")


def disc_radius(spec: RegionHoldSpec, state: WorldState) -> float:
    """Radius of the spec's ``within`` disc: given, or scale x half the bbox's shorter side."""
    within = spec.within
    assert within is not None
    if within.radius is not None:
        return within.radius
    assert within.radius_from_bbox is not None
    dx, dy = state.bbox_xy(within.radius_from_bbox)
    return within.radius_scale * 0.5 * min(float(dx), float(dy))


@register("region_hold")
class RegionHold(ConditionEvaluator[RegionHoldSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.RegionHoldSpec`.

    Reads ``state.position(object)`` every update, ``state.rotation(object)`` when a tilt
    limit is set, and for a disc ``state.position(within.center)`` every update and
    ``state.bbox_xy(within.radius_from_bbox)`` at reset.

    Metrics: ``x``, ``y``, ``z`` (m); ``out_x``/``out_y``/``out_z`` (m outside each bound,
    0 inside) for bounded axes; ``xy_error`` (m from the disc centre) and ``radius`` with a
    disc; ``tilt_deg`` with a tilt limit; ``hold_s``.
    """

    spec_type = RegionHoldSpec

    _rest_up: np.ndarray | None = None

    def prime(self, state: WorldState) -> None:
        # upright is how the object stood at the episode's start, not as a stage before left it
        # (a lid still hanging tilted from the hand that lifted it off)
        self._rest_up = up_axis(state.rotation(self.spec.object)) if self.spec.max_tilt_deg is not None else None

    def start(self, state: WorldState) -> None:
        spec = self.spec
        self._radius = disc_radius(spec, state) if spec.within is not None else 0.0
        self._up0 = None
        if spec.max_tilt_deg is not None:
            self._up0 = self._rest_up if self._rest_up is not None else up_axis(state.rotation(spec.object))

    def check(self, state: WorldState) -> Check:
        spec = self.spec
        pos = position(state, spec.object)
        metrics = dict(zip(AXES, map(float, pos), strict=True))
        if self._up0 is not None:
            metrics["tilt_deg"] = tilt_deg(self._up0, state.rotation(spec.object))
        for i, axis in enumerate(AXES):
            bound = getattr(spec, axis)
            if bound is not None:
                metrics[f"out_{axis}"] = bound_gap(bound, float(pos[i]))
        if spec.within is not None:
            center = position(state, spec.within.center)
            metrics["xy_error"] = float(np.linalg.norm(pos[:2] - center[:2]))
            metrics["radius"] = self._radius
        held = spec.released and state.robot_touches(spec.object)
        if spec.max_tilt_deg is not None and metrics["tilt_deg"] > spec.max_tilt_deg:
            if held:  # carried tilted (a lid by its handle): not yet placed, not yet fallen
                return Check(False, metrics, unmet="held")
            return Check(False, metrics, fail="tilted")
        unmet = self._region_unmet(pos, metrics)
        if unmet is None and held:
            unmet = "held"
        return Check(unmet is None, metrics, unmet=unmet)

    def _region_unmet(self, pos: np.ndarray, metrics: dict[str, float]) -> str | None:
        spec = self.spec
        horizontal_ok = all(metrics.get(f"out_{axis}", 0.0) == 0.0 for axis in ("x", "y"))
        if spec.within is not None and metrics["xy_error"] > self._radius:
            horizontal_ok = False
        if not horizontal_ok:
            return "out_of_region"
        if spec.z is not None and not spec.z.contains(float(pos[2])):
            return "too_low" if spec.z.min is not None and pos[2] < spec.z.min else "too_high"
        return None


@register("stable_placement")
class StablePlacement(RegionHold):
    """Runtime of :class:`~pipette_cli.specs.evaluators.StablePlacementSpec`.

    Metrics: those of :class:`RegionHold` plus ``dz`` = ``|z_t - z_{t-1}|`` (m).
    """

    spec_type = StablePlacementSpec
    spec: StablePlacementSpec

    def start(self, state: WorldState) -> None:
        super().start(state)
        self._prev_z = float(position(state, self.spec.object)[2])

    def check(self, state: WorldState) -> Check:
        check = super().check(state)
        z = check.metrics["z"]
        dz = abs(z - self._prev_z)
        self._prev_z = z
        metrics = {**check.metrics, "dz": dz}
        if check.fail is not None or not check.ok:
            return Check(False, metrics, unmet=check.unmet, fail=check.fail)
        steady = dz <= self.spec.max_dz_per_step
        return Check(steady, metrics, unmet=None if steady else "unstable")
