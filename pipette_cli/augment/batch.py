"""Batch physics screening with MuJoCo's multithreaded ``mujoco.rollout``.

For tasks without scripted mechanisms (their logic runs in Python between steps), every physics
variant of a demo is rolled out at once from the demo's start: the arm and gripper controls of
each control step are held for its physics substeps. The task's evaluator then judges each
trajectory after the fact, one control step at a time, from the rolled-out states. Variants it
rejects need no further work; the accepted ones are simulated once more step by step, which
records the bit-exact states the recorder and the replay check need (rollout returns no solver
warmstart per step). The step-by-step verdict decides.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import mujoco
import numpy as np
from mujoco import rollout

from pipette_cli.augment.simulate import restore
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.world import World

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def can_batch(world: World) -> bool:
    """Rollout runs open loop: only tasks without scripted mechanisms qualify."""
    return not world.mechanisms


def controls(world: World, actions: np.ndarray, steps: int) -> np.ndarray:
    """Per-physics-step controls for ``actions`` held ``world.substeps`` each, padded to ``steps``
    control steps by holding the last action (what :func:`~.simulate.simulate` does)."""
    d = world.data
    saved = d.ctrl.copy()
    out = np.empty((steps * world.substeps, world.model.nu))
    for k in range(steps):
        world.apply_action(np.asarray(actions[min(k, len(actions) - 1)], dtype=np.float64))
        out[k * world.substeps : (k + 1) * world.substeps] = d.ctrl
    d.ctrl[:] = saved
    return out


def screen(
    world: World,
    seed: int,
    state0: np.ndarray,
    action_lists: Sequence[np.ndarray],
    *,
    settle_steps: int = 0,
    nthread: int | None = None,
) -> list[Verdict]:
    """The evaluator's verdict on each action sequence, from one multithreaded rollout."""
    if not action_lists:
        return []
    m, d = world.model, world.data
    restore(world, seed, state0)
    start = np.empty(mujoco.mj_stateSize(m, FULL))
    mujoco.mj_getState(m, d, start, FULL)
    warmstart = d.qacc_warmstart.copy()
    lengths = [len(a) + settle_steps for a in action_lists]
    longest = max(lengths)
    control = np.stack([controls(world, a, longest) for a in action_lists])
    threads = max(1, min(nthread or os.cpu_count() or 1, len(action_lists)))
    datas = [mujoco.MjData(m) for _ in range(threads)]
    states, _ = rollout.rollout(m, datas, start[None], control, initial_warmstart=warmstart[None])
    verdicts = []
    for i, length in enumerate(lengths):
        restore(world, seed, state0)  # the evaluator starts from the demo's first state
        verdict = Verdict()
        for k in range(length):
            state = states[i, (k + 1) * world.substeps - 1]
            if not np.all(np.isfinite(state)):
                verdict = Verdict(failed=True, reason="diverged")
                break
            mujoco.mj_setState(m, d, state, FULL)
            mujoco.mj_forward(m, d)
            world.step_count = k + 1
            verdict = world.evaluator.update(world)
            if verdict.done:
                break
        verdicts.append(verdict)
    restore(world, seed, state0)
    return verdicts
