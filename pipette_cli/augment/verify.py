"""Re-verify an augmented file: every episode's actions, replayed from its first state, must
reproduce its recorded states bit for bit and succeed under the task's evaluator."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pipette_cli.augment.simulate import Rollout, offset_from_attrs, replay_check
from pipette_cli.demos.provenance import replay_reason
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.errors import DatasetError
from pipette_cli.sim.distractors import distractors_from_attrs, with_distractors
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec


@dataclass(frozen=True)
class Check:
    index: int
    variant: str
    ok: bool
    reason: str


def verify_file(task: TaskSpec, path: Path, world: World | None = None) -> list[Check]:
    """Replay and judge every episode of ``path`` (physics only)."""
    status = scan(Path(path))
    if status.info is not None and status.info.task_id != task.id:
        raise DatasetError(f"{path} holds episodes of task {status.info.task_id}, not {task.id}")
    world = world or World(task)
    checks = []
    for ref in status.episodes:
        record = read_episode(ref)
        extra = distractors_from_attrs(record.attrs)  # the scene it ran in: the task's, plus its distractors
        scene = World(with_distractors(task, extra), meshes=world.meshes) if extra else world
        why = replay_check(scene, ref.summary.seed, Rollout.from_record(record), offset_from_attrs(record.attrs))
        reason = "" if why is None else replay_reason(why, record.attrs)
        checks.append(Check(ref.index, str(record.attrs.get("augment_variant", "")), why is None, reason))
    return checks
