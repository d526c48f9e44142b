"""``instrument_state``: values an instrument reports lie in their bounds, all at once.

Condition: for every ``name: bound`` of the spec, ``bound.contains(state.mechanism(mechanism).value(name))``
(closed intervals; flags such as ``closed`` or ``running`` are 1 or 0), held ``hold_s``. Unmet
reason: ``"<name>_unmet"`` for the first value (in spec order) outside its bound, e.g.
``"run_time_s_unmet"`` for a centrifuge that has not run long enough.
"""

from __future__ import annotations

from pipette_cli.evaluators.base import WorldState, register
from pipette_cli.evaluators.condition import Check, ConditionEvaluator, bound_gap
from pipette_cli.specs.evaluators import InstrumentStateSpec


@register("instrument_state")
class InstrumentState(ConditionEvaluator[InstrumentStateSpec]):
    """Runtime of :class:`~pipette_cli.specs.evaluators.InstrumentStateSpec`.

    Reads ``state.mechanism(mechanism)`` every update.

    Metrics: each named value, ``bound_gap`` (summed distance of the values outside their bounds,
    0 when all are inside), ``hold_s``.
    """

    spec_type = InstrumentStateSpec

    def start(self, state: WorldState) -> None:
        """Nothing to record: the instrument keeps its own clocks and counters."""

    def check(self, state: WorldState) -> Check:
        reading = state.mechanism(self.spec.mechanism)
        metrics: dict[str, float] = {}
        gap = 0.0
        unmet = None
        for name, bound in self.spec.values.items():
            value = reading.value(name)
            metrics[name] = value
            gap += bound_gap(bound, value)
            if unmet is None and not bound.contains(value):
                unmet = f"{name}_unmet"
        metrics["bound_gap"] = gap
        return Check(unmet is None, metrics, unmet=unmet)
