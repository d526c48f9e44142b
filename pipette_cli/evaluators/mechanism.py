"""``mechanism_triggered``: a scripted scene mechanism has fired and driven its joint far
enough (paper A.6, centrifuge lid release button).

Condition: ``state.mechanism(name).triggered`` and ``target.contains(min_target)``, where
``min_target`` is the lowest target the mechanism has commanded since reset (closed
interval). There is no hold. Unmet reasons: ``"not_triggered"``, else ``"not_reached"``.
"""

from __future__ import annotations

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, bound_gap
from pipette_cli.specs.evaluators import MechanismTriggeredSpec


@register("mechanism_triggered")
class MechanismTriggered(ConditionEvaluator[MechanismTriggeredSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.MechanismTriggeredSpec`.

    Reads ``state.mechanism(mechanism)`` every update.

    Metrics: ``triggered`` (1 or 0), ``target`` and ``min_target`` (the spec's unit),
    ``bound_gap`` (how far ``min_target`` lies outside the bound, 0 inside), ``hold_s``.
    """

    spec_type = MechanismTriggeredSpec

    def start(self, state: WorldState) -> None:
        """Nothing to record: the mechanism keeps its own minimum since reset."""

    def check(self, state: WorldState) -> Check:
        spec = self.spec
        mech = state.mechanism(spec.mechanism)
        metrics = {
            "triggered": 1.0 if mech.triggered else 0.0,
            "target": float(mech.target),
            "min_target": float(mech.min_target),
            "bound_gap": bound_gap(spec.target, float(mech.min_target)),
        }
        reached = spec.target.contains(float(mech.min_target))
        if not mech.triggered:
            return Check(False, metrics, unmet="not_triggered")
        return Check(reached, metrics, unmet=None if reached else "not_reached")
