"""Per-episode conditions of a shifted evaluation: a suite's perturbations applied to one episode.

A suite may list ``perturbations:`` (the specs of :mod:`pipette_cli.specs.perturbations`, the
same ones ``pipette augment`` uses). Each episode draws its own values from its seed, through
the augmentation's own planner (:func:`~pipette_cli.augment.perturb.plan_variant`, without
actions) and applies them through the augmentation's own code: the object offset as
:func:`~pipette_cli.augment.simulate.apply_offset` after the reset, lights, cameras and surface
colours as :func:`~pipette_cli.augment.render.visual_perturbation` around the whole episode. The
same seed gives the same conditions, whatever the worker, and the values drawn are written to the
episode's log (``conditions``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import mujoco

from pipette_cli.augment.perturb import VariantPlan, placed_object, plan_variant
from pipette_cli.augment.render import visual_perturbation
from pipette_cli.augment.simulate import apply_offset, placement
from pipette_cli.augment.specs import VariantSpec
from pipette_cli.sim.env import Observation, PipetteEnv
from pipette_cli.specs.perturbations import PerturbationSpec

CONDITIONS = "conditions"
"""The name the conditions are drawn under (part of their random stream, like a variant's name)."""


def plan_conditions(env: PipetteEnv, seed: int, perturbations: Sequence[PerturbationSpec]) -> VariantPlan:
    """Draw the conditions of the episode with ``seed`` (the world must be reset with that seed)."""
    variant = VariantSpec(name=CONDITIONS, perturbations=list(perturbations))
    target = env.task.targets[0] if env.task.targets else None
    name = placed_object(variant, target)
    start = placement(env.world, name) if name is not None else None
    return plan_variant(variant, None, seed=0, demo_seed=seed, default_object=target, placement=start)


@contextmanager
def episode_conditions(
    env: PipetteEnv, seed: int, perturbations: Sequence[PerturbationSpec]
) -> Iterator[tuple[Observation, dict[str, Any]]]:
    """Reset ``env`` with ``seed`` under the drawn conditions; yields the first observation and
    what was drawn. Lights, cameras and colours are restored when the block ends."""
    obs = env.reset(seed)
    if not perturbations:
        yield obs, {}
        return
    plan = plan_conditions(env, seed, perturbations)
    world = env.world
    if plan.offset is not None:
        apply_offset(world, plan.offset)
    with visual_perturbation(world.model, plan, env.rig.ids if env.rig is not None else {}):
        mujoco.mj_forward(world.model, world.data)  # the moved object and cameras
        if plan.offset is not None:
            world.restart()  # judged from where the object now starts
        yield env.observe(), plan.params
