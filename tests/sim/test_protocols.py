"""Protocol tasks end to end in MuJoCo: instrument state machines, stage order, per-stage language
and instrument values recorded per step and restored bit for bit."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from pipette_cli.augment.simulate import Rollout, replay_check
from pipette_cli.demos.check import run_expert_episode
from pipette_cli.demos.experts.base import find_expert
from pipette_cli.demos.recorder import SIM_STATE, DatasetInfo, EpisodeWriter, sim_state
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.registry import load_registry
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.sim.world import World
from pipette_cli.skills.program import ProgramExpert
from pipette_cli.specs.expert import CloseHingeSpec, PressSpec, WaitSpec
from pipette_cli.specs.task import stage_specs

REGISTRY = load_registry()
RUN = "protocols/SpinLoadedMicrocentrifuge-v1"  # tube loaded, lid open: close, start, wait for the run, open


def test_start_pressed_before_the_lid_is_closed_does_not_count() -> None:
    """The wrong order, done by the skills: press start while the lid is open, then close the lid."""
    world = World(REGISTRY.get(RUN))
    world.reset(0)
    expert = ProgramExpert(
        [
            PressSpec(button="centrifuge/start_button"),
            WaitSpec(seconds=0.5),
            CloseHingeSpec(joint="centrifuge/lid_hinge"),
            WaitSpec(seconds=1.0),
        ]
    )
    expert.reset(world, np.random.default_rng(0))
    refused_while_open = False
    while not (expert.done or expert.failure or world.verdict.done):
        world.step(expert.act(world))
        state = world.mechanism("centrifuge")
        refused_while_open |= state.value("refused") == 1.0 and state.value("closed") == 0.0
    assert expert.failure is None, expert.failure
    state = world.mechanism("centrifuge")
    assert refused_while_open and state.value("closed") == 1.0
    assert state.value("running") == 0.0 and state.value("runs") == 0.0 and state.value("run_time_s") == 0.0
    assert world.stage == 1 and not world.verdict.success  # stage 2 (press start) is still to do
    assert world.instruction() == "Press the start button."


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One scripted SpinLoadedMicrocentrifuge episode written by the real recorder (physics only)."""
    task = REGISTRY.get(RUN)
    env = PipetteEnv(task, render=False)
    path = tmp_path_factory.mktemp("protocol") / "episode_000000.h5"
    writer = EpisodeWriter(path, DatasetInfo.from_env(env), index=0, seed=3, source="scripted")
    obs = env.reset(3)
    _, expert = find_expert(task)
    expert.reset(env.world, np.random.default_rng([3, 1]))
    verdict = env.world.verdict
    while not verdict.done:
        action = expert.act(env.world)
        writer.add(obs, action, sim_state(env.world.model, env.world.data))
        obs, verdict = env.step(action)
    writer.close(verdict, env.world.state(), sim_state(env.world.model, env.world.data))
    writer.commit()
    env.close()
    return path


def test_each_step_records_its_stage_instruction_stage_and_instrument_values(recorded: Path) -> None:
    task = REGISTRY.get(RUN)
    record = read_episode(scan(recorded).episode(0))
    assert record.summary.success
    a = record.arrays
    stages = a["stage"]
    assert stages[0] == 0 and np.all(np.diff(stages) >= 0) and stages[-1] == len(stage_specs(task)) - 1
    texts = [t.decode() for t in a["instruction"]]
    expected = [stage.instruction for stage in stage_specs(task)]
    assert [texts[int(np.argmax(stages == k))] for k in range(len(expected))] == expected  # each stage's own words
    world = World(task)
    names = list(world.instrument_names)
    assert a["instrument_state"].shape == (len(stages), len(names))
    running = a["instrument_state"][:, names.index("centrifuge.running")]
    assert running.max() == 1.0 and running[0] == 0.0


def test_instrument_state_survives_restore_and_replay_bit_exactly(recorded: Path) -> None:
    record = read_episode(scan(recorded).episode(0))
    world = World(REGISTRY.get(RUN))
    world.reset(record.summary.seed)
    rows = record.arrays["instrument_state"]
    for k in np.linspace(0, len(rows) - 1, 12).astype(int):  # across every stage
        mujoco.mj_setState(world.model, world.data, record.arrays["sim_state"][k], SIM_STATE)
        mujoco.mj_forward(world.model, world.data)
        assert world.instrument_state().tobytes() == rows[k].tobytes(), k
    assert replay_check(world, record.summary.seed, Rollout.from_record(record)) is None


def test_a_scripted_protocol_completes_every_stage() -> None:
    world = World(REGISTRY.get("protocols/SpinMicrotube-v1"))
    verdict, failure = run_expert_episode(world, 0)
    assert failure is None and verdict.success
    assert world.stage == 4 and verdict.metrics["stages"] == 4.0


def test_the_second_tube_is_taken_out_of_the_rack_and_the_rotor_balanced() -> None:
    """Seed 5 of BalancedSpin: coming from the rotor, the arm sagged 4.4 mm under its grasp of the
    second tube, its open fingertips hung below the top of the rack's grid, over the tube's hole, and
    closing they ran into the grid bars (the grasp closed on nothing). Fingertips sunk beside what
    they close over, touching nothing, are raised to the planned height before they close."""
    world = World(REGISTRY.get("protocols/BalancedSpin-v1"))
    verdict, failure = run_expert_episode(world, 5)
    assert failure is None, failure
    assert verdict.success, verdict
    state = world.mechanism("centrifuge")
    assert state.values["opposite.tube_b"] == 1 and state.values["rotor_loaded"] == 2


INSTRUMENT_RUNS = [
    # (protocol, instrument, the values it must take in this order, values at the end)
    (
        "protocols/RunThermalCycler-v1",
        "cycler",
        [("lid_closed", 1), ("running", 1), ("runs", 1), ("lid_closed", 0)],
        {"block_loaded.tube": 1, "refused": 0},
    ),
    (
        "protocols/ReadPlate-v1",
        "reader",
        [("drawer_closed", 1), ("running", 1), ("runs", 1), ("drawer_closed", 0)],
        {"carrier.plate": 1, "refused": 0},
    ),
    (
        "protocols/ReadCuvette-v1",
        "spectro",
        [("lid_closed", 1), ("running", 1), ("runs", 1)],
        {"holder.cuvette": 1, "aborted": 0},
    ),
    (
        "protocols/SpinLoadedBenchtopCentrifuge-v1",
        "centrifuge",
        [("closed", 1), ("running", 1), ("runs", 1), ("closed", 0)],
        {"rotor_loaded": 2, "aborted": 0},
    ),
    ("protocols/VortexConicalTube-v1", "vortex", [("running", 1), ("runs", 1), ("running", 0)], {"runs": 1}),
]


@pytest.mark.parametrize(
    ("task_id", "instrument", "order", "end"), INSTRUMENT_RUNS, ids=[r[0] for r in INSTRUMENT_RUNS]
)
def test_an_instrument_run_goes_through_its_states_in_order(
    task_id: str, instrument: str, order: list[tuple[str, float]], end: dict[str, float]
) -> None:
    """The skill program works the instrument's state machine: each value is reached after the one
    before it (the lid shut before the run starts, the run over before the lid opens), and the
    instrument ends with what it holds still in place."""
    world = World(REGISTRY.get(task_id))
    world.reset(0)
    expert = find_expert(world.task)[1]
    expert.reset(world, np.random.default_rng([0, 1]))
    reached = 0
    while not world.verdict.done:
        world.step(expert.act(world))
        state = world.mechanism(instrument)
        if reached < len(order) and state.value(order[reached][0]) == order[reached][1]:
            reached += 1
    assert expert.failure is None, expert.failure
    assert reached == len(order), f"stopped before {order[reached]}"
    assert world.verdict.success and world.stage == len(stage_specs(world.task)), world.verdict
    state = world.mechanism(instrument)
    assert {key: state.value(key) for key in end} == end
