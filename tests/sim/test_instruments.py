"""Instrument state machines beyond the centrifuge and balance, driven by the skills in MuJoCo: a
thermal cycler and a plate reader run only when closed, an incubator reports its door and shelves,
a vortex mixer runs while its cup is pressed (fixtures in tests/fixtures/protocols)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from pydantic import ValidationError

from pipette_cli.registry import load_registry
from pipette_cli.sim.world import World
from pipette_cli.skills.program import ProgramExpert
from pipette_cli.specs.expert import PressSpec, WaitSpec
from pipette_cli.specs.mechanisms import InstrumentSpec

FIXTURES = load_registry([Path(__file__).parents[1] / "fixtures" / "protocols"])


def _run(world: World, steps: list, seed: int = 0) -> dict[str, float]:
    """Run a skill program to its end; returns the values the instrument reports then."""
    expert = ProgramExpert(steps)
    expert.reset(world, np.random.default_rng(seed))
    name = next(iter(world.task.scene.mechanisms)).name
    while not (expert.done or expert.failure):
        world.step(expert.act(world))
    assert expert.failure is None, expert.failure
    return dict(world.mechanism(name).values)


@pytest.mark.parametrize(
    ("task", "closure", "closed_name"),
    [
        ("instruments/CyclerRun-v1", "cycler/lid_button", "lid_closed"),
        ("instruments/ReaderRun-v1", "reader/drawer_button", "drawer_closed"),
    ],
)
def test_start_is_refused_while_open_and_runs_once_closed(task: str, closure: str, closed_name: str) -> None:
    owner = closure.split("/")[0]
    world = World(FIXTURES.get(task))
    world.reset(0)
    assert world.mechanism(owner).value(closed_name) == 1.0  # shut at reset
    # open it with its button, then press start: refused, nothing runs
    opened = _run(world, [PressSpec(button=closure), WaitSpec(seconds=1.2), PressSpec(button=f"{owner}/start_button")])
    assert opened[closed_name] == 0.0
    assert opened["refused"] == 1.0 and opened["running"] == 0.0 and opened["runs"] == 0.0

    world.reset(0)
    shut = _run(
        world,
        [
            PressSpec(button=closure),
            WaitSpec(seconds=1.2),
            PressSpec(button=closure),  # the motor drives it back shut
            WaitSpec(seconds=1.2),
            PressSpec(button=f"{owner}/start_button"),
            WaitSpec(seconds=1.0),
        ],
    )
    assert shut[closed_name] == 1.0 and shut["refused"] == 0.0
    assert shut["running"] == 1.0 and shut["run_time_s"] > 0.5


def test_a_full_run_completes_with_the_lid_shut() -> None:
    world = World(FIXTURES.get("instruments/CyclerRun-v1"))
    world.reset(1)
    values = _run(world, list(world.task.expert), seed=1)
    assert values["runs"] == 1.0 and values["running"] == 0.0 and values["run_time_s"] >= 3.0
    assert world.verdict.success


def test_incubator_reports_its_door_and_what_stands_on_each_shelf() -> None:
    world = World(FIXTURES.get("instruments/IncubatorShelves-v1"))
    world.reset(0)
    before = world.mechanism("incubator")
    assert before.value("door_closed") == 0.0  # the task opens it to 105 degrees
    assert before.value("shelf_0") == 0.0 and before.value("shelf_0.dish") == 0.0
    expert = ProgramExpert(world.task.expert)
    expert.reset(world, np.random.default_rng(0))
    while not world.verdict.done:
        world.step(expert.act(world))
    assert world.verdict.success, world.verdict.reason
    after = world.mechanism("incubator")
    assert after.value("shelf_0") == 1.0 and after.value("shelf_0.dish") == 1.0
    assert after.value("shelf_1") == 0.0 and after.value("shelf_1.dish") == 0.0
    # the door shut by hand (its joint set closed): reported closed, the dish still on its shelf
    world.data.qpos[world.model.jnt_qposadr[world.joint_id("incubator/door_hinge")]] = 0.0
    mujoco.mj_forward(world.model, world.data)
    shut = world.mechanism("incubator")
    assert shut.value("door_closed") == 1.0 and shut.value("shelf_0.dish") == 1.0


def _move_body(world: World, body: str, pos: tuple[float, float, float]) -> None:
    """Put free object ``body`` at ``pos`` (its orientation kept)."""
    adr = world.model.jnt_qposadr[world.model.body_jntadr[world.body_id(body)]]
    world.data.qpos[adr : adr + 3] = pos
    world.data.qvel[world.model.jnt_dofadr[world.model.body_jntadr[world.body_id(body)]] :][:6] = 0.0
    mujoco.mj_forward(world.model, world.data)


def test_vortex_runs_while_its_cup_is_pressed_and_counts_a_press_held_long_enough() -> None:
    world = World(FIXTURES.get("instruments/VortexTouch-v1"))
    world.reset(0)
    short = _run(world, [WaitSpec(seconds=1.0)])  # the bottle's 2.9 N on the cup: running, no run yet
    assert short["running"] == 1.0 and 0.8 < short["run_time_s"] < 1.2 and short["runs"] == 0.0
    held = _run(world, [WaitSpec(seconds=1.5)])
    assert held["running"] == 1.0 and held["runs"] == 1.0 and held["run_time_s"] >= 2.0
    longer = _run(world, [WaitSpec(seconds=1.0)])  # one press is one run, however long it is held
    assert longer["runs"] == 1.0
    _move_body(world, "bottle", (0.35, 0.25, 0.56))  # lifted off: it stops
    off = _run(world, [WaitSpec(seconds=0.5)])
    assert off["running"] == 0.0 and off["runs"] == 1.0


def test_vortex_does_not_run_under_a_light_touch() -> None:
    world = World(FIXTURES.get("instruments/VortexTouch-v1"))
    world.reset(0)
    _move_body(world, "bottle", (0.35, 0.25, 0.56))
    _move_body(world, "tube", (0.5, 0.2, 0.64))  # a 1.1 g tube dropped into the cup: 0.01 N
    values = _run(world, [WaitSpec(seconds=2.5)])
    assert values["running"] == 0.0 and values["runs"] == 0.0
    assert not world.verdict.success


def test_an_instrument_has_a_start_button_or_a_touch_head_not_both() -> None:
    touch = {"head": "vortex/head"}
    assert InstrumentSpec(name="vortex", touch=touch).touch is not None
    with pytest.raises(ValidationError, match="'run'.*'touch'.*not both"):
        InstrumentSpec(name="vortex", touch=touch, run={"button": "vortex/start_button"})
