"""Turn a :class:`~.specs.VariantSpec` into concrete perturbations of one demo.

A :class:`VariantPlan` is everything sampled for one (demo, variant): the perturbed action
sequence (``None`` when the variant only changes what is rendered), the light factor, the
camera offsets, the object offset and the surface tints. Its random numbers come from
``default_rng([seed, demo seed, crc32(variant name)])``: the same inputs give the same episode,
whatever the worker or executor. Evaluation suites plan their per-episode conditions with the
same function and no actions (:func:`plan_variant` with ``actions=None``).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pipette_cli.augment import formulas
from pipette_cli.augment.clutter import Clutter, place_distractors
from pipette_cli.augment.simulate import ObjectOffset, Placement, wrap_deg
from pipette_cli.augment.specs import VariantSpec
from pipette_cli.sim.distractors import Distractor
from pipette_cli.sim.scene import CAMERA_NAMES
from pipette_cli.specs.perturbations import (
    CameraPoseSpec,
    DistractorSpec,
    JointNoiseSpec,
    LightingSpec,
    ObjectPoseSpec,
    SpeedSpec,
    SurfaceColorSpec,
)


@dataclass
class VariantPlan:
    """The sampled perturbations of one demo for one variant."""

    variant: str
    magnitude: str
    actions: np.ndarray | None
    light_scale: float = 1.0
    headlight: bool = True
    camera_offsets: dict[str, np.ndarray] = field(default_factory=dict)
    offset: ObjectOffset | None = None
    object_ramp: int = 0
    surface_tint: dict[str, np.ndarray] = field(default_factory=dict)
    """Per surface (``bench``, ``floor``), the colour mixed into its own."""
    surface_blend: float = 0.0
    """The weight of that colour."""
    distractors: list[Distractor] = field(default_factory=list)
    """Objects put on the bench (the scene is rebuilt with them, :mod:`.clutter`)."""
    noise: np.ndarray | None = None
    """Corrective joint noise (``joint_noise`` with ``corrective``), ``(T, D - 1)``: added to the arm
    targets the simulation executes, after any retargeting, while ``actions`` stay the clean targets
    the episode records."""
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def physics(self) -> bool:
        return self.actions is not None

    def executed(self) -> np.ndarray | None:
        """The actions the simulation runs: ``actions`` plus the corrective noise, if any."""
        if self.actions is None or self.noise is None:
            return self.actions
        out = self.actions.copy()
        out[:, :-1] += self.noise
        return out

    @property
    def visual(self) -> bool:
        return self.light_scale != 1.0 or bool(self.camera_offsets) or bool(self.surface_tint)


def variant_rng(seed: int, demo_seed: int, variant: str) -> np.random.Generator:
    return np.random.default_rng([seed, demo_seed, zlib.crc32(variant.encode())])


def _object_offset(
    obj: ObjectPoseSpec, name: str, rng: np.random.Generator, placement: Placement | None
) -> ObjectOffset:
    if obj.task_range is None:
        dx, dy = rng.uniform(-obj.xy, obj.xy, size=2) if obj.xy > 0 else (0.0, 0.0)
        dyaw = float(rng.uniform(-obj.yaw_deg, obj.yaw_deg)) if obj.yaw_deg > 0 else 0.0
        return ObjectOffset(name, float(dx), float(dy), dyaw)
    if placement is None or placement.name != name:
        raise ValueError(f"object_pose with task_range needs where {name!r} starts (its placement)")
    new = [
        nominal + (float(rng.uniform(-span, span)) * obj.task_range if span > 0 else 0.0)
        for nominal, span in zip(placement.nominal, placement.span)
    ]
    start = placement.start
    return ObjectOffset(name, new[0] - start[0], new[1] - start[1], wrap_deg(new[2] - start[2]))


def placed_object(variant: VariantSpec, default_object: str | None) -> str | None:
    """The object whose start pose :func:`plan_variant` needs (``object_pose`` with ``task_range``)."""
    obj = variant.get(ObjectPoseSpec)
    if not isinstance(obj, ObjectPoseSpec) or obj.task_range is None:
        return None
    return obj.object or default_object


def plan_variant(
    variant: VariantSpec,
    actions: np.ndarray | None,
    *,
    seed: int,
    demo_seed: int,
    default_object: str | None = None,
    placement: Placement | None = None,
    clutter: Clutter | None = None,
) -> VariantPlan:
    """Sample the perturbations of ``variant`` for a demo with ``actions`` (T, D).

    Order on the actions: speed resampling first, then joint noise on the arm targets (corrective
    noise is kept apart in ``plan.noise`` and added when the plan runs, :meth:`VariantPlan.executed`).
    Without actions (an evaluation episode's conditions) perturbations of the actions are refused.

    Args:
        placement: Where the moved object starts (needed by ``object_pose`` with ``task_range``).
        clutter: Where the demonstration leaves room on the bench (needed by ``distractors``).
    """
    rng = variant_rng(seed, demo_seed, variant.name)
    plan = VariantPlan(variant.name, variant.magnitude(), None)
    params: dict[str, Any] = {}
    if actions is None and any(p.on_actions for p in variant.perturbations):
        raise ValueError(f"{variant.name}: speed and joint noise perturb a demonstration's actions; there are none")
    physics_actions = np.asarray(actions if actions is not None else np.zeros((0, 1)), dtype=np.float64)
    if (speed := variant.get(SpeedSpec)) is not None:
        assert isinstance(speed, SpeedSpec)
        source_steps = len(physics_actions)
        x = formulas.warp_positions(source_steps, speed.factor, rng, rho=speed.rho, window=speed.window)
        physics_actions = formulas.resample_actions(physics_actions, x, speed.interpolation)
        params["speed"] = {**speed.model_dump(), "source_steps": source_steps, "steps": len(x)}
    if (noise := variant.get(JointNoiseSpec)) is not None:
        assert isinstance(noise, JointNoiseSpec)
        shape = (len(physics_actions), physics_actions.shape[1] - 1)
        eta = formulas.joint_noise(rng, shape, noise.sigma, noise.bound, noise.window)
        if noise.corrective:
            plan.noise = eta  # executed, not recorded: the episode's actions stay the demonstrated targets
        else:
            physics_actions = physics_actions.copy()
            physics_actions[:, :-1] += eta
        params["joint_noise"] = {**noise.model_dump(), "max_abs": float(np.abs(eta).max(initial=0.0))}
    if (obj := variant.get(ObjectPoseSpec)) is not None:
        assert isinstance(obj, ObjectPoseSpec)
        name = obj.object or default_object
        if name is None:
            raise ValueError("object_pose needs an object (the task has no target)")
        plan.offset = _object_offset(obj, name, rng, placement)
        plan.object_ramp = obj.ramp_steps
        params["object_pose"] = {**obj.model_dump(), **plan.offset.as_dict()}
    if (extra := variant.get(DistractorSpec)) is not None:
        assert isinstance(extra, DistractorSpec)
        if clutter is None:
            raise ValueError(f"{variant.name}: distractors need where the demonstration leaves room (its clutter)")
        plan.distractors = place_distractors(extra, clutter, rng)
        params["distractors"] = {**extra.model_dump(), "placed": [d.as_dict() for d in plan.distractors]}
    if variant.physics and actions is not None:
        plan.actions = physics_actions
    if (light := variant.get(LightingSpec)) is not None:
        assert isinstance(light, LightingSpec)
        scale = light.scale + (float(rng.uniform(-light.jitter, light.jitter)) if light.jitter > 0 else 0.0)
        plan.light_scale, plan.headlight = scale, light.headlight
        params["lighting"] = {**light.model_dump(), "scale_used": scale}
    if (cam := variant.get(CameraPoseSpec)) is not None:
        assert isinstance(cam, CameraPoseSpec)
        if cam.camera == "all":
            names = list(CAMERA_NAMES)
        else:
            names = [cam.camera if cam.camera != "random" else str(rng.choice(CAMERA_NAMES))]
        radii = {name: cam.wrist_radius if name == "wrist" else cam.radius for name in names}
        for name, radius in radii.items():
            plan.camera_offsets[name] = formulas.ball_offset(rng, radius)
        if len(names) == 1:
            [name] = names
            chosen: dict[str, Any] = {
                "chosen": name,
                "radius_used": radii[name],
                "delta": plan.camera_offsets[name].tolist(),
            }
        else:
            chosen = {"chosen": "all", "delta": {n: d.tolist() for n, d in plan.camera_offsets.items()}}
        params["camera_pose"] = {**cam.model_dump(), **chosen}
    if (surface := variant.get(SurfaceColorSpec)) is not None:
        assert isinstance(surface, SurfaceColorSpec)
        for name in surface.surfaces:
            plan.surface_tint[name] = rng.uniform(0.0, 1.0, size=3)
        plan.surface_blend = surface.blend
        params["surface_color"] = {
            **surface.model_dump(),
            "tint": {n: t.round(4).tolist() for n, t in plan.surface_tint.items()},
        }
    plan.params = params
    return plan
