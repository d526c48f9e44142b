"""``instrument_state`` and the per-stage language of ``sequence``, on hand-made episodes.

Step ``k`` (1-based) is ``verdicts[k - 1]``; control at 30 Hz.
"""

from __future__ import annotations

import pytest

from pipette_cli.errors import EvaluatorError
from pipette_cli.evaluators import make_evaluator
from pipette_cli.evaluators.base import MechanismState
from pipette_cli.evaluators.testing import ScriptedWorld, first_done, run
from pipette_cli.specs.evaluators import InstrumentStateSpec, SequenceSpec

SPUN = {
    "type": "instrument_state",
    "mechanism": "centrifuge",
    "values": {"run_time_s": {"min": 2}, "rotor.tube": {"min": 1}, "closed": {"min": 1}},
}


def centrifuge(closed: float, run_time_s: float, loaded: float) -> MechanismState:
    return MechanismState(values={"closed": closed, "run_time_s": run_time_s, "rotor.tube": loaded, "running": 0.0})


def world(state: MechanismState) -> ScriptedWorld:
    return ScriptedWorld(mechanisms={"centrifuge": state})


def test_instrument_state_needs_every_value_in_its_bound_at_once() -> None:
    w = world(centrifuge(1.0, 0.0, 1.0))
    evaluator = make_evaluator(InstrumentStateSpec.model_validate({**SPUN, "timeout_s": 3.0}))
    evaluator.reset(w)

    def spin(w: ScriptedWorld, k: int) -> None:
        w.mechanisms["centrifuge"] = centrifuge(1.0, k * w.control_dt, 1.0)

    verdicts = run(evaluator, w, 90, spin)
    assert first_done(verdicts) == 60 and verdicts[59].success  # 2 s of running at 30 Hz
    assert verdicts[58].metrics["run_time_s"] == pytest.approx(59 / 30)


def test_instrument_state_rejects_a_run_with_the_tube_out_of_the_rotor() -> None:
    """The hand-made failing episode: the centrifuge ran 5 s, closed, but the tube was never loaded."""
    w = world(centrifuge(1.0, 5.0, 0.0))
    evaluator = make_evaluator(InstrumentStateSpec.model_validate({**SPUN, "timeout_s": 1.0}))
    evaluator.reset(w)
    verdicts = run(evaluator, w, 40)
    assert first_done(verdicts) == 30 and verdicts[29].failed
    assert verdicts[29].reason == "rotor.tube_unmet"
    assert verdicts[29].metrics["bound_gap"] == pytest.approx(1.0)


def test_instrument_state_names_an_unknown_value() -> None:
    w = world(centrifuge(1.0, 0.0, 1.0))
    evaluator = make_evaluator(InstrumentStateSpec.model_validate({**SPUN, "values": {"rpm": {"min": 1}}}))
    evaluator.reset(w)
    with pytest.raises(EvaluatorError, match="no value 'rpm'"):
        run(evaluator, w, 1)


def test_each_stage_hands_out_its_own_instruction() -> None:
    w = world(centrifuge(0.0, 0.0, 0.0))
    spec = SequenceSpec.model_validate(
        {
            "of": [
                {
                    "type": "instrument_state",
                    "mechanism": "centrifuge",
                    "values": {"closed": {"min": 1}},
                    "instruction": "Close the lid.",
                },
                {**SPUN, "instruction": "Press start."},
            ]
        }
    )
    evaluator = make_evaluator(spec)
    evaluator.reset(w)
    assert (evaluator.stage, evaluator.stage_instruction()) == (0, "Close the lid.")

    def protocol(w: ScriptedWorld, k: int) -> None:
        w.mechanisms["centrifuge"] = centrifuge(float(k >= 5), max(0.0, (k - 10) * w.control_dt), 1.0)

    verdicts = run(evaluator, w, 100, protocol, stop_when_done=True)
    assert verdicts[5].metrics["stage"] == 1.0 and evaluator.stage_instruction() == "Press start."
    assert verdicts[-1].success and evaluator.stage == 2 and verdicts[-1].metrics["stages"] == 2.0


def test_start_before_the_lid_is_closed_does_not_count() -> None:
    """A run that started with the lid open (refused, never running) leaves the protocol at the
    'press start' stage even after the lid is closed."""
    w = world(centrifuge(0.0, 0.0, 1.0))
    spec = SequenceSpec.model_validate(
        {
            "timeout_s": 2.0,
            "of": [{"type": "instrument_state", "mechanism": "centrifuge", "values": {"closed": {"min": 1}}}, SPUN],
        }
    )
    evaluator = make_evaluator(spec)
    evaluator.reset(w)

    def wrong_order(w: ScriptedWorld, k: int) -> None:  # start pressed at step 3 while open: refused
        w.mechanisms["centrifuge"] = centrifuge(float(k >= 10), 0.0, 1.0)

    verdicts = run(evaluator, w, 70, wrong_order)
    assert verdicts[-1].failed and verdicts[-1].metrics["stage"] == 1.0
    assert verdicts[-1].reason == "run_time_s_unmet"
