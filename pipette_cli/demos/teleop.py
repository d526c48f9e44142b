"""Keyboard SE(3) teleoperation in the MuJoCo viewer (paper A.5), recorded like any expert.

:class:`KeyboardTeleop` holds the end-effector target pose ``(p*, q*)``. Each key press (or
auto-repeat) queued since the last control step adds one increment: ``p* += dp`` with
``|dp| = 0.002 k`` m along a base-frame axis, ``q* = normalize(q* x Quat(dphi))`` with
``|dphi| = 0.01 k`` rad about a tool-frame axis (k = 4.0: 8 mm and 0.04 rad). Damped least
squares (:class:`~pipette_cli.sim.controllers.DifferentialIK`) turns the target into 7 joint
targets; a key toggles the binary gripper command. It follows the
:class:`~pipette_cli.demos.experts.base.Expert` protocol (``reset``, ``act``), so a teleop
episode goes through the same recorder as a scripted one. Save, discard and reset keys
become events the session loop (:func:`teleop_episode`) acts on.

Keys are GLFW key codes, as ``mujoco.viewer.launch_passive(key_callback=...)`` reports them
(``docs/teleop.md`` lists them); the viewer's own panels are hidden so that letter keys do not
also toggle its rendering flags.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipette_cli.demos.collect import CollectResult, check_target, plan_seeds, step_cap
from pipette_cli.demos.provenance import model_sha256, provenance
from pipette_cli.demos.recorder import STOPPED, TRUNCATED, DatasetInfo, EpisodeSummary, EpisodeWriter, sim_state
from pipette_cli.demos.store import clean, pack, part_path, scan, writing
from pipette_cli.errors import DatasetError, PipetteError
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.controllers import DifferentialIK
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.sim.world import World
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

SENSITIVITY = 4.0
"""Paper A.5: k = 4.0 -> 0.008 m and 0.04 rad per control step."""
IK_TOLERANCE = 1e-5
"""Metres of tcp position error at which the IK iteration stops."""
REACH_TOLERANCE = 0.005
"""Metres of IK position error beyond which a target increment is refused (out of reach)."""


_KEY_CODES = {**{c: ord(c) for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"}, "Enter": 257, "Delete": 261, "Home": 268}


def glfw_key(name: str) -> int:
    """GLFW key code of a letter, a digit, ``Enter``, ``Delete`` or ``Home``."""
    try:
        return _KEY_CODES[name if len(name) > 1 else name.upper()]
    except KeyError:
        raise ValueError(f"unknown key {name!r}; known: {', '.join(_KEY_CODES)}") from None


@dataclass(frozen=True)
class KeyMap:
    """Which key does what: translation along and rotation about the x, y, z axes, gripper, events."""

    translate: dict[int, tuple[int, float]]
    rotate: dict[int, tuple[int, float]]
    gripper: int
    events: dict[int, str]

    def describe(self) -> list[tuple[str, str]]:
        """``(key, what it does)`` rows for help texts."""
        label = {code: name for name, code in _KEY_CODES.items()}
        rows = [
            (label[k], f"move the target {'+' if s > 0 else '-'}{'xyz'[a]} (base frame)")
            for k, (a, s) in self.translate.items()
        ]
        rows += [
            (label[k], f"rotate {'+' if s > 0 else '-'} about the tool's {'xyz'[a]} axis")
            for k, (a, s) in self.rotate.items()
        ]
        rows.append((label[self.gripper], "toggle the gripper (open/closed)"))
        rows += [(label[k], f"{event} the episode") for k, event in self.events.items()]
        return rows


DEFAULT_KEYS = KeyMap(
    translate={
        glfw_key(k): v
        for k, v in {
            "W": (0, 1.0),
            "S": (0, -1.0),
            "A": (1, 1.0),
            "D": (1, -1.0),
            "R": (2, 1.0),
            "F": (2, -1.0),
        }.items()
    },
    rotate={
        glfw_key(k): v
        for k, v in {
            "U": (0, 1.0),
            "J": (0, -1.0),
            "I": (1, 1.0),
            "K": (1, -1.0),
            "O": (2, 1.0),
            "L": (2, -1.0),
        }.items()
    },
    gripper=glfw_key("G"),
    events={glfw_key("Enter"): "save", glfw_key("Delete"): "discard", glfw_key("Home"): "reset"},
)


class KeyboardTeleop:
    """Keyboard SE(3) teleoperation of a world's arm: target pose, IK, gripper, episode events.

    Args:
        world: The world whose arm is driven.
        sensitivity: k of paper A.5 (translation 0.002 k m, rotation 0.01 k rad per increment).
        keys: The key map.
    """

    def __init__(self, world: World, *, sensitivity: float = SENSITIVITY, keys: KeyMap = DEFAULT_KEYS) -> None:
        self.world = world
        self.keys = keys
        self.pos_step = 0.002 * sensitivity
        self.rot_step = 0.01 * sensitivity
        self.ik = DifferentialIK(world)
        self._pressed: queue.SimpleQueue[int] = queue.SimpleQueue()
        self.events: deque[str] = deque()
        self.reset(world)

    # ------------------------------------------------------------ Expert protocol
    def reset(self, world: World, rng: np.random.Generator | None = None) -> None:
        """Start from the arm's current joint targets and the tcp pose they command; gripper as the
        task starts; forget queued keys."""
        self.world = world
        self.joint_targets = world.data.ctrl[world.arm_actuator_ids].copy()
        from mink import SO3  # deferred: mink and scipy (~1 s; `pipette --help` imports this module)

        self.target_pos, rot = self.ik.tcp_pose(self.joint_targets)
        self.target_quat = SO3.from_matrix(rot).wxyz
        self.gripper = 1.0 if world.task.embodiment.gripper == "open" else 0.0
        while not self._pressed.empty():
            self._pressed.get_nowait()
        self.events.clear()

    def act(self, world: World) -> np.ndarray:
        """Apply the keys pressed since the last step and return ``[joint targets..., gripper]``."""
        dp, dphi = np.zeros(3), np.zeros(3)
        while not self._pressed.empty():
            key = self._pressed.get_nowait()
            if key in self.keys.translate:
                axis, sign = self.keys.translate[key]
                dp[axis] += sign * self.pos_step
            elif key in self.keys.rotate:
                axis, sign = self.keys.rotate[key]
                dphi[axis] += sign * self.rot_step
            elif key == self.keys.gripper:
                self.gripper = 0.0 if self.gripper >= 0.5 else 1.0
        if dp.any() or dphi.any():
            self._move(dp, dphi)
        return np.append(self.joint_targets, self.gripper)

    # ----------------------------------------------------------------- input
    def on_key(self, keycode: int) -> None:
        """Key callback (called from the viewer's thread): queue the key for the next control step.

        Save, discard and reset take effect at once, even while the episode waits for a decision.
        """
        if keycode in self.keys.events:
            self.events.append(self.keys.events[keycode])
        else:
            self._pressed.put(keycode)

    def pop_event(self) -> str | None:
        """The oldest pending ``save``, ``discard`` or ``reset`` event, if any."""
        return self.events.popleft() if self.events else None

    # ------------------------------------------------------------------ motion
    def _move(self, dp: np.ndarray, dphi: np.ndarray) -> None:
        from mink import SO3  # deferred: mink and scipy (~1 s; `pipette --help` imports this module)

        pos = self.target_pos + dp
        turned = (SO3(wxyz=self.target_quat) @ SO3.exp(dphi)).normalize()
        result = self.ik.solve(pos, turned.as_matrix(), q_start=self.joint_targets, tolerance=IK_TOLERANCE)
        if result.position_error > REACH_TOLERANCE:
            log.info("target out of reach (IK error %.1f mm); increment ignored", result.position_error * 1000)
            return
        self.target_pos, self.target_quat, self.joint_targets = pos, turned.wxyz, result.qpos


@dataclass
class TeleopOutcome:
    """How a teleoperated episode ended: ``save`` (with its summary), ``discard``, ``reset`` or ``quit``."""

    event: str
    summary: EpisodeSummary | None = None


def teleop_episode(
    env: PipetteEnv,
    teleop: KeyboardTeleop,
    writer: EpisodeWriter,
    *,
    max_steps: int,
    sync: Callable[[], None] = lambda: None,
    running: Callable[[], bool] = lambda: True,
    lock: Callable[[], Any] = contextlib.nullcontext,
    stop: Callable[[], bool] = lambda: False,
    realtime: bool = True,
    on_done: Callable[[Verdict], None] | None = None,
) -> TeleopOutcome:
    """Run one teleoperated episode into ``writer`` until a save, discard, reset or quit.

    The world steps at the control rate (paced to wall-clock time when ``realtime``); when
    the evaluator decides (or the step cap is reached) stepping stops and the loop waits for
    the operator to save, discard or reset. ``save`` closes the writer (the caller commits it);
    every other outcome aborts it.
    """
    obs = env.reset(writer.seed)
    teleop.reset(env.world)
    verdict, done = Verdict(), False
    period = env.world.control_dt
    next_tick = time.perf_counter()
    with writer:
        while True:
            if stop() or not running():
                return TeleopOutcome("quit")
            event = teleop.pop_event()
            if event in ("discard", "reset"):
                return TeleopOutcome(event)
            if event == "save" and writer.num_steps:
                undecided = TRUNCATED if writer.num_steps >= max_steps else STOPPED
                summary = writer.close(
                    verdict, env.world.state(), sim_state(env.world.model, env.world.data), undecided=undecided
                )
                return TeleopOutcome("save", summary)
            if not done:
                with lock():
                    action = teleop.act(env.world)
                    writer.add(obs, action, sim_state(env.world.model, env.world.data))
                    obs, verdict = env.step(action)
                done = verdict.done or writer.num_steps >= max_steps
                if done and on_done is not None:
                    on_done(verdict)
            sync()
            if realtime:
                next_tick += period
                time.sleep(max(0.0, next_tick - time.perf_counter()))


def require_display() -> None:
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise PipetteError(
            "keyboard teleoperation needs a display (no DISPLAY or WAYLAND_DISPLAY); "
            "use --source scripted on a headless machine"
        )


def teleop_collect(
    task: TaskSpec,
    out: Path,
    *,
    episodes: int,
    seed: int = 0,
    image_size: int | None = None,
    sensitivity: float = SENSITIVITY,
    max_steps: int | None = None,
    on_start: Callable[[int, int], None] | None = None,
    on_episode: Callable[[EpisodeSummary], None] | None = None,
    on_done: Callable[[Verdict], None] | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> CollectResult:
    """Teleoperate ``task`` in the MuJoCo viewer until ``out`` holds ``episodes`` episodes.

    Same file rules as :func:`~pipette_cli.demos.collect.collect` (resume, seeds, atomic
    packing); a discarded episode uses up its seed, a reset one retries it; closing the viewer
    ends the session and keeps every saved episode.

    Raises:
        PipetteError: no display.
        DatasetError: ``out`` is unreadable or belongs to another task or image size.
    """
    require_display()
    out = Path(out)
    with writing(out):  # a second run on this file stops here
        status = scan(out)
        check_target(status, task, image_size)
        have = len(status.episodes)
        result = CollectResult(out, total=have)
        clean(status)
        if on_start is not None:
            on_start(have, max(0, episodes - have))
        if have >= episodes:
            pack(out)
            return result
        import mujoco.viewer  # deferred: glfw (~30 ms; needs a display)

        env = PipetteEnv(task, image_size=image_size)
        try:
            info = DatasetInfo.from_env(env)
            if status.info is not None and (why := status.info.mismatch(info)) is not None:
                raise DatasetError(f"cannot add to {out}: {why}")
            attrs = {
                **provenance(task),
                "model_sha256": model_sha256(env.world.model),
                "expert": f"{KeyboardTeleop.__module__}.KeyboardTeleop",
                "sensitivity": sensitivity,
            }
            teleop = KeyboardTeleop(env.world, sensitivity=sensitivity)
            used = set(status.seeds)
            current = plan_seeds(used, seed + have, 1)[0]
            cap = max_steps or step_cap(task)
            with mujoco.viewer.launch_passive(
                env.world.model, env.world.data, key_callback=teleop.on_key, show_left_ui=False, show_right_ui=False
            ) as viewer:
                while result.total < episodes:
                    index = result.total
                    writer = EpisodeWriter(
                        part_path(out, index), info, index=index, seed=current, source="teleop", attrs=attrs
                    )
                    outcome = teleop_episode(
                        env,
                        teleop,
                        writer,
                        max_steps=cap,
                        sync=viewer.sync,
                        running=viewer.is_running,
                        lock=viewer.lock,
                        stop=stop,
                        on_done=on_done,
                    )
                    if outcome.event == "quit":
                        result.interrupted = stop()
                        break
                    if outcome.event == "save":
                        assert outcome.summary is not None
                        writer.commit()
                        result.added.append(outcome.summary)
                        result.total += 1
                        if on_episode is not None:
                            on_episode(outcome.summary)
                    if outcome.event in ("save", "discard"):
                        used.add(current)
                        current = plan_seeds(used, current + 1, 1)[0]
        finally:
            env.close()
            clean(scan(out))
            pack(out)
        return result
