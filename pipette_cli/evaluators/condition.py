"""Shared machinery of the built-in evaluators: a per-step condition, a hold timer, a timeout.

A family only says what its condition is (:meth:`ConditionEvaluator.check`, returning a
:class:`Check`) and what it records at reset (:meth:`ConditionEvaluator.start`); this module
turns that into the contract of :mod:`pipette_cli.evaluators.base`:

* the hold time grows by ``state.control_dt`` on every update whose condition holds and
  drops to 0 on the first update where it does not;
* the criterion is *satisfied* on an update whose condition holds and whose hold time has
  reached ``hold_s`` (``hold_s = 0``: the first update whose condition holds);
* a :attr:`Check.fail` reason (e.g. ``"tilted"``) fails at once, before anything else;
* at ``elapsed >= timeout_s`` (elapsed = ``state.time`` minus the time at reset), checked
  after the condition so that success on that very step still counts, it fails with the
  last unmet reason (``"out_of_region"``, ``"too_low"``, ...), or ``"timeout"`` when the
  condition held but its hold was cut short; ``metrics["timed_out"]`` is then 1;
* :meth:`ConditionEvaluator.update` latches: after a success or a failure every later call
  returns that same verdict. :meth:`ConditionEvaluator.advance` latches failures only and
  reports whether the criterion is satisfied *now*; composites use it to ask that children
  hold at the same time.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Generic, TypeVar

import numpy as np

from pipette_cli.errors import EvaluatorError
from pipette_cli.evaluators.base import Verdict, WorldState
from pipette_cli.specs.base import BoundSpec
from pipette_cli.specs.evaluators import EvaluatorSpec

TIME_EPS = 1e-9
"""Slack on time comparisons, so 15 steps of 1/30 s reach a 0.5 s hold despite rounding."""
TIMEOUT = "timeout"

S = TypeVar("S", bound=EvaluatorSpec)


@dataclass(frozen=True)
class Check:
    """One update's test of a condition.

    Attributes:
        ok: The condition holds on this update.
        metrics: Continuous measurements (metres, degrees), reported whatever ``ok`` is.
        unmet: Why the condition does not hold; the failure reason if the timeout hits now.
        fail: An unrecoverable failure (e.g. ``"tilted"``); ends the episode at once.
    """

    ok: bool
    metrics: dict[str, float] = field(default_factory=dict)
    unmet: str | None = None
    fail: str | None = None


class ConditionEvaluator(ABC, Generic[S]):
    """Base of the built-in evaluators; subclasses implement :meth:`start` and :meth:`check`."""

    spec_type: type[EvaluatorSpec] = EvaluatorSpec

    def __init__(self, spec: S) -> None:
        if not isinstance(spec, self.spec_type):
            raise EvaluatorError(f"{type(self).__name__} needs a {self.spec_type.__name__}, got {type(spec).__name__}")
        self.spec: S = spec
        self._started = False
        self._t0 = 0.0
        self._held = 0.0
        self._ever_satisfied = False
        self._unmet: str | None = None
        self._final: Verdict | None = None

    @property
    def hold_s(self) -> float:
        """Seconds the condition must hold; 0 for families without a ``hold_s`` field."""
        return float(getattr(self.spec, "hold_s", 0.0))

    @property
    def unmet(self) -> str | None:
        """Reason the criterion was not satisfied on the last update (None when it was)."""
        return self._unmet

    def prime(self, state: WorldState) -> None:
        """At the episode's start, for a stage of a sequence that starts later: take the references
        that belong to the episode, not to the stage's start (an object's upright)."""

    def reset(self, state: WorldState) -> None:
        """Forget everything and take the references (initial pose, clock) from ``state``."""
        self._started = True
        self._t0 = float(state.time)
        self._held = 0.0
        self._ever_satisfied = False
        self._unmet = None
        self._final = None
        self.start(state)

    def update(self, state: WorldState) -> Verdict:
        """Evaluate one control step; success and failure are final (latched)."""
        if self._final is not None:
            return self._final
        verdict = self.advance(state)
        if verdict.success:
            self._final = verdict
        return verdict

    def advance(self, state: WorldState) -> Verdict:
        """Evaluate one control step; failures latch, success means "satisfied on this step"."""
        if not self._started:
            raise EvaluatorError(f"{self.spec.type}: call reset(state) before update(state)")
        if self._final is not None and self._final.failed:
            return self._final
        check = self.check(state)
        metrics = dict(check.metrics)
        if check.fail is not None:
            self._unmet = check.fail
            return self._fail(check.fail, metrics)
        self._held = self._held + float(state.control_dt) if check.ok else 0.0
        metrics["hold_s"] = self._held
        if check.ok and self._held + TIME_EPS >= self.hold_s:
            self._ever_satisfied = True
            self._unmet = None
            return Verdict(success=True, metrics=metrics)
        self._unmet = TIMEOUT if check.ok else (check.unmet or TIMEOUT)
        if self.timed_out(state) and not self._ever_satisfied:
            metrics["timed_out"] = 1.0
            return self._fail(self._unmet, metrics)
        return Verdict(metrics=metrics)

    def timed_out(self, state: WorldState) -> bool:
        """Whether ``timeout_s`` has elapsed since reset."""
        limit = self.spec.timeout_s
        return limit is not None and float(state.time) - self._t0 + TIME_EPS >= limit

    def _fail(self, reason: str, metrics: dict[str, float]) -> Verdict:
        self._final = Verdict(failed=True, reason=reason, metrics=metrics)
        return self._final

    @abstractmethod
    def start(self, state: WorldState) -> None:
        """Record what the condition is measured against (called by :meth:`reset`)."""

    @abstractmethod
    def check(self, state: WorldState) -> Check:
        """Test the condition on this update."""


def up_axis(rotation: np.ndarray) -> np.ndarray:
    """The body's local z axis in world coordinates (third column of its rotation), unit length."""
    axis = np.asarray(rotation, dtype=float).reshape(3, 3)[:, 2]
    norm = float(np.linalg.norm(axis))
    if norm == 0.0 or not np.isfinite(norm):
        raise EvaluatorError(f"invalid rotation matrix {rotation!r}")
    return axis / norm


def tilt_deg(up0: np.ndarray, rotation: np.ndarray) -> float:
    """Angle in degrees between ``up0`` and the current up axis: arccos(u_t . u_0) (paper A.8)."""
    cosine = float(np.clip(np.dot(up_axis(rotation), up0), -1.0, 1.0))
    return float(np.degrees(np.arccos(cosine)))


def bound_gap(bound: BoundSpec, value: float) -> float:
    """How far ``value`` lies outside ``bound`` (0 inside); a continuous progress metric."""
    if bound.min is not None and value < bound.min:
        return bound.min - value
    if bound.max is not None and value > bound.max:
        return value - bound.max
    return 0.0


def position(state: WorldState, ref: str) -> np.ndarray:
    """``state.position(ref)`` as a float array of shape (3,)."""
    return np.asarray(state.position(ref), dtype=float).reshape(3)
