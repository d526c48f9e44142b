"""``displacement``: an object moved from its start by given per-axis amounts (paper A.8).

Condition: every bounded axis of ``position_t - position_0`` lies in its bound (closed
intervals), held ``hold_s``. ``max_tilt_deg`` fails at once with ``"tilted"``. Unmet reason:
``"not_displaced"``.

Paper examples: water bath lid ``x_0 - x_t > 0.30`` and ``z_t - z_0 > 0.10`` is
``delta: {x: {max: -0.30}, z: {min: 0.10}}``; tube off the balance ``y_t - y_0 > 0.25`` and
``z_0 - z_t > 0.12`` is ``delta: {y: {min: 0.25}, z: {max: -0.12}}``.
"""

from __future__ import annotations

import numpy as np

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, bound_gap, position, tilt_deg, up_axis
from pipette_cli.specs.evaluators import DisplacementSpec

AXES = ("x", "y", "z")


@register("displacement")
class Displacement(ConditionEvaluator[DisplacementSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.DisplacementSpec`.

    Reads ``state.position(object)`` every update and ``state.rotation(object)`` when a tilt
    limit is set.

    Metrics: ``dx``, ``dy``, ``dz`` (m from the start), ``bound_gap`` (sum over bounded axes of
    how far each lies outside its bound, 0 when all inside), ``tilt_deg`` with a tilt limit,
    ``hold_s``.
    """

    spec_type = DisplacementSpec

    def start(self, state: WorldState) -> None:
        self._p0 = position(state, self.spec.object)
        self._up0 = up_axis(state.rotation(self.spec.object)) if self.spec.max_tilt_deg is not None else None

    def check(self, state: WorldState) -> Check:
        spec = self.spec
        delta: np.ndarray = position(state, spec.object) - self._p0
        metrics = {f"d{axis}": float(delta[i]) for i, axis in enumerate(AXES)}
        gap = 0.0
        for i, axis in enumerate(AXES):
            bound = getattr(spec.delta, axis)
            if bound is not None:
                gap += bound_gap(bound, float(delta[i]))
        metrics["bound_gap"] = gap
        inside = all(
            getattr(spec.delta, axis) is None or getattr(spec.delta, axis).contains(float(delta[i]))
            for i, axis in enumerate(AXES)
        )
        if self._up0 is not None:
            metrics["tilt_deg"] = tilt_deg(self._up0, state.rotation(spec.object))
            if spec.max_tilt_deg is not None and metrics["tilt_deg"] > spec.max_tilt_deg:
                return Check(False, metrics, fail="tilted")
        return Check(inside, metrics, unmet=None if inside else "not_displaced")
