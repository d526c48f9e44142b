"""``joint_threshold``: an articulated joint (a lid hinge, a drawer slide) inside a bound.

Condition: ``bound.contains(state.joint(joint))`` (closed interval), held ``hold_s``. The
value is in the world state's units: degrees for hinges, metres for slides; the spec's
``unit`` names which one the bound is written in. Unmet reason: ``"not_reached"``.
"""

from __future__ import annotations

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, bound_gap
from pipette_cli.specs.evaluators import JointThresholdSpec


@register("joint_threshold")
class JointThreshold(ConditionEvaluator[JointThresholdSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.JointThresholdSpec`.

    Reads ``state.joint(joint)`` every update.

    Metrics: ``joint_deg`` or ``joint_m`` (after the spec's unit), ``joint_start_deg`` /
    ``joint_start_m`` (at reset), ``bound_gap`` (how far outside the bound, 0 inside),
    ``hold_s``.
    """

    spec_type = JointThresholdSpec

    def start(self, state: WorldState) -> None:
        self._start = float(state.joint(self.spec.joint))

    def check(self, state: WorldState) -> Check:
        spec = self.spec
        value = float(state.joint(spec.joint))
        metrics = {
            f"joint_{spec.unit}": value,
            f"joint_start_{spec.unit}": self._start,
            "bound_gap": bound_gap(spec.bound, value),
        }
        inside = spec.bound.contains(value)
        return Check(inside, metrics, unmet=None if inside else "not_reached")
