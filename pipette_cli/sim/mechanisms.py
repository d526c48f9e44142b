"""Scripted mechanisms (paper A.6), built from :mod:`pipette_cli.specs.mechanisms`.

A mechanism owns the actuator on the joint it drives. Actuators of scene objects that no
mechanism drives are switched off at build time, so hinged lids are passive: contact, gravity
and joint friction move them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from pipette_cli.errors import SimError, suggest
from pipette_cli.evaluators.base import MechanismState
from pipette_cli.specs.mechanisms import ButtonReleaseSpec, MechanismSpec

if TYPE_CHECKING:
    from pipette_cli.sim.world import World


class ButtonRelease:
    """Gripper sensing point inside the button's trigger sphere -> the joint's position target
    ramps linearly from its value at trigger time to ``target_deg`` within ``ramp_s``."""

    def __init__(self, spec: ButtonReleaseSpec, world: World) -> None:
        self.spec = spec
        self.site_id = world.site_id(spec.button)
        self.joint_id = world.joint_id(spec.joint)
        self.actuator_id = world.actuator_for_joint(spec.joint)
        self.hinge = world.model.jnt_type[self.joint_id] == mujoco.mjtJoint.mjJNT_HINGE
        model = world.model
        model.actuator_gainprm[self.actuator_id, 0] = spec.stiffness
        model.actuator_biasprm[self.actuator_id, :3] = [0.0, -spec.stiffness, -spec.damping]
        model.actuator_forcerange[self.actuator_id] = [-spec.max_force, spec.max_force]
        model.actuator_forcelimited[self.actuator_id] = 1
        model.actuator_ctrllimited[self.actuator_id] = 0
        self._world = world
        self.reset()

    def _to_user(self, value: float) -> float:
        return float(np.rad2deg(value)) if self.hinge else float(value)

    def _from_user(self, value: float) -> float:
        return float(np.deg2rad(value)) if self.hinge else float(value)

    def reset(self) -> None:
        data = self._world.data
        self.triggered = False
        self.trigger_time = 0.0
        self.start = float(data.qpos[self._world.model.jnt_qposadr[self.joint_id]])
        self.target = self.start
        self.min_target = self.start
        data.ctrl[self.actuator_id] = self.target

    def update(self) -> None:
        world = self._world
        data = world.data
        if not self.triggered:
            distance = np.linalg.norm(world.tcp_position() - data.site_xpos[self.site_id])
            if distance <= self.spec.trigger_radius:
                self.triggered = True
                self.trigger_time = data.time
        if self.triggered:
            alpha = min(1.0, (data.time - self.trigger_time) / self.spec.ramp_s)
            goal = self._from_user(self.spec.target_deg)
            self.target = (1 - alpha) * self.start + alpha * goal
            self.min_target = min(self.min_target, self.target)
        data.ctrl[self.actuator_id] = self.target

    def state(self) -> MechanismState:
        return MechanismState(self.triggered, self._to_user(self.target), self._to_user(self.min_target))


MechanismFactory = Callable[[MechanismSpec, "World"], ButtonRelease]
_FACTORIES: dict[str, MechanismFactory] = {"button_release": ButtonRelease}  # type: ignore[dict-item]


def register_mechanism_runtime(type_name: str, factory: MechanismFactory) -> None:
    """Register the runtime for a mechanism spec type (third-party mechanisms)."""
    _FACTORIES[type_name] = factory


def make_mechanism(spec: MechanismSpec, world: World):
    """Build the runtime mechanism for ``spec``; unknown types are errors."""
    factory = _FACTORIES.get(spec.type)
    if factory is None:
        raise SimError(f"no runtime for mechanism type {spec.type!r}; {suggest(spec.type, _FACTORIES)}")
    return factory(spec, world)
