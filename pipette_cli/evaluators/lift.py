"""``lift_and_hold``: raise an object above its start and keep it there (paper A.8, test tube).

Condition: ``z_t - z_0 > min_height_gain``, held ``hold_s``. Tilt ``arccos(u_t . u_0)``
(``u`` = the object's local z axis in world) above ``max_tilt_deg`` fails at once with
``"tilted"``.

Dropping is deliberately *not* an early failure: paper A.8 fails this task only on tilt and
on the timeout, and a re-grasp within the time limit still succeeds. A dropped tube
almost always falls over, which the tilt limit catches at once. Dropping shows in the
timeout reason instead: ``"dropped"`` when the gain had exceeded the threshold at some
step, ``"not_lifted"`` when it never did, ``"timeout"`` when it is up but the hold was cut
short.
"""

from __future__ import annotations

import numpy as np

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, position, tilt_deg, up_axis
from pipette_cli.specs.evaluators import LiftAndHoldSpec


@register("lift_and_hold")
class LiftAndHold(ConditionEvaluator[LiftAndHoldSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.LiftAndHoldSpec`.

    Reads ``state.position(object)`` and ``state.rotation(object)`` every update.

    Metrics: ``height_gain`` (m), ``max_height_gain`` (m, since reset), ``tilt_deg``,
    ``hold_s``.
    """

    spec_type = LiftAndHoldSpec

    def start(self, state: WorldState) -> None:
        self._z0 = float(position(state, self.spec.object)[2])
        self._up0: np.ndarray = up_axis(state.rotation(self.spec.object))
        self._max_gain = -np.inf
        self._was_lifted = False

    def check(self, state: WorldState) -> Check:
        spec = self.spec
        gain = float(position(state, spec.object)[2]) - self._z0
        tilt = tilt_deg(self._up0, state.rotation(spec.object))
        self._max_gain = max(self._max_gain, gain)
        metrics = {"height_gain": gain, "max_height_gain": self._max_gain, "tilt_deg": tilt}
        if spec.max_tilt_deg is not None and tilt > spec.max_tilt_deg:
            return Check(False, metrics, fail="tilted")
        lifted = gain > spec.min_height_gain
        unmet = None if lifted else ("dropped" if self._was_lifted else "not_lifted")
        self._was_lifted = self._was_lifted or lifted
        return Check(lifted, metrics, unmet=unmet)
