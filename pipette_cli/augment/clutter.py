"""Distractor objects on the bench, where a demonstration's hand never goes (``distractors``).

Per demonstration, :func:`clutter_of` measures where the scene leaves room: the bench top, the
task's objects (their footprints, and every place a free one passes while it is carried) and
the hand's path below ``path_height``. :func:`place_distractors` draws the objects' places
there from the variant's random numbers; :func:`~pipette_cli.sim.distractors.with_distractors`
is the task with them added as scene objects, and :func:`transfer_state` carries a recorded
simulator state into that scene (joints, actuators and mocap bodies by name; the distractors
rest where they were put). An augmented episode records its distractors
(``augment_distractors``), so verifying or replaying it rebuilds the same scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from pipette_cli.augment.simulate import ObjectOffset, apply_offset
from pipette_cli.demos.recorder import SIM_STATE, sim_state
from pipette_cli.sim.distractors import Distractor
from pipette_cli.sim.scene import BENCH, collision_boxes
from pipette_cli.sim.world import World
from pipette_cli.specs.base import BENCH_TOP_Z
from pipette_cli.specs.perturbations import DistractorSpec

DISTRACTOR_RADIUS = 0.05
"""m, the footprint radius every distractor is given (the default assets are under 9 cm across)."""
HAND_RADIUS = 0.05
"""m, half the width of a gripper around its tool point."""
BASE_RADIUS = 0.2
"""m, kept clear around the robot's base."""


@dataclass(frozen=True)
class Clutter:
    """Where a demonstration leaves room on the bench."""

    bench: tuple[float, float, float, float]
    """x0, y0, x1, y1 of the bench top."""
    objects: list[tuple[float, float, float]]
    """(x, y, radius) of each task object at the start."""
    keep_out: np.ndarray
    """(n, 3): x, y, radius of every place the hand (low) or a carried object went."""
    base: tuple[float, float]


def clutter_of(world: World, states: np.ndarray, path_height: float = 0.25, every: int = 3) -> Clutter:
    """The room a demonstration (its recorded ``states`` in ``world``) leaves on the bench."""
    m, d = world.model, world.data
    mujoco.mj_setState(m, d, states[0], SIM_STATE)
    mujoco.mj_forward(m, d)
    names = [n for n in world.objects if n != "bench"]
    objects = []
    for name in names:
        size = world.bbox_xy(name)
        center = world.position(name)[:2]
        objects.append((float(center[0]), float(center[1]), 0.5 * math.hypot(*size)))
    free = [n for n in names if world.objects[n].free]
    points: list[tuple[float, float, float]] = []
    for state in states[::every]:
        mujoco.mj_setState(m, d, state, SIM_STATE)
        mujoco.mj_kinematics(m, d)
        tcp = d.site_xpos[world.tcp_site_id]
        if tcp[2] < BENCH_TOP_Z + path_height:
            points.append((float(tcp[0]), float(tcp[1]), HAND_RADIUS))
        for (_, _, radius), name in zip(objects, names, strict=True):
            if name in free:
                p = world.position(name)
                points.append((float(p[0]), float(p[1]), radius))
    bench = [b for b in range(m.nbody) if m.body(b).name.split("/", 1)[0] == BENCH]
    boxes = collision_boxes(m, d, np.flatnonzero(np.isin(m.geom_bodyid, bench)))
    top = boxes[np.abs(boxes[:, 5] - boxes[:, 5].max()) < 0.01]
    base = world.task.embodiment.base.pos
    return Clutter(
        (float(top[:, 0].min()), float(top[:, 1].min()), float(top[:, 3].max()), float(top[:, 4].max())),
        objects,
        np.asarray(points, dtype=np.float64).reshape(-1, 3),
        (float(base[0]), float(base[1])),
    )


def expert_path(world: World, seed: int, offset: ObjectOffset | None = None, limit: int = 3000) -> np.ndarray:
    """The simulator states of the task's scripted expert solving episode ``seed`` (the target
    moved by ``offset`` first): where a policy's hand would go, for an evaluation, which has no
    demonstration. Its success does not matter; its path does."""
    from pipette_cli.demos.experts.base import find_expert  # deferred: the skills, only for this

    world.reset(seed)
    if offset is not None:
        apply_offset(world, offset)
        mujoco.mj_forward(world.model, world.data)
        world.restart()
    expert = find_expert(world.task)[1]
    expert.reset(world, np.random.default_rng([seed, 1]))
    states = [sim_state(world.model, world.data)]
    while not world.verdict.done and world.step_count < limit:
        world.step(expert.act(world))
        states.append(sim_state(world.model, world.data))
    return np.stack(states)


def place_distractors(spec: DistractorSpec, clutter: Clutter, rng: np.random.Generator) -> list[Distractor]:
    """Up to ``spec.count`` distractors, each near a task object and clear of everything the
    demonstration uses and of each other (fewer when the bench has no more room: 200 draws each)."""
    placed: list[Distractor] = []
    x0, y0, x1, y1 = clutter.bench
    margin = DISTRACTOR_RADIUS + 0.02
    for _ in range(spec.count):
        for _ in range(200):
            ox, oy, radius = clutter.objects[int(rng.integers(len(clutter.objects)))]
            near = radius + spec.clearance + DISTRACTOR_RADIUS
            distance, angle = rng.uniform(near, max(near, spec.reach)), rng.uniform(0.0, 2 * math.pi)
            x, y = ox + distance * math.cos(angle), oy + distance * math.sin(angle)
            yaw = float(rng.uniform(-180.0, 180.0))
            asset = str(spec.assets[int(rng.integers(len(spec.assets)))])
            if (
                _clear(x, y, spec, clutter, placed)
                and x0 + margin <= x <= x1 - margin
                and y0 + margin <= y <= y1 - margin
            ):
                placed.append(Distractor(asset, round(x, 4), round(y, 4), round(yaw, 2)))
                break
    return placed


def _clear(x: float, y: float, spec: DistractorSpec, clutter: Clutter, placed: list[Distractor]) -> bool:
    gap = spec.clearance + DISTRACTOR_RADIUS
    if math.hypot(x - clutter.base[0], y - clutter.base[1]) < BASE_RADIUS + gap:
        return False
    if any(math.hypot(x - ox, y - oy) < r + gap for ox, oy, r in clutter.objects):
        return False
    if len(clutter.keep_out):
        dist = np.hypot(clutter.keep_out[:, 0] - x, clutter.keep_out[:, 1] - y) - clutter.keep_out[:, 2]
        if float(dist.min()) < gap:
            return False
    return all(math.hypot(x - p.x, y - p.y) >= 2 * DISTRACTOR_RADIUS + 0.01 for p in placed)


def transfer_state(source: World, state: np.ndarray, target: World, seed: int) -> np.ndarray:
    """``state`` of ``source`` as a state of ``target`` (the same scene plus distractors): every
    joint, actuator and mocap body by name; what ``source`` lacks as ``target`` resets it."""
    target.reset(seed)
    sm, sd, tm, td = source.model, source.data, target.model, target.data
    mujoco.mj_setState(sm, sd, state, SIM_STATE)
    td.time = sd.time
    for j in range(sm.njnt):
        t = _same(tm, mujoco.mjtObj.mjOBJ_JOINT, sm.joint(j).name)
        size = {0: 7, 1: 4}.get(int(sm.jnt_type[j]), 1)
        dofs = {0: 6, 1: 3}.get(int(sm.jnt_type[j]), 1)
        sq, tq, sv, tv = sm.jnt_qposadr[j], tm.jnt_qposadr[t], sm.jnt_dofadr[j], tm.jnt_dofadr[t]
        td.qpos[tq : tq + size] = sd.qpos[sq : sq + size]
        td.qvel[tv : tv + dofs] = sd.qvel[sv : sv + dofs]
        td.qacc_warmstart[tv : tv + dofs] = sd.qacc_warmstart[sv : sv + dofs]
    for a in range(sm.nu):
        t = _same(tm, mujoco.mjtObj.mjOBJ_ACTUATOR, sm.actuator(a).name)
        td.ctrl[t] = sd.ctrl[a]
        if sm.actuator_actadr[a] >= 0:
            td.act[tm.actuator_actadr[t] : tm.actuator_actadr[t] + sm.actuator_actnum[a]] = sd.act[
                sm.actuator_actadr[a] : sm.actuator_actadr[a] + sm.actuator_actnum[a]
            ]
    for b in range(sm.nbody):
        if sm.body_mocapid[b] >= 0:
            t = _same(tm, mujoco.mjtObj.mjOBJ_BODY, sm.body(b).name)
            td.mocap_pos[tm.body_mocapid[t]] = sd.mocap_pos[sm.body_mocapid[b]]
            td.mocap_quat[tm.body_mocapid[t]] = sd.mocap_quat[sm.body_mocapid[b]]
    for e in range(sm.neq):  # the task's equalities come before any a distractor could bring
        td.eq_active[_same(tm, mujoco.mjtObj.mjOBJ_EQUALITY, sm.eq(e).name) if sm.eq(e).name else e] = sd.eq_active[e]
    mujoco.mj_forward(tm, td)
    return sim_state(tm, td)


def _same(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    """The id of ``name`` in ``model``.

    Raises:
        ValueError: ``model`` has no such element (it is not the same scene plus distractors).
    """
    found = mujoco.mj_name2id(model, kind, name)
    if found < 0:
        raise ValueError(f"the scene with distractors has no {kind.name.removeprefix('mjOBJ_').lower()} {name!r}")
    return found
