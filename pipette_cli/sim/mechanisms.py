"""Scripted mechanisms (paper A.6), built from :mod:`pipette_cli.specs.mechanisms`.

A mechanism owns the actuator on the joint it drives. Actuators of scene objects that no
mechanism drives are switched off at build time, so hinged lids are passive: contact, gravity
and joint friction move them.

A mechanism keeps its state (fired or not, ramp start, a run's clock, a filtered reading) in
named slots of MuJoCo's ``data.userdata`` (:class:`Memory`), which the recorder's simulator state
(``mjSTATE_INTEGRATION``) includes: restoring a recorded state with ``mj_setState`` restores the
mechanisms with it, and replaying compares them bit for bit with the physics.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, ClassVar, Protocol

import mujoco
import numpy as np

from pipette_cli.errors import SimError
from pipette_cli.evaluators.base import MechanismState
from pipette_cli.plugins import Plugins
from pipette_cli.specs.mechanisms import ButtonReleaseSpec, MechanismSpec

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


class Mechanism(Protocol):
    """What the world asks of a runtime mechanism."""

    spec: MechanismSpec

    def reset(self) -> None: ...

    def update(self) -> None:
        """Called once per control step, after the physics steps."""
        ...

    def state(self) -> MechanismState: ...

    def names(self) -> list[str]:
        """Names of the values :meth:`state` reports, in a fixed order (recorded per step)."""
        ...


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


class ButtonRelease:
    """Gripper sensing point inside the button's trigger sphere -> the joint's position target
    ramps linearly from its value at trigger time to ``target_deg`` within ``ramp_s``."""

    MEMORY: ClassVar[tuple[str, ...]] = ("triggered", "trigger_time", "start", "target", "min_target")

    def __init__(self, spec: ButtonReleaseSpec, world: World) -> None:
        self.spec = spec
        self.site_id = world.site_id(spec.button)
        self.servo = Servo(world, spec.joint, spec.stiffness, spec.damping, spec.max_force)
        self.actuator_id = self.servo.actuator_id
        self.memory = world.mechanism_memory(spec.name, self.MEMORY)
        self._world = world
        self.reset()

    @property
    def triggered(self) -> bool:
        return self.memory["triggered"] > 0.5

    @property
    def trigger_time(self) -> float:
        return self.memory["trigger_time"]

    def reset(self) -> None:
        mem = self.memory
        mem.clear()
        start = self.servo.position
        mem["start"] = mem["target"] = mem["min_target"] = start
        self.servo.drive(start)

    def update(self) -> None:
        world, mem = self._world, self.memory
        if not self.triggered:
            distance = np.linalg.norm(world.tcp_position() - world.data.site_xpos[self.site_id])
            if distance <= self.spec.trigger_radius:
                mem["triggered"] = 1.0
                mem["trigger_time"] = world.data.time
        if self.triggered:
            alpha = min(1.0, (world.data.time - mem["trigger_time"]) / self.spec.ramp_s)
            mem["target"] = (1 - alpha) * mem["start"] + alpha * self.spec.target_deg
            mem["min_target"] = min(mem["min_target"], mem["target"])
        self.servo.drive(mem["target"])

    def names(self) -> list[str]:
        return ["triggered", "target", "min_target"]

    def state(self) -> MechanismState:
        mem = self.memory
        values = {"triggered": float(self.triggered), "target": mem["target"], "min_target": mem["min_target"]}
        return MechanismState(self.triggered, mem["target"], mem["min_target"], values)


MechanismFactory = Callable[[MechanismSpec, "World"], Mechanism]
MECHANISM_RUNTIMES: Plugins[MechanismFactory] = Plugins("mechanism runtime", SimError)
MECHANISM_RUNTIMES.add("button_release", ButtonRelease)  # type: ignore[arg-type]  # a class is its factory


def register_mechanism_runtime(type_name: str, factory: MechanismFactory) -> None:
    """Register the runtime for a mechanism spec type (third-party mechanisms). A factory that keeps
    state declares its slots as ``MEMORY`` (names) or ``memory_size(spec)`` and asks the world for
    them with ``world.mechanism_memory(spec.name, names)``."""
    MECHANISM_RUNTIMES.add(type_name, factory)


def _factory(spec: MechanismSpec) -> MechanismFactory:
    import pipette_cli.sim.instruments  # noqa: F401  (registers the instrument runtime)

    return MECHANISM_RUNTIMES.get(spec.type)


def memory_size(spec: MechanismSpec) -> int:
    """How many ``userdata`` slots the runtime of ``spec`` keeps its state in."""
    factory = _factory(spec)
    sized = getattr(factory, "memory_size", None)
    if callable(sized):
        return int(sized(spec))
    return len(getattr(factory, "MEMORY", ()))


def make_mechanism(spec: MechanismSpec, world: World) -> Mechanism:
    """Build the runtime mechanism for ``spec``; unknown types are errors."""
    return _factory(spec)(spec, world)
