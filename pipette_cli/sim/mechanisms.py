"""Scripted mechanisms (paper A.6), built from :mod:`pipette_cli.specs.mechanisms`.

A mechanism owns the actuator on the joint it drives. Actuators of scene objects that no
mechanism drives are switched off at build time, so hinged lids are passive: contact, gravity
and joint friction move them.

A mechanism keeps its state (fired or not, ramp start, a run's clock, a filtered reading) in
named slots of MuJoCo's ``data.userdata`` (:class:`~pipette_cli.sim.actuation.Memory`), which
the recorder's simulator state (``mjSTATE_INTEGRATION``) includes: restoring a recorded state
with ``mj_setState`` restores the mechanisms with it, and replaying compares them bit for bit
with the physics. The built-in types are ``button_release`` (here) and ``instrument``
(:mod:`~pipette_cli.sim.instruments`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, ClassVar, Protocol

import numpy as np

from pipette_cli.errors import SimError
from pipette_cli.evaluators.base import MechanismState
from pipette_cli.plugins import Plugins
from pipette_cli.sim.actuation import Servo
from pipette_cli.sim.instruments import Instrument
from pipette_cli.specs.mechanisms import ButtonReleaseSpec, MechanismSpec

if TYPE_CHECKING:
    from pipette_cli.sim.world import World


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
MECHANISM_RUNTIMES.add("instrument", Instrument)  # type: ignore[arg-type]


def register_mechanism_runtime(type_name: str, factory: MechanismFactory) -> None:
    """Register the runtime for a mechanism spec type (third-party mechanisms). A factory that keeps
    state declares its slots as ``MEMORY`` (names) or ``memory_size(spec)`` and asks the world for
    them with ``world.mechanism_memory(spec.name, names)``."""
    MECHANISM_RUNTIMES.add(type_name, factory)


def _factory(spec: MechanismSpec) -> MechanismFactory:
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
