"""The scripted-expert contract: a policy over the simulation state, one action per control step.

Experts see the :class:`~pipette_cli.sim.world.World` (object poses, joints, the robot) —
privileged state a learned policy never gets — and return the same 8-D (or 7-D) action a
policy or a teleoperator produces: arm joint targets plus a gripper command (1 open, 0 closed).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np

from pipette_cli.errors import PipetteError, suggest
from pipette_cli.sim.world import World

if TYPE_CHECKING:
    from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)


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

FAMILY_EXPERTS: dict[str, tuple[str, ...]] = {
    # task family (a tag written by ``pipette new-task``) -> family expert names tried in order
    "pick": ("pick",),
    "place": ("place",),
    "insert": ("insert", "place"),
    "transfer": ("transfer", "place"),
    "open": ("open_lid",),  # none built in yet ("lid" is the closing plan): a clear "no expert" error
    "close": ("close_lid", "lid"),
    "press": ("press_button", "press"),
    "position": ("position",),
}


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
    does not get the benchmark's expert, whose plan names that task's scene objects; it gets
    its family's expert through :func:`find_expert`.

    Raises:
        PipetteError: no expert is registered for the task.
    """
    _load_builtins()
    key = _key(task_id)
    factory = _EXPERTS.get(key)
    if factory is None:
        raise PipetteError(f"no scripted expert for task {task_id!r}; {suggest(key, _EXPERTS)}")
    return factory()


def task_family(task: TaskSpec) -> str | None:
    """The task family recorded in the task's tags (``generated, place, ...``), if any."""
    return next((t for t in task.tags if t in FAMILY_EXPERTS), None)


def find_expert(task: TaskSpec) -> tuple[str, Expert]:
    """The task's own expert (by id), else the first registered expert of its family.

    This is how ``collect``, ``experts check`` and ``new-task --check`` pick an expert, so a
    task written by ``pipette new-task`` gets the family expert (``pick``, ``place``, ...).

    Returns:
        The expert's registered name and a fresh expert.

    Raises:
        PipetteError: neither the task nor its family has an expert.
    """
    family = task_family(task)
    candidates = FAMILY_EXPERTS.get(family or "", ())
    for name in (task.id, *candidates):
        try:
            return name, make_expert(name)
        except PipetteError:
            continue
        except Exception as exc:  # an expert that fails to build must not hide the others
            log.warning("expert %s unavailable: %s", name, exc)
    tried = f" or its family {family!r} (tried: {', '.join(candidates)})" if family else ""
    raise PipetteError(f"no scripted expert for task {task.id!r}{tried}; {suggest(_key(task.id), _EXPERTS)}")


def _load_builtins() -> None:
    import pipette_cli.demos.experts  # noqa: F401  (imports every expert module)
