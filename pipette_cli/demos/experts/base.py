"""The scripted-expert contract: a policy over the simulation state, one action per control step.

Experts see the :class:`~pipette_cli.sim.world.World` (object poses, joints, the robot) —
privileged state a learned policy never gets — and return the same 8-D (or 7-D) action a
policy or a teleoperator produces: arm joint targets plus a gripper command (1 open, 0 closed).
"""

from __future__ import annotations

import re
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


def register_expert(*names: str) -> Callable[[ExpertFactory], ExpertFactory]:
    """Register an expert factory under task ids without version (``pipette/PickUpTestTube``) or
    under family names without a namespace (``pick``, ``close_lid``) for generated tasks."""

    def decorate(factory: ExpertFactory) -> ExpertFactory:
        for name in names:
            _EXPERTS[_key(name)] = factory
        return factory

    return decorate


def _key(name: str) -> str:
    """``pipette/PickUpTestTube-v1`` -> ``pipette/PickUpTestTube``; family names stay as they are."""
    return re.sub(r"-v[0-9]+$", "", name)


def expert_names() -> list[str]:
    _load_builtins()
    return sorted(_EXPERTS)


def make_expert(task_id: str) -> Expert:
    """The scripted expert for ``task_id`` (any version), or for a family name.

    The namespace is part of the key: a generated ``generated/CloseSpectrophotometerLid-v1``
    does not get the benchmark's expert, whose plan names that task's scene objects.

    Raises:
        PipetteError: no expert is registered for the task.
    """
    _load_builtins()
    key = _key(task_id)
    factory = _EXPERTS.get(key)
    if factory is None:
        raise PipetteError(f"no scripted expert for task {task_id!r}; {suggest(key, _EXPERTS)}")
    return factory()


def _load_builtins() -> None:
    import pipette_cli.demos.experts  # noqa: F401  (imports every expert module)
