"""Turn a :class:`~.specs.VariantSpec` into concrete perturbations of one demo.

A :class:`VariantPlan` is everything sampled for one (demo, variant): the perturbed action
sequence (``None`` when the variant only changes what is rendered), the light factor, the
camera offsets and the object offset. Its random numbers come from
``default_rng([seed, demo seed, crc32(variant name)])``: the same inputs give the same episode,
whatever the worker or executor.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pipette_cli.augment import formulas
from pipette_cli.augment.simulate import ObjectOffset
from pipette_cli.augment.specs import (
    CameraPoseSpec,
    JointNoiseSpec,
    LightingSpec,
    ObjectPoseSpec,
    SpeedSpec,
    VariantSpec,
)
from pipette_cli.sim.scene import CAMERA_NAMES


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
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def physics(self) -> bool:
        return self.actions is not None

    @property
    def visual(self) -> bool:
        return self.light_scale != 1.0 or bool(self.camera_offsets)


def variant_rng(seed: int, demo_seed: int, variant: str) -> np.random.Generator:
    return np.random.default_rng([seed, demo_seed, zlib.crc32(variant.encode())])


def plan_variant(
    variant: VariantSpec, actions: np.ndarray, *, seed: int, demo_seed: int, default_object: str | None = None
) -> VariantPlan:
    """Sample the perturbations of ``variant`` for a demo with ``actions`` (T, D).

    Order on the actions: speed resampling first, then joint noise on the arm targets.
    """
    rng = variant_rng(seed, demo_seed, variant.name)
    plan = VariantPlan(variant.name, variant.magnitude(), None)
    params: dict[str, Any] = {}
    physics_actions = np.asarray(actions, dtype=np.float64)
    if (speed := variant.get(SpeedSpec)) is not None:
        assert isinstance(speed, SpeedSpec)
        x = formulas.warp_positions(len(physics_actions), speed.factor, rng, rho=speed.rho, window=speed.window)
        physics_actions = formulas.resample_actions(physics_actions, x, speed.interpolation)
        params["speed"] = {**speed.model_dump(), "source_steps": len(actions), "steps": len(x)}
    if (noise := variant.get(JointNoiseSpec)) is not None:
        assert isinstance(noise, JointNoiseSpec)
        eta = formulas.joint_noise(rng, (len(physics_actions), physics_actions.shape[1] - 1), noise.sigma, noise.bound)
        physics_actions = physics_actions.copy()
        physics_actions[:, :-1] += eta
        params["joint_noise"] = {**noise.model_dump(), "max_abs": float(np.abs(eta).max(initial=0.0))}
    if (obj := variant.get(ObjectPoseSpec)) is not None:
        assert isinstance(obj, ObjectPoseSpec)
        name = obj.object or default_object
        if name is None:
            raise ValueError("object_pose needs an object (the task has no target)")
        dx, dy = rng.uniform(-obj.xy, obj.xy, size=2) if obj.xy > 0 else (0.0, 0.0)
        dyaw = float(rng.uniform(-obj.yaw_deg, obj.yaw_deg)) if obj.yaw_deg > 0 else 0.0
        plan.offset = ObjectOffset(name, float(dx), float(dy), dyaw)
        plan.object_ramp = obj.ramp_steps
        params["object_pose"] = {**obj.model_dump(), **plan.offset.as_dict()}
    if variant.physics:
        plan.actions = physics_actions
    if (light := variant.get(LightingSpec)) is not None:
        assert isinstance(light, LightingSpec)
        plan.light_scale, plan.headlight = light.scale, light.headlight
        params["lighting"] = light.model_dump()
    if (cam := variant.get(CameraPoseSpec)) is not None:
        assert isinstance(cam, CameraPoseSpec)
        name = cam.camera if cam.camera != "random" else str(rng.choice(CAMERA_NAMES))
        radius = cam.wrist_radius if name == "wrist" else cam.radius
        delta = formulas.ball_offset(rng, radius)
        plan.camera_offsets[name] = delta
        params["camera_pose"] = {**cam.model_dump(), "chosen": name, "radius_used": radius, "delta": delta.tolist()}
    plan.params = params
    return plan
