"""The evaluator contract: a success criterion fed one world state per control step.

An evaluator is built from its spec (:mod:`pipette_cli.specs.evaluators`), reset with the
state at reset, then updated once per control step. Each update returns a
:class:`Verdict`: ``success`` once the criterion is met, ``failed`` with a reason once it
can no longer be met (timeout, dropped, tilted, ...), and continuous metrics either way.
Runtime classes register under the spec's ``type`` name; an unknown type is an error.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from pipette_cli.errors import EvaluatorError, suggest
from pipette_cli.plugins import Plugins
from pipette_cli.specs.evaluators import EvaluatorSpec


class WorldState(Protocol):
    """Read-only view of the simulation an evaluator needs; refs are ``object`` or ``object/part``.

    Positions are in the bench frame (metres); joint positions in degrees for hinges and
    metres for slides.
    """

    @property
    def time(self) -> float:
        """Simulated seconds since reset."""
        ...

    control_dt: float
    """Seconds per control step."""

    def position(self, ref: str) -> np.ndarray:
        """World position of an object's root body, or of one of its bodies or sites."""
        ...

    def rotation(self, ref: str) -> np.ndarray:
        """3x3 world rotation matrix of an object's root body (or a body/site)."""
        ...

    def joint(self, ref: str) -> float:
        """Position of an articulated joint (degrees for hinges, metres for slides)."""
        ...

    def bbox_xy(self, ref: str) -> tuple[float, float]:
        """Size (dx, dy) of the axis-aligned xy bounding box of a part's collision geometry."""
        ...

    def mechanism(self, name: str) -> MechanismState:
        """State of a scene mechanism."""
        ...

    def robot_touches(self, ref: str) -> bool:
        """Whether the robot (any of its links or fingers) is in contact with the object ``ref``."""
        ...


@dataclass(frozen=True)
class MechanismState:
    """What a scripted mechanism reports (paper A.6), and an instrument's named values."""

    triggered: bool = False
    target: float = 0.0
    """Current target of the driven joint (degrees or metres)."""
    min_target: float = 0.0
    """Lowest target reached since reset."""
    values: Mapping[str, float] = field(default_factory=dict)
    """Every reported value by name: an instrument's ``closed``, ``running``, ``run_time_s``,
    ``mass_g``, zone counts such as ``rotor`` and ``rotor.tube`` (1/0 flags, seconds, grams)."""

    def value(self, name: str) -> float:
        """The reported value ``name``.

        Raises:
            EvaluatorError: the mechanism reports no such value (the message lists those it does).
        """
        try:
            return float(self.values[name])
        except KeyError:
            raise EvaluatorError(f"the mechanism reports no value {name!r}; {suggest(name, self.values)}") from None


@dataclass(frozen=True)
class Verdict:
    """Outcome of one evaluator update."""

    success: bool = False
    failed: bool = False
    reason: str | None = None
    """Why it failed ("timeout", "dropped", "tilted", "out_of_region", "too_low", ...)."""
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def done(self) -> bool:
        return self.success or self.failed


class Evaluator(Protocol):
    """Runtime evaluator built from a spec."""

    @property
    def spec(self) -> EvaluatorSpec: ...

    def reset(self, state: WorldState) -> None: ...

    def update(self, state: WorldState) -> Verdict: ...


EvaluatorFactory = Callable[[Any], Evaluator]  # takes the spec of the type it is registered under
EVALUATOR_RUNTIMES: Plugins[EvaluatorFactory] = Plugins("evaluator runtime", EvaluatorError)


def register(type_name: str) -> Callable[[EvaluatorFactory], EvaluatorFactory]:
    """Decorator: register the runtime class (or factory) for spec type ``type_name``."""
    return EVALUATOR_RUNTIMES.register(type_name)


def make_evaluator(spec: EvaluatorSpec) -> Evaluator:
    """Build the runtime evaluator for ``spec``.

    The built-in families are registered by then: this module is only importable through its
    package, whose ``__init__`` imports every family module.

    Raises:
        EvaluatorError: no runtime is registered for ``spec.type`` (never a silent success).
    """
    return EVALUATOR_RUNTIMES.get(spec.type)(spec)


def registered_types() -> list[str]:
    """Names of every evaluator type that has a runtime, built-in families included."""
    return EVALUATOR_RUNTIMES.names()
