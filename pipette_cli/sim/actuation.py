"""What a mechanism is built from: its named slots in ``data.userdata`` (:class:`Memory`), the
servo it takes over on the joint it drives (:class:`Servo`), and a button press (:func:`pressed`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from pipette_cli.sim.world import World


class Memory:
    """Named float slots of one mechanism in ``data.userdata``."""

    def __init__(self, world: World, offset: int, names: Sequence[str]) -> None:
        self._world = world
        self._offset = offset
        self._index = {name: offset + i for i, name in enumerate(names)}

    def __getitem__(self, name: str) -> float:
        return float(self._world.data.userdata[self._index[name]])

    def __setitem__(self, name: str, value: float) -> None:
        self._world.data.userdata[self._index[name]] = value

    def clear(self) -> None:
        self._world.data.userdata[self._offset : self._offset + len(self._index)] = 0.0


class Servo:
    """A joint's position actuator taken over by a mechanism: its gains set from the spec, its
    target written every control step (degrees or metres in, radians or metres to MuJoCo)."""

    def __init__(self, world: World, joint: str, stiffness: float, damping: float, max_force: float) -> None:
        self._world = world
        self.joint_id = world.joint_id(joint)
        self.actuator_id = world.actuator_for_joint(joint)
        self.hinge = world.model.jnt_type[self.joint_id] == mujoco.mjtJoint.mjJNT_HINGE
        self.qpos_adr = int(world.model.jnt_qposadr[self.joint_id])
        model = world.model
        model.actuator_gainprm[self.actuator_id, 0] = stiffness
        model.actuator_biasprm[self.actuator_id, :3] = [0.0, -stiffness, -damping]
        model.actuator_forcerange[self.actuator_id] = [-max_force, max_force]
        model.actuator_forcelimited[self.actuator_id] = 1
        model.actuator_ctrllimited[self.actuator_id] = 0

    def to_user(self, value: float) -> float:
        return float(np.rad2deg(value)) if self.hinge else float(value)

    def from_user(self, value: float) -> float:
        return float(np.deg2rad(value)) if self.hinge else float(value)

    @property
    def position(self) -> float:
        """The joint's position now (degrees or metres)."""
        return self.to_user(float(self._world.data.qpos[self.qpos_adr]))

    def drive(self, target: float) -> None:
        """Command ``target`` (degrees or metres)."""
        self._world.data.ctrl[self.actuator_id] = self.from_user(target)

    def let_go(self) -> None:
        """Command where the joint is, so the servo only damps it (the part moves freely)."""
        self._world.data.ctrl[self.actuator_id] = self._world.data.qpos[self.qpos_adr]


def pressed(world: World, site_id: int, radius: float, memory: Memory, slot: str) -> bool:
    """Whether the gripper's sensing point entered the sphere of ``radius`` around a button on this
    step (an edge: holding it there does not press again). ``slot`` remembers being inside."""
    inside = float(np.linalg.norm(world.tcp_position() - world.data.site_xpos[site_id])) <= radius
    was = memory[slot] > 0.5
    memory[slot] = 1.0 if inside else 0.0
    return inside and not was
