"""Per-episode conditions of a shifted evaluation: a suite's perturbations applied to one episode.

A suite may list ``perturbations:`` (the specs of :mod:`pipette_cli.specs.perturbations`, the
same ones ``pipette augment`` uses). Each episode draws its own values from its seed, through
the augmentation's own planner (:func:`~pipette_cli.augment.perturb.plan_variant`, without
actions) and applies them through the augmentation's own code: the object offset as
:func:`~pipette_cli.augment.simulate.apply_offset` after the reset, lights, cameras and surface
colours as :func:`~pipette_cli.augment.render.visual_perturbation` around the whole episode, and
distractors as a scene built with them (placed clear of the task's expert's path). The
same seed gives the same conditions, whatever the worker, and the values drawn are written to the
episode's log (``conditions``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import mujoco

from pipette_cli.augment.clutter import clutter_of, expert_path
from pipette_cli.augment.perturb import VariantPlan, placed_object, plan_variant
from pipette_cli.augment.render import visual_perturbation
from pipette_cli.augment.simulate import apply_offset, placement
from pipette_cli.augment.specs import VariantSpec
from pipette_cli.sim.distractors import with_distractors
from pipette_cli.sim.env import Observation, PipetteEnv
from pipette_cli.specs.perturbations import DistractorSpec, PerturbationSpec

CONDITIONS = "conditions"
"""The name the conditions are drawn under (part of their random stream, like a variant's name)."""


def plan_conditions(env: PipetteEnv, seed: int, perturbations: Sequence[PerturbationSpec]) -> VariantPlan:
    """Draw the conditions of the episode with ``seed`` (the world must be reset with that seed).
    Distractors are drawn last, from their own stream, clear of the path the task's scripted
    expert takes in that episode (the object already moved), which leaves the world elsewhere."""
    others = [p for p in perturbations if not isinstance(p, DistractorSpec)]
    variant = VariantSpec(name=CONDITIONS, perturbations=others)
    target = env.task.targets[0] if env.task.targets else None
    name = placed_object(variant, target)
    start = placement(env.world, name) if name is not None else None
    plan = plan_variant(variant, None, seed=0, demo_seed=seed, default_object=target, placement=start)
    extra = next((p for p in perturbations if isinstance(p, DistractorSpec)), None)
    if extra is not None:
        room = clutter_of(env.world, expert_path(env.world, seed, plan.offset), extra.path_height)
        clutter = VariantSpec(name=f"{CONDITIONS}+{extra.atom}", perturbations=[extra])
        drawn = plan_variant(clutter, None, seed=0, demo_seed=seed, clutter=room)
        plan.distractors = drawn.distractors
        plan.params = {**plan.params, **drawn.params}
    return plan


@contextmanager
def episode_conditions(
    env: PipetteEnv, seed: int, perturbations: Sequence[PerturbationSpec]
) -> Iterator[tuple[PipetteEnv, Observation, dict[str, Any]]]:
    """Reset ``env`` with ``seed`` under the drawn conditions; yields the environment the episode
    runs in (``env``, or one built with the drawn distractors and closed after the block), its
    first observation and what was drawn. Lights, cameras and colours are restored when the
    block ends."""
    obs = env.reset(seed)
    if not perturbations:
        yield env, obs, {}
        return
    plan = plan_conditions(env, seed, perturbations)
    scene = env
    if plan.distractors:
        scene = PipetteEnv(
            with_distractors(env.task, plan.distractors),
            image_size=env.image_size,
            render_profile=env.render_profile,
            render=env.rig is not None,
        )
    try:
        if scene is not env:
            scene.reset(seed)
        world = scene.world
        if plan.offset is not None:
            apply_offset(world, plan.offset)
        with visual_perturbation(world.model, plan, scene.rig.ids if scene.rig is not None else {}):
            mujoco.mj_forward(world.model, world.data)  # the moved object and cameras
            if plan.offset is not None:
                world.restart()  # judged from where the object now starts
            yield scene, scene.observe(), plan.params
    finally:
        if scene is not env:
            scene.close()
