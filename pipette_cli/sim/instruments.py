"""The ``instrument`` mechanism: an instrument's state machine, declared in the task's YAML.

Built from :class:`~pipette_cli.specs.mechanisms.InstrumentSpec`; every part is optional:

* **closure** -- closed while its joint lies in the bound (``closed``, or the name it reports as,
  e.g. ``door_closed``).
* **motor** -- a button drives the closure joint. ``toggle``: each press ramps it to the other end
  and holds it there (a thermal cycler's motorised lid, a plate reader's drawer). ``release``: a
  press while closed ramps it open and lets go (a centrifuge lid on its strut); pushed shut by
  hand, it latches (held shut) again. Presses are ignored during a run, which holds it shut.
* **run** -- a start button starts a run of ``seconds`` only when closed and idle; otherwise the
  press is refused (``refused`` counts them). Opening during a run aborts it (``aborted``).
  Reports ``running``, ``run_time_s`` (of the current or last run), ``runs`` (completed).
* **touch** -- a head worked by pressing on it (a vortex mixer in touch mode) runs while something
  presses it down with at least ``force_n``; a press held ``seconds`` completes a run. Reports
  ``running``, ``run_time_s`` (of the current or last press) and ``runs``, as a run does.
* **contents** -- zones (wells, shelves, a block) report how many tracked objects are in them
  (``rotor``) and which (``rotor.tube``: 1 or 0).
* **scale** -- a weighing pan reports ``mass_g``: the vertical contact force on the pan over g,
  low-pass filtered, minus the tare; ``stable`` when the filtered reading has caught up with the
  force; ``tared`` counts presses of the tare button.

Buttons fire when the gripper's sensing point enters a sphere around them (paper A.6), once per
entry. Timers and filters live in the world's mechanism memory (``data.userdata``), so the state
survives saving and restoring the simulator state bit for bit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import mujoco
import numpy as np

from pipette_cli.evaluators.base import MechanismState
from pipette_cli.sim.actuation import Servo, pressed
from pipette_cli.specs.mechanisms import InstrumentSpec, ZoneSpec

if TYPE_CHECKING:
    from pipette_cli.sim.world import World

GRAVITY = 9.81
RUN_REPORTS = ("running", "run_time_s", "runs")
"""What a run reports, whether started by a button or by pressing a head."""


class Zone:
    """Which tracked objects stand in a zone (their origin near one of its sites)."""

    def __init__(self, spec: ZoneSpec, world: World) -> None:
        self.spec = spec
        self._world = world
        self.site_ids = [world.site_id(site) for site in spec.sites]
        self.objects = list(spec.objects) if spec.objects else [n for n, info in world.objects.items() if info.free]

    def names(self) -> list[str]:
        return [self.spec.name, *(f"{self.spec.name}.{obj}" for obj in self.objects)]

    def values(self) -> dict[str, float]:
        spec, data = self.spec, self._world.data
        sites = data.site_xpos[self.site_ids]
        flags = {}
        for obj in self.objects:
            delta = self._world.position(obj) - sites
            inside = (
                (np.hypot(delta[:, 0], delta[:, 1]) <= spec.radius)
                & (delta[:, 2] >= -spec.below)
                & (delta[:, 2] <= spec.above)
            )
            flags[f"{spec.name}.{obj}"] = 1.0 if bool(np.any(inside)) else 0.0
        return {spec.name: float(sum(flags.values())), **flags}


class Instrument:
    """Runtime of :class:`~pipette_cli.specs.mechanisms.InstrumentSpec` (see the module docstring)."""

    MEMORY: ClassVar[tuple[str, ...]] = (
        "motor_target",
        "motor_from",
        "motor_to",
        "motor_t0",
        "motor_ramping",
        "motor_free",
        "motor_inside",
        "running",
        "run_t0",
        "run_time_s",
        "runs",
        "refused",
        "aborted",
        "run_inside",
        "mass_g",
        "tare_g",
        "tared",
        "raw_g",
        "tare_inside",
        "touch_counted",
    )

    def __init__(self, spec: InstrumentSpec, world: World) -> None:
        from mink.utils import get_subtree_body_ids  # deferred: mink and scipy (`pipette --help` imports this)

        self.spec = spec
        self._world = world
        self.memory = world.mechanism_memory(spec.name, self.MEMORY)
        m = world.model
        self.closure_joint = world.joint_id(spec.closure.joint) if spec.closure else None
        motor = spec.motor
        self.servo = (
            Servo(world, spec.closure.joint, motor.stiffness, motor.damping, motor.max_force)
            if motor is not None and spec.closure is not None
            else None
        )
        self.motor_button = world.site_id(motor.button) if motor is not None else None
        self.run_button = world.site_id(spec.run.button) if spec.run is not None else None
        self.zones = [Zone(zone, world) for zone in spec.contents]
        self.pan_bodies: set[int] = set()
        self.head_bodies: set[int] = set()
        self.owner_bodies: set[int] = set()
        self.tare_button = None
        pressed_on = spec.scale.pan if spec.scale is not None else spec.touch.head if spec.touch is not None else None
        if pressed_on is not None:
            owner = world.body_id(pressed_on.split("/", 1)[0])
            self.owner_bodies = set(get_subtree_body_ids(m, owner))
        if spec.scale is not None:
            pan = world.body_id(spec.scale.pan)
            self.pan_bodies = set(get_subtree_body_ids(m, pan))
            if spec.scale.tare_button is not None:
                self.tare_button = world.site_id(spec.scale.tare_button)
        if spec.touch is not None:
            head = world.body_id(spec.touch.head)
            self.head_bodies = set(get_subtree_body_ids(m, head))
        self._force = np.zeros(6)
        self.reset()

    # ------------------------------------------------------------------ state
    def closed(self) -> bool:
        closure = self.spec.closure
        if closure is None:
            return True
        return closure.closed.contains(self._world.joint(closure.joint))

    @property
    def running(self) -> bool:
        return self.memory["running"] > 0.5

    def names(self) -> list[str]:
        spec = self.spec
        out = [spec.closure.report] if spec.closure else []
        if spec.motor:
            out.append("motor_target")
        out += list(self._run_reports())
        for zone in self.zones:
            out += zone.names()
        if spec.scale:
            out += ["mass_g", "stable", "tared"]
        return out

    def state(self) -> MechanismState:
        spec, mem = self.spec, self.memory
        values: dict[str, float] = {}
        if spec.closure:
            values[spec.closure.report] = float(self.closed())
        if spec.motor:
            values["motor_target"] = mem["motor_target"]
        values.update({key: mem[key] for key in self._run_reports()})
        for zone in self.zones:
            values.update(zone.values())
        if spec.scale:
            reading = mem["mass_g"] - mem["tare_g"]
            values.update(
                mass_g=reading,
                stable=float(abs(mem["raw_g"] - mem["mass_g"]) <= spec.scale.stable_g),
                tared=mem["tared"],
            )
        return MechanismState(self.running, mem["motor_target"], mem["motor_target"], values)

    def _run_reports(self) -> tuple[str, ...]:
        """The values a run reports: a start button's, or a touch head's (no presses refused or runs
        aborted: pressing is the run)."""
        if self.spec.run is not None:
            return (*RUN_REPORTS, "refused", "aborted")
        return RUN_REPORTS if self.spec.touch is not None else ()

    # ------------------------------------------------------------------ episode
    def reset(self) -> None:
        mem = self.memory
        mem.clear()
        if self.servo is not None:
            motor = self.spec.motor
            assert motor is not None
            now = self.servo.position
            mem["motor_target"] = now
            mem["motor_to"] = motor.open if abs(now - motor.open) < abs(now - motor.shut) else motor.shut
            mem["motor_free"] = float(motor.mode == "release" and not self.closed())
            self._drive()
        if self.spec.scale is not None:
            mem["raw_g"] = mem["mass_g"] = self._weigh()

    def update(self) -> None:
        if self.servo is not None:
            self._update_motor()
        if self.spec.run is not None:
            self._update_run()
        if self.spec.touch is not None:
            self._update_touch()
        if self.spec.scale is not None:
            self._update_scale()

    # ------------------------------------------------------------------ parts
    def _update_motor(self) -> None:
        motor, mem, world = self.spec.motor, self.memory, self._world
        assert motor is not None and self.servo is not None and self.motor_button is not None
        if pressed(world, self.motor_button, motor.trigger_radius, mem, "motor_inside") and not self.running:
            if motor.mode == "toggle":
                self._ramp(motor.shut if mem["motor_to"] == motor.open else motor.open)
            elif self.closed():
                self._ramp(motor.open)
        if mem["motor_ramping"] > 0.5:
            alpha = min(1.0, (world.time - mem["motor_t0"]) / motor.ramp_s)
            mem["motor_target"] = (1 - alpha) * mem["motor_from"] + alpha * mem["motor_to"]
            if alpha >= 1.0:
                mem["motor_ramping"] = 0.0
                mem["motor_free"] = float(motor.mode == "release")
        elif mem["motor_free"] > 0.5 and self.closed():  # pushed shut by hand: the latch holds it
            mem["motor_free"] = 0.0
            mem["motor_target"] = mem["motor_to"] = motor.shut
        self._drive()

    def _ramp(self, goal: float) -> None:
        mem = self.memory
        assert self.servo is not None
        mem["motor_from"] = self.servo.position if mem["motor_free"] > 0.5 else mem["motor_target"]
        mem["motor_to"] = goal
        mem["motor_t0"] = self._world.time
        mem["motor_ramping"] = 1.0
        mem["motor_free"] = 0.0

    def _drive(self) -> None:
        assert self.servo is not None and self.spec.motor is not None
        mem = self.memory
        if self.running:
            self.servo.drive(self.spec.motor.shut)  # locked shut during a run
        elif mem["motor_free"] > 0.5:
            mem["motor_target"] = self.servo.position
            self.servo.let_go()
        else:
            self.servo.drive(mem["motor_target"])

    def _update_run(self) -> None:
        run, mem, world = self.spec.run, self.memory, self._world
        assert run is not None and self.run_button is not None
        closed = self.closed()
        if pressed(world, self.run_button, run.trigger_radius, mem, "run_inside"):
            if self.running or not closed or mem["motor_ramping"] > 0.5:
                mem["refused"] += 1.0
            else:
                mem["running"], mem["run_t0"], mem["run_time_s"] = 1.0, world.time, 0.0
        if not self.running:
            return
        if not closed:
            mem["running"] = 0.0
            mem["aborted"] += 1.0
            return
        mem["run_time_s"] = min(run.seconds, world.time - mem["run_t0"])
        if world.time - mem["run_t0"] >= run.seconds:
            mem["running"] = 0.0
            mem["runs"] += 1.0

    def _update_touch(self) -> None:
        touch, mem, now = self.spec.touch, self.memory, self._world.time
        assert touch is not None
        if self._pressing(self.head_bodies) < touch.force_n:
            mem["running"] = mem["touch_counted"] = 0.0
            return
        if not self.running:
            mem["running"], mem["run_t0"] = 1.0, now
        mem["run_time_s"] = now - mem["run_t0"]
        if mem["run_time_s"] >= touch.seconds and mem["touch_counted"] < 0.5:
            mem["runs"] += 1.0
            mem["touch_counted"] = 1.0

    def _update_scale(self) -> None:
        scale, mem, world = self.spec.scale, self.memory, self._world
        assert scale is not None
        raw = self._weigh()
        mem["raw_g"] = raw
        mem["mass_g"] += (raw - mem["mass_g"]) * min(1.0, world.control_dt / scale.filter_s)
        if self.tare_button is not None and pressed(world, self.tare_button, scale.trigger_radius, mem, "tare_inside"):
            mem["tare_g"] = mem["mass_g"]
            mem["tared"] += 1.0

    def _weigh(self) -> float:
        """Grams pressing down on the pan now."""
        return 1000.0 * self._pressing(self.pan_bodies) / GRAVITY

    def _pressing(self, bodies: set[int]) -> float:
        """Newtons pressing down on ``bodies`` now: the vertical contact forces on them from
        anything but the instrument itself."""
        m, d = self._world.model, self._world.data
        down = 0.0
        for i in range(d.ncon):
            contact = d.contact[i]
            b1, b2 = int(m.geom_bodyid[contact.geom1]), int(m.geom_bodyid[contact.geom2])
            on1, on2 = b1 in bodies, b2 in bodies
            if on1 == on2 or (b2 if on1 else b1) in self.owner_bodies:
                continue
            mujoco.mj_contactForce(m, d, i, self._force)
            world_force = contact.frame.reshape(3, 3).T @ self._force[:3]  # on geom2, from geom1
            down += float(world_force[2]) if on1 else -float(world_force[2])
        return down
