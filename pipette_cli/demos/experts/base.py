"""The scripted-expert contract and how a task gets its expert.

An expert sees the :class:`~pipette_cli.sim.world.World` (object poses, joints, the robot) —
privileged state a learned policy never gets — and returns the same action a policy or a
teleoperator produces: arm joint targets plus a gripper command (1 open, 0 closed).

A task's expert is data: the skill program in its YAML (``expert:``), or, without one, the program
read off its success criterion (:func:`~pipette_cli.skills.derive.derive_program`). Python experts
can still be registered by task id (a task pack's own controller, a test's stand-in); they take
precedence over the program.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np

from pipette_cli.errors import PipetteError
from pipette_cli.sim.world import World
from pipette_cli.skills.derive import derive_program

if TYPE_CHECKING:
    from pipette_cli.specs.expert import StepSpec
    from pipette_cli.specs.task import TaskSpec


class Expert(Protocol):
    """A scripted demonstrator for one task."""

    def reset(self, world: World, rng: np.random.Generator) -> None:
        """Plan for the episode that ``world`` was just reset to."""
        ...

    def act(self, world: World) -> np.ndarray:
        """The action for the current control step."""
        ...


ExpertFactory = Callable[[], Expert]
_CUSTOM: dict[str, ExpertFactory] = {}


def register_expert(*task_ids: str) -> Callable[[ExpertFactory], ExpertFactory]:
    """Register a Python expert for task ids (any version): it replaces the task's skill program."""

    def decorate(factory: ExpertFactory) -> ExpertFactory:
        for task_id in task_ids:
            _CUSTOM[_key(task_id)] = factory
        return factory

    return decorate


def _key(task_id: str) -> str:
    return re.sub(r"-v[0-9]+$", "", task_id)


def expert_program(task: TaskSpec) -> tuple[list[StepSpec], str]:
    """The skill program a task's expert runs and where it comes from (``task`` or ``derived``).

    Raises:
        PipetteError: the task has no program and none can be read off its success criterion.
    """
    return derive_program(task), "task" if task.expert else "derived"


def find_expert(task: TaskSpec) -> tuple[str, Expert]:
    """The expert for ``task``: a registered Python expert, else its skill program.

    This is how ``collect``, ``experts check``, ``augment`` and ``new-task --check`` pick one.

    Returns:
        A short description of the expert (``program``, ``derived program`` or the Python class)
        and a fresh expert.

    Raises:
        PipetteError: there is neither a registered expert nor a program for the task.
    """
    factory = _CUSTOM.get(_key(task.id))
    if factory is not None:
        return getattr(factory, "__qualname__", "custom expert"), factory()
    from pipette_cli.skills.program import ProgramExpert  # deferred: mink, scipy (~0.26 s)

    steps, source = expert_program(task)
    return ("program" if source == "task" else "derived program"), ProgramExpert(steps, source)


def expert_failure(expert: Expert) -> str | None:
    """Why the expert stopped trying (a skill step that could not do its job), if it did."""
    failure = getattr(expert, "failure", None)
    return failure if isinstance(failure, str) else None


__all__ = ["Expert", "PipetteError", "expert_failure", "expert_program", "find_expert", "register_expert"]
