"""``near_target``: a point on an object comes horizontally close to a target, carried high
enough (paper A.8, pipette over the petri dish).

Condition: ``d_xy = ||p_object^xy - p_target^xy|| <= max_xy_distance`` and, when ``min_z``
is set, ``z_object >= min_z``; held ``hold_s`` (default 0: the first such step succeeds).
The target's position is read on every update, so a moving target is followed.

Unmet reasons (reported at the timeout): ``"too_low"`` when the object was, at any update
since reset, within the distance but below ``min_z`` (the paper's "insufficient height"
failure), else ``"out_of_region"``.
"""

from __future__ import annotations

import numpy as np

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, position
from pipette_cli.specs.evaluators import NearTargetSpec


@register("near_target")
class NearTarget(ConditionEvaluator[NearTargetSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.NearTargetSpec`.

    Reads ``state.position(object)`` and ``state.position(target)`` every update.

    Metrics: ``xy_distance`` (m), ``z`` (m, the object's height), ``min_xy_distance`` (m,
    closest since reset), ``hold_s``.
    """

    spec_type = NearTargetSpec

    def start(self, state: WorldState) -> None:
        self._closest = np.inf
        self._was_near_low = False

    def check(self, state: WorldState) -> Check:
        spec = self.spec
        pos = position(state, spec.object)
        target = position(state, spec.target)
        distance = float(np.linalg.norm(pos[:2] - target[:2]))
        self._closest = min(self._closest, distance)
        metrics = {"xy_distance": distance, "z": float(pos[2]), "min_xy_distance": self._closest}
        near = distance <= spec.max_xy_distance
        high = spec.min_z is None or pos[2] >= spec.min_z
        if near and not high:
            self._was_near_low = True
        ok = near and high
        unmet = None if ok else ("too_low" if self._was_near_low else "out_of_region")
        return Check(ok, metrics, unmet=unmet)
