"""A hand-scripted :class:`~pipette_cli.evaluators.base.WorldState` for testing evaluators
without a simulator (ours and third-party ones).

Example:
    >>> from pipette_cli.evaluators import make_evaluator
    >>> from pipette_cli.specs.evaluators import LiftAndHoldSpec
    >>> world = ScriptedWorld(positions={"tube": (0.5, 0.0, 0.6)})
    >>> evaluator = make_evaluator(LiftAndHoldSpec(object="tube", min_height_gain=0.02, hold_s=0.5))
    >>> evaluator.reset(world)
    >>> world.move("tube", (0.5, 0.0, 0.65))
    >>> first_done(run(evaluator, world, steps=30))  # 15 steps of 1/30 s
    15
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from pipette_cli.errors import EvaluatorError, suggest
from pipette_cli.evaluators.base import Evaluator, MechanismState, Verdict

Vec = np.ndarray | tuple[float, float, float] | list[float]


def rotation_x(deg: float) -> np.ndarray:
    """Rotation matrix of ``deg`` degrees about the world x axis (tilts the z axis by ``deg``)."""
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _vectors(values: Mapping[str, Vec]) -> dict[str, np.ndarray]:
    return {ref: np.asarray(v, dtype=float) for ref, v in values.items()}


@dataclass
class ScriptedWorld:
    """World state whose values a test sets by hand; every read is recorded in ``reads``.

    Unknown refs raise :class:`~pipette_cli.errors.EvaluatorError` unless ``strict`` is false,
    in which case they read as origin, identity, 0, a 0.1 m square and an idle mechanism.
    """

    positions: dict[str, np.ndarray] = field(default_factory=dict)
    rotations: dict[str, np.ndarray] = field(default_factory=dict)
    joints: dict[str, float] = field(default_factory=dict)
    bboxes: dict[str, tuple[float, float]] = field(default_factory=dict)
    mechanisms: dict[str, MechanismState] = field(default_factory=dict)
    touched: set[str] = field(default_factory=set)
    """Objects the robot is in contact with."""
    control_dt: float = 1.0 / 30.0
    time: float = 0.0
    steps: int = 0
    strict: bool = True
    reads: set[tuple[str, str]] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.positions = _vectors(self.positions)
        self.rotations = _vectors(self.rotations)

    def _get(self, kind: str, table: Mapping[str, object], ref: str, default: object) -> object:
        self.reads.add((kind, ref))
        if ref in table:
            return table[ref]
        if kind == "rotation" and ref in self.positions:
            return np.eye(3)  # an object placed without a rotation stands upright
        if self.strict:
            raise EvaluatorError(f"scripted world has no {kind} for {ref!r}; {suggest(ref, table)}")
        return default

    def position(self, ref: str) -> np.ndarray:
        return np.array(self._get("position", self.positions, ref, np.zeros(3)), dtype=float)

    def rotation(self, ref: str) -> np.ndarray:
        return np.array(self._get("rotation", self.rotations, ref, np.eye(3)), dtype=float)

    def joint(self, ref: str) -> float:
        return float(self._get("joint", self.joints, ref, 0.0))  # type: ignore[arg-type]

    def bbox_xy(self, ref: str) -> tuple[float, float]:
        return self._get("bbox_xy", self.bboxes, ref, (0.1, 0.1))  # type: ignore[return-value]

    def mechanism(self, name: str) -> MechanismState:
        return self._get("mechanism", self.mechanisms, name, MechanismState(False, 0.0, 0.0))  # type: ignore[return-value]

    def robot_touches(self, ref: str) -> bool:
        self.reads.add(("robot_touches", ref))
        return ref in self.touched

    def move(self, ref: str, pos: Vec) -> None:
        """Set the position of ``ref``."""
        self.positions[ref] = np.asarray(pos, dtype=float)

    def advance(self) -> None:
        """One control step later (time is ``steps * control_dt``, without drift)."""
        self.steps += 1
        self.time = self.steps * self.control_dt


Script = Callable[[ScriptedWorld, int], None]


def run(
    evaluator: Evaluator,
    world: ScriptedWorld,
    steps: int,
    script: Script | None = None,
    *,
    stop_when_done: bool = False,
) -> list[Verdict]:
    """Advance ``world`` ``steps`` control steps, updating ``evaluator`` after each.

    Args:
        evaluator: An evaluator already reset with ``world``.
        world: The scripted world; its clock advances before ``script`` runs.
        steps: How many control steps.
        script: Called as ``script(world, k)`` for step ``k`` (1-based) to set that step's
            values.
        stop_when_done: Stop at the first verdict that is done.

    Returns:
        One verdict per step run; ``verdicts[k - 1]`` belongs to step ``k``.
    """
    verdicts: list[Verdict] = []
    for _ in range(steps):
        world.advance()
        if script is not None:
            script(world, world.steps)
        verdicts.append(evaluator.update(world))
        if stop_when_done and verdicts[-1].done:
            break
    return verdicts


def first_done(verdicts: Iterable[Verdict]) -> int | None:
    """1-based step of the first verdict that is done, or None."""
    return next((k for k, v in enumerate(verdicts, start=1) if v.done), None)
