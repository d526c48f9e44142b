"""Re-execute a recorded episode and compare it with the recording, bit for bit.

``World.reset(seed)`` restores what the seed changed in the model (static instruments move
through ``model.body_pos``) and resets mechanisms and evaluator; ``mj_setState`` then loads the
recorded step-0 simulator state; the recorded actions are applied one control step at a time
and after each step the simulator state is compared byte for byte with the next recorded one
(the last with ``final_sim_state``), and at the end the verdict with the recorded one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from pipette_cli.demos.provenance import code_change, task_spec_sha256
from pipette_cli.demos.recorder import SIM_STATE, STOPPED, TRUNCATED, sim_state
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.errors import DatasetError
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.distractors import distractors_from_attrs, with_distractors
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.specs.task import TaskSpec


@dataclass
class ReplayReport:
    """Outcome of :func:`replay_episode`."""

    episode: int
    seed: int
    steps: int
    states_compared: int = 0
    first_mismatch: int | None = None
    """Index of the first recorded state the replay did not reproduce (``steps`` = the final state)."""
    max_abs_diff: float = 0.0
    recorded: dict[str, object] = field(default_factory=dict)
    replayed: dict[str, object] = field(default_factory=dict)
    spec_changed: bool = False
    code_changed: str | None = None
    """``recorded by X, replayed by Y`` when other code recorded the episode (:func:`.provenance.code_change`)."""

    @property
    def states_equal(self) -> bool:
        return self.first_mismatch is None

    @property
    def outcome_equal(self) -> bool:
        return self.recorded == self.replayed

    @property
    def ok(self) -> bool:
        return self.states_equal and self.outcome_equal

    def as_dict(self) -> dict[str, object]:
        return {
            "episode": self.episode,
            "seed": self.seed,
            "steps": self.steps,
            "states_compared": self.states_compared,
            "states_equal": self.states_equal,
            "first_mismatch": self.first_mismatch,
            "max_abs_diff": self.max_abs_diff,
            "outcome_equal": self.outcome_equal,
            "recorded": self.recorded,
            "replayed": self.replayed,
            "spec_changed": self.spec_changed,
            "code_changed": self.code_changed,
            "ok": self.ok,
        }


def _outcome(verdict: Verdict, undecided: str) -> dict[str, object]:
    return {
        "success": bool(verdict.success),
        "reason": (verdict.reason or "") if verdict.done else undecided,
        "metrics": {k: float(v) for k, v in verdict.metrics.items()},
    }


def _bits_equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def replay_episode(path: Path, index: int, task: TaskSpec) -> ReplayReport:
    """Replay episode ``index`` of ``path`` (physics only, no rendering) against ``task``.

    Raises:
        DatasetError: the file is unreadable, the index out of range, or the episode was
            recorded for another task or a model with another state size.
    """
    status = scan(Path(path))
    ref = status.episode(index)
    assert status.info is not None
    if status.info.task_id != task.id:
        raise DatasetError(f"{path} holds episodes of task {status.info.task_id}, not {task.id}")
    if status.info.embodiment != task.embodiment.robot:
        raise DatasetError(
            f"{path} was recorded on the {status.info.embodiment}, not the {task.embodiment.robot}; "
            "replay it on the task placed on that robot (pipette_cli.demos.embodiment.on_robot)"
        )
    record = read_episode(ref)
    states = record.arrays["sim_state"]
    actions = record.arrays.get("executed_action", record.arrays["action"])  # what ran (corrective noise records other)
    report = ReplayReport(index, ref.summary.seed, len(actions))
    report.spec_changed = record.attrs.get("task_spec_sha256") != task_spec_sha256(task)
    report.code_changed = code_change(record.attrs)
    reason = ref.summary.reason
    report.recorded = {"success": ref.summary.success, "reason": reason, "metrics": ref.summary.metrics}
    undecided = reason if reason in (TRUNCATED, STOPPED) else TRUNCATED
    env = PipetteEnv(with_distractors(task, distractors_from_attrs(record.attrs)), render=False)  # its own scene
    try:
        world = env.world
        size = mujoco.mj_stateSize(world.model, SIM_STATE)
        if states.shape[1] != size:
            raise DatasetError(
                f"{path}: episode {index} has simulator states of size {states.shape[1]}, the {task.id} model "
                f"now has {size}; the task or its assets changed since recording"
            )
        world.reset(report.seed)
        mujoco.mj_setState(world.model, world.data, states[0], SIM_STATE)
        mujoco.mj_forward(world.model, world.data)
        expected = [*states[1:], record.arrays["final_sim_state"]]
        verdict = Verdict()
        for k, action in enumerate(actions):
            verdict = world.step(action)
            now = sim_state(world.model, world.data)
            report.states_compared += 1
            if not _bits_equal(now, expected[k]):
                report.max_abs_diff = max(report.max_abs_diff, float(np.max(np.abs(now - expected[k]))))
                if report.first_mismatch is None:
                    report.first_mismatch = k + 1
        report.replayed = _outcome(verdict, undecided)
    finally:
        env.close()
    return report
