"""Physics first: restore a demo's start, run an action sequence without rendering, judge it.

A :class:`Rollout` holds everything the recorder needs except images: per control step the
action, the simulator state before it, the proprioceptive state and the time, plus the final
state and the evaluator's verdict. Images are rendered later, only for kept rollouts, from
these states (:mod:`.render`).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from pipette_cli.demos.recorder import SIM_STATE, sim_state
from pipette_cli.demos.store import EpisodeRecord
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.scene import euler_to_quat
from pipette_cli.sim.world import World


@dataclass(frozen=True)
class ObjectOffset:
    """A rigid move of one scene object at reset: translation (m) and yaw (deg) about its origin."""

    name: str
    dx: float
    dy: float
    dyaw_deg: float

    def as_dict(self) -> dict[str, float | str]:
        return {"object": self.name, "dx": self.dx, "dy": self.dy, "dyaw_deg": self.dyaw_deg}


@dataclass(frozen=True)
class Placement:
    """Where an object starts, and its task's nominal pose and randomisation range
    (``x, y`` in m, yaw in degrees from the nominal orientation): what ``object_pose`` with
    ``task_range`` places it within."""

    name: str
    start: tuple[float, float, float]
    nominal: tuple[float, float, float]
    span: tuple[float, float, float]


def wrap_deg(angle: float) -> float:
    """``angle`` in degrees, wrapped into [-180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def placement(world: World, name: str) -> Placement:
    """Where ``name`` stands in ``world`` now, with its task's nominal pose and randomisation range.

    Raises:
        KeyError: ``name`` is not an object of the task.
    """
    spec = next((o for o in world.task.scene.objects if o.name == name), None)
    if spec is None:
        raise KeyError(f"{world.task.id} has no object {name!r}")
    m, d = world.model, world.data
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, world.objects[name].root_body)
    if world.objects[name].free:
        adr = m.jnt_qposadr[m.body_jntadr[body]]
        pos, quat = d.qpos[adr : adr + 3], d.qpos[adr + 3 : adr + 7]
    else:
        pos, quat = m.body_pos[body], m.body_quat[body]
    # yaw about the vertical since the nominal orientation (reset turns the nominal pose by rz(yaw))
    turn, nominal_conj = np.zeros(4), np.zeros(4)
    mujoco.mju_negQuat(nominal_conj, euler_to_quat(spec.pose.euler_deg))
    mujoco.mju_mulQuat(turn, np.asarray(quat, dtype=np.float64), nominal_conj)
    yaw = float(np.degrees(2 * np.arctan2(turn[3], turn[0])))
    randomize = spec.randomize
    span = (0.0, 0.0, 0.0) if randomize is None else (*randomize.xy, randomize.yaw_deg)
    nominal = (spec.pose.pos[0], spec.pose.pos[1], 0.0)
    return Placement(name, (float(pos[0]), float(pos[1]), wrap_deg(yaw)), nominal, span)


@dataclass
class Rollout:
    """One simulated episode without images (the recorder's rows, paper A.3)."""

    actions: np.ndarray
    states: np.ndarray
    obs_state: np.ndarray
    sim_time: np.ndarray
    wall_time: np.ndarray
    final_state: np.ndarray
    final_sim_state: np.ndarray
    verdict: Verdict
    instruction: list[str]
    """Each step's language instruction (a protocol's stage instruction)."""
    stage: np.ndarray
    """Stages completed before each step."""
    instrument: np.ndarray
    """Instrument values before each step, ``(T, len(World.instrument_names))``."""
    executed: np.ndarray | None = None
    """The actions the simulation ran, where they differ from the recorded ``actions`` (corrective
    joint noise records the clean targets); None: ``actions`` ran."""

    @property
    def applied(self) -> np.ndarray:
        """The actions that reproduce ``states`` (what ran)."""
        return self.actions if self.executed is None else self.executed

    def relabelled(self, labels: np.ndarray) -> Rollout:
        """This rollout recording ``labels`` as its actions, keeping what ran as ``executed``.
        ``labels`` follows the actions given to :func:`simulate`: held at its last row through the
        settle steps, cut where the evaluator decided."""
        rows = np.minimum(np.arange(self.num_steps), len(labels) - 1)
        return replace(self, actions=np.asarray(labels)[rows], executed=self.applied)

    @classmethod
    def from_record(cls, record: EpisodeRecord) -> Rollout:
        """The recorded physics of an episode (used as is by light/camera-only variants)."""
        a = record.arrays
        s = record.summary
        verdict = Verdict(success=s.success, failed=not s.success, reason=s.reason or None, metrics=dict(s.metrics))
        steps = len(a["action"])
        instruction = [t.decode() if isinstance(t, bytes) else str(t) for t in a["instruction"]]
        return cls(
            actions=a["action"],
            states=a["sim_state"],
            obs_state=a["state"],
            sim_time=a["sim_time"],
            wall_time=a["wall_time"],
            final_state=a["final_state"],
            final_sim_state=a["final_sim_state"],
            verdict=verdict,
            instruction=instruction,
            stage=a.get("stage", np.zeros(steps, dtype=np.int32)),
            instrument=a.get("instrument_state", np.zeros((steps, 0))),
            executed=a.get("executed_action"),
        )

    @property
    def num_steps(self) -> int:
        return len(self.actions)


def apply_offset(world: World, offset: ObjectOffset) -> None:
    """Move ``offset.name`` after ``world.reset``: free bodies through qpos, fixed ones through ``model.body_pos``."""
    m, d = world.model, world.data
    info = world.objects[offset.name]
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, info.root_body)
    rot = euler_to_quat((0.0, 0.0, offset.dyaw_deg))
    if info.free:
        adr = m.jnt_qposadr[m.body_jntadr[body]]
        d.qpos[adr : adr + 2] += (offset.dx, offset.dy)
        quat = np.zeros(4)
        mujoco.mju_mulQuat(quat, rot, d.qpos[adr + 3 : adr + 7].copy())
        d.qpos[adr + 3 : adr + 7] = quat
    else:
        m.body_pos[body, :2] += (offset.dx, offset.dy)
        quat = np.zeros(4)
        mujoco.mju_mulQuat(quat, rot, m.body_quat[body].copy())
        m.body_quat[body] = quat


def restore(world: World, seed: int, state0: np.ndarray, offset: ObjectOffset | None = None) -> None:
    """Reset ``world`` to a recorded start: ``reset(seed)``, the object offset, ``mj_setState(state0)``.

    Mechanisms and the evaluator are reset again from the restored state, so a moved object
    is judged relative to where it now starts.
    """
    world.reset(seed)
    if offset is not None:
        apply_offset(world, offset)
    mujoco.mj_setState(world.model, world.data, state0, SIM_STATE)
    mujoco.mj_forward(world.model, world.data)
    if offset is not None:
        world.restart()


def start_state(world: World, seed: int, state0: np.ndarray, offset: ObjectOffset | None) -> np.ndarray:
    """The state an (optionally offset) rollout starts from: ``state0`` with the object moved."""
    world.reset(seed)
    if offset is None:
        return np.asarray(state0, dtype=np.float64).copy()
    mujoco.mj_setState(world.model, world.data, state0, SIM_STATE)
    apply_offset(world, offset)
    mujoco.mj_forward(world.model, world.data)
    return sim_state(world.model, world.data)


def simulate(
    world: World,
    seed: int,
    state0: np.ndarray,
    actions: np.ndarray,
    *,
    settle_steps: int = 0,
    offset: ObjectOffset | None = None,
) -> Rollout:
    """Run ``actions`` from a restored start until the evaluator decides; no rendering.

    When the actions run out before a decision the last one is held for up to
    ``settle_steps`` more control steps (recorded like the others).
    """
    start = start_state(world, seed, state0, offset)
    restore(world, seed, start, offset)
    m, d = world.model, world.data
    rows_a, rows_s, rows_q, rows_t, rows_w = [], [], [], [], []
    rows_text, rows_stage, rows_inst = [], [], []
    verdict = Verdict()
    wall0 = time.perf_counter()
    total = len(actions) + settle_steps
    for k in range(total):
        action = np.asarray(actions[min(k, len(actions) - 1)], dtype=np.float64)
        rows_a.append(action)
        rows_s.append(sim_state(m, d))
        rows_q.append(world.state())
        rows_t.append(world.time)
        rows_w.append(time.perf_counter() - wall0)
        rows_text.append(world.instruction())
        rows_stage.append(world.stage)
        rows_inst.append(world.instrument_state())
        verdict = world.step(action)
        if verdict.done:
            break
    return Rollout(
        actions=np.stack(rows_a),
        states=np.stack(rows_s),
        obs_state=np.stack(rows_q),
        sim_time=np.asarray(rows_t),
        wall_time=np.asarray(rows_w),
        final_state=world.state(),
        final_sim_state=sim_state(m, d),
        verdict=verdict,
        instruction=rows_text,
        stage=np.asarray(rows_stage, dtype=np.int32),
        instrument=np.stack(rows_inst),
    )


def replay_check(world: World, seed: int, rollout: Rollout, offset: ObjectOffset | None = None) -> str | None:
    """Re-run a rollout's actions from its first state; ``None`` when every state matches bit for
    bit and the episode succeeds, else why not."""
    restore(world, seed, rollout.states[0], offset)
    expected = [*rollout.states[1:], rollout.final_sim_state]
    verdict = Verdict()
    for k, action in enumerate(rollout.applied):
        verdict = world.step(action)
        now = sim_state(world.model, world.data)
        if now.tobytes() != np.asarray(expected[k], dtype=np.float64).tobytes():
            return f"replay differs from the recording at step {k + 1}"
    if not verdict.success:
        return f"replay does not succeed ({verdict.reason or 'undecided'})"
    return None


def settle_steps(world: World, settle_s: float) -> int:
    return math.ceil(settle_s / world.control_dt)


def offset_from_attrs(attrs: dict[str, object]) -> ObjectOffset | None:
    """The object offset an augmented episode was recorded with (``augment_object_offset``)."""
    raw = attrs.get("augment_object_offset")
    data = json.loads(str(raw)) if raw else {}
    return ObjectOffset(data["object"], data["dx"], data["dy"], data["dyaw_deg"]) if data else None
