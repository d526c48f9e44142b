"""The scripted-expert contract: a policy over the simulation state, one action per control step.

Experts see the :class:`~pipette_cli.sim.world.World` (object poses, joints, the robot) —
privileged state a learned policy never gets — and return the same 8-D (or 7-D) action a
policy or a teleoperator produces: arm joint targets plus a gripper command (1 open, 0 closed).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from pipette_cli.errors import PipetteError, suggest
from pipette_cli.sim.world import World


class Expert(Protocol):
    """A scripted demonstrator for one task."""

    def reset(self, world: World, rng: np.random.Generator) -> None:
        """Plan for the episode that ``world`` was just reset to."""
        ...

    def act(self, world: World) -> np.ndarray:
        """The action for the current control step."""
        ...


ExpertFactory = Callable[[], Expert]
_EXPERTS: dict[str, ExpertFactory] = {}


def register_expert(*task_names: str) -> Callable[[ExpertFactory], ExpertFactory]:
    """Register an expert factory for tasks by short name without version (``PickUpTestTube``)."""

    def decorate(factory: ExpertFactory) -> ExpertFactory:
        for name in task_names:
            _EXPERTS[name] = factory
        return factory

    return decorate


def expert_names() -> list[str]:
    _load_builtins()
    return sorted(_EXPERTS)


def make_expert(task_id: str) -> Expert:
    """The scripted expert for ``task_id`` (any version).

    Raises:
        PipetteError: no expert is registered for the task.
    """
    _load_builtins()
    short = task_id.split("/")[-1].rsplit("-v", 1)[0]
    factory = _EXPERTS.get(short)
    if factory is None:
        raise PipetteError(f"no scripted expert for task {task_id!r}; {suggest(short, _EXPERTS)}")
    return factory()


def _load_builtins() -> None:
    import pipette_cli.demos.experts  # noqa: F401  (imports every expert module)
