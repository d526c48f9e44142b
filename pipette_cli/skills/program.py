"""Run an expert program: skill steps in order, one action per control step.

:class:`ProgramExpert` implements the scripted-expert contract
(:class:`~pipette_cli.demos.experts.base.Expert`). Each step's skill yields moves; a move is
executed as a straight tool path with a smooth (minimum-jerk) time profile, solved by IK every
control step warm-started from the last solution, so consecutive actions are continuous joint
targets. When a skill fails, the expert stops moving (it holds its joints), and ``failure`` says
which step failed and why, for ``collect``, ``experts check`` and ``new-task --check`` to report.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator

import numpy as np

from pipette_cli.sim.world import World
from pipette_cli.skills.frames import min_jerk, slerp
from pipette_cli.skills.library import skill_runtime
from pipette_cli.skills.moves import Move, SkillFailure
from pipette_cli.skills.runtime import SkillContext
from pipette_cli.specs.expert import StepSpec

log = logging.getLogger(__name__)


class ProgramExpert:
    """A scripted expert that runs a program of skill steps (see the module docstring)."""

    def __init__(self, steps: list[StepSpec], source: str = "task") -> None:
        self.steps = list(steps)
        self.source = source
        """Where the program came from: ``task`` (its YAML) or ``derived`` (from the success criterion)."""
        self.failure: str | None = None
        self.step_index = -1
        self._ctx: SkillContext | None = None

    # ------------------------------------------------------------------ contract
    def reset(self, world: World, rng: np.random.Generator) -> None:
        self._ctx = SkillContext(world, rng)
        self.failure = None
        self.step_index = -1
        self._moves: Iterator[Move] | None = None
        self._move: Move | None = None
        self._k = 0
        self._n = 0
        self._start_pos = world.tcp_position()
        self._start_rot = world.tcp_rotation()
        self._q = world.arm_qpos()
        self._gripper = self._ctx.hand.gripper

    @property
    def done(self) -> bool:
        """Every step has run (or one failed)."""
        return self._ctx is not None and self._move is None and self.step_index >= len(self.steps)

    def act(self, world: World) -> np.ndarray:
        ctx = self._ctx
        if ctx is None:
            raise RuntimeError("call reset() before act()")
        if self._move is None or self._k >= self._n:
            self._advance()
        move = self._move
        if move is None:
            return np.append(self._q, self._gripper)
        self._k += 1
        t = min_jerk(self._k / self._n)
        if move.free:
            self._q = (1 - t) * self._start_q + t * move.q
        else:
            pos = (1 - t) * self._start_pos + t * move.pos
            rot = slerp(self._start_rot, move.rot, t)
            self._q = ctx.ik.solve(pos, rot, self._q, iterations=4 if self._k < self._n else 12).qpos
        self._gripper = move.gripper
        return np.append(self._q, move.gripper)

    # ------------------------------------------------------------------ internals
    def _advance(self) -> None:
        ctx = self._ctx
        assert ctx is not None
        if self._move is not None:
            self._start_pos, self._start_rot = self._move.pos, self._move.rot
        self._move = None
        if self.failure is not None:
            return
        while self.step_index < len(self.steps):
            self._start_q = self._q.copy()
            try:
                if self._moves is None:
                    self.step_index += 1
                    if self.step_index >= len(self.steps):
                        return
                    step = self.steps[self.step_index]
                    ctx.next_step = self.steps[self.step_index + 1] if self.step_index + 1 < len(self.steps) else None
                    self._moves = skill_runtime(type(step))(ctx, step)
                self._move = next(self._moves)
            except StopIteration:
                self._moves = None
                continue
            except SkillFailure as exc:
                self._fail(str(exc))
                return
            except Exception as exc:  # a skill bug must not crash a collection run of many episodes
                log.debug("skill crashed", exc_info=True)
                self._fail(f"internal error in the skill: {type(exc).__name__}: {exc}")
                return
            self._k = 0
            self._n = max(1, int(round(self._move.seconds / ctx.world.control_dt)))
            return

    def _fail(self, why: str) -> None:
        step = self.steps[self.step_index]
        self.failure = f"step {self.step_index + 1} ({step.describe()}): {why}"
        self._moves = None
        self._move = None
        log.info("expert stopped: %s", self.failure)
