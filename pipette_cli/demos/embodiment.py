"""Run a task on another robot: the robot's home pose and wrist camera, a base pose it reaches from.

``on_robot(task, "ur5e_2f85")`` returns the task with ``embodiment`` (and the wrist camera, when it
is mounted on the hand) taken from the robot's facts (``registry/robots/``). The task's skill
program is robot-agnostic and runs unchanged. Where the task's base pose leaves a point the program
works at out of the robot's comfortable reach (hand-down reach for what it picks up, its full
reach for the rest), the base slides along the bench (x first: toward or away from the work area;
then sideways) to the nearest pose on the bench top, clear of every object, from which all work
points are. A robot that physically cannot do the task (payload, reach from any
base pose on the bench) is refused with :class:`~pipette_cli.errors.InfeasibleTask` naming the limit.

The result depends on the task and the robot only, so ``on_robot(task, file's embodiment)`` rebuilds
the scene an episode was recorded in (``pipette data replay``, ``pipette augment``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import mujoco
import numpy as np

from pipette_cli.demos.experts.base import expert_program
from pipette_cli.errors import InfeasibleTask, SimError, SpecError
from pipette_cli.sim.scene import ROBOT_PREFIX, collision_boxes, compile_scene, make_scene_spec, robot_boxes
from pipette_cli.skills.frames import UP
from pipette_cli.skills.moves import COVER_ROOM, SHIFT_STEP, SHIFTS
from pipette_cli.specs.base import PoseSpec
from pipette_cli.specs.robot import RobotSpec, robot_spec
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

COMFORT = 0.9
"""Work points stay within this fraction of the robot's stated reach from its base axis."""
CLEARANCE = 0.02
"""Metres kept between the robot's base footprint and any object's collision geometry."""
STEP = 0.025
"""Grid step (metres) of the base poses tried."""
MAX_SHIFT = 0.6
"""Farthest the base moves from the task's own base pose, metres."""
LOW = 0.1
"""Metres over the bench top below which a picked object counts against the hand-down reach."""
HOLDING_SKILLS = ("pick", "remove_from")
"""Skills whose ``object`` the robot carries (its mass counts against the payload)."""


@dataclass(frozen=True)
class Workspace:
    """What the base placement needs of a compiled scene: the program's work points (x, y, z), every
    object's collision boxes (n, 6), the bench top's extent (x0, y0, x1, y1), the carried masses and
    what of that is pinched at its rim, the hand pitched (not taken from above)."""

    points: dict[str, np.ndarray]
    boxes: np.ndarray
    bench: tuple[float, float, float, float]
    carried: dict[str, float]
    pinched: frozenset[str] = frozenset()


def resolve_robot(name: str) -> RobotSpec:
    """The robot called ``name`` (registry id or alias). Raises :class:`SimError` listing the robots."""
    try:
        return robot_spec(name)
    except SpecError as exc:
        raise SimError(str(exc)) from None


def on_robot(task: TaskSpec, robot: str | None) -> TaskSpec:
    """``task`` with ``robot`` standing at the bench (``None`` or the task's own robot: unchanged).

    Raises:
        SimError: unknown robot.
        InfeasibleTask: the robot cannot do the task (a payload or reach limit, named).
    """
    if robot is None:
        return task
    config = resolve_robot(robot)
    if config.name == task.embodiment.robot:
        return task
    moved = _with_robot(task, config, task.embodiment.base, config.arm.home)
    space = measure_workspace(moved)
    check_payload(moved, config, space)
    base, joints = reachable_base(moved, config, space)
    if base != moved.embodiment.base:
        log.info(
            "%s on the %s: base moved from %s to %s so the work points are within %.0f %% of its %.2f m reach",
            task.id,
            config.name,
            _fmt(task.embodiment.base.pos),
            _fmt(base.pos),
            100 * COMFORT,
            config.reach,
        )
    if joints != config.arm.home:
        log.info("%s on the %s: starts stowed (its home pose would touch the scene there)", task.id, config.name)
    if base != moved.embodiment.base or joints != config.arm.home:
        moved = _with_robot(task, config, base, joints)
    return moved


def _with_robot(task: TaskSpec, config: RobotSpec, base: PoseSpec, joints: list[float]) -> TaskSpec:
    data = task.model_dump(mode="json")
    data["embodiment"] = {
        "robot": config.name,
        "base": base.model_dump(mode="json"),
        "initial_joints": list(joints),
        "gripper": task.embodiment.gripper,
    }
    if task.cameras.wrist.mount == "end_effector":
        data["cameras"]["wrist"] = {"mount": "end_effector", **config.wrist_camera.model_dump(mode="json")}
    return TaskSpec.model_validate(data)


def _fmt(pos: tuple[float, ...]) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in pos[:2]) + ")"


def measure_workspace(task: TaskSpec) -> Workspace:
    """Compile the task's scene at its nominal poses and read the program's work points, the
    objects' collision boxes and the masses of what the program carries."""
    from pipette_cli.skills.grasp import pinched  # deferred: mink, scipy (~0.26 s)

    spec, _, objects = make_scene_spec(task)
    model = compile_scene(spec, task)
    data = mujoco.MjData(model)
    for state in task.scene.joint_states:  # a lid that starts open stands where it starts
        joint = model.joint(state.joint)
        hinge = joint.type[0] == mujoco.mjtJoint.mjJNT_HINGE
        data.qpos[joint.qposadr[0]] = np.deg2rad(state.value) if hinge else state.value
    mujoco.mj_forward(model, data)
    steps, _ = expert_program(task)
    refs = {ref for step in steps for _, ref in step.refs()} | {ref for _, ref in task.success.refs()}
    refs |= set(task.targets)
    points: dict[str, np.ndarray] = {}
    for ref in sorted(refs):
        pos = _position(model, data, ref, objects)
        if pos is not None:
            points[ref] = pos
    owners = np.array([model.body(b).name.split("/", 1)[0] for b in model.geom_bodyid])
    bench_boxes = collision_boxes(model, data, np.flatnonzero(owners == "bench"))
    top = bench_boxes[bench_boxes[:, 5] > task.embodiment.base.pos[2] - 0.01]  # the top slab, not the legs
    bench = (float(top[:, 0].min()), float(top[:, 1].min()), float(top[:, 3].max()), float(top[:, 4].max()))
    boxes = collision_boxes(model, data, np.flatnonzero(np.isin(owners, [o.name for o in task.scene.objects])))
    carried: dict[str, float] = {}
    held_boxes: dict[str, np.ndarray] = {}  # each carried object's collision boxes
    pinches = set()
    for step in steps:
        name = getattr(step, "object", None)
        if step.skill in HOLDING_SKILLS and name in objects:
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, objects[name].root_body)
            carried[name] = float(model.body_subtreemass[body])
            if name not in held_boxes:
                held_boxes[name] = collision_boxes(model, data, np.flatnonzero(owners == name))
            held = held_boxes[name]
            if len(held):
                size = held[:, 3:].max(axis=0) - held[:, :3].min(axis=0)
                if pinched(size[2], size[:2], getattr(step, "grasp", "auto"), getattr(step, "at", None)):
                    pinches.add(name)
    for step in steps:  # a spot inside an enclosure: set down at its front, through its mouth
        target, name = getattr(step, "target", None), getattr(step, "object", None)
        if step.skill == "place_on" and isinstance(target, str) and target in points and name in carried:
            held = held_boxes[name]
            half = float(np.max(held[:, 3:5] - held[:, :2])) / 2 if len(held) else 0.05
            front = _enclosure_front(model, data, points[target], np.asarray(task.embodiment.base.pos), half)
            if front is not None:
                points[target], points[f"{target} (entry)"] = front
    return Workspace(points, boxes, bench, carried, frozenset(pinches))


def _enclosure_front(
    model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray, base: np.ndarray, half: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """For a spot under a roof (a shelf in an incubator), where an object of half-size ``half`` is set
    down (as near the mouth as ``place_on`` shifts it toward the robot) and where the hand enters,
    the object clear of the mouth; ``None`` for a spot in the open."""
    toward = base - point
    toward[2] = 0.0
    toward /= np.linalg.norm(toward) + 1e-12
    if not _overhead(model, data, point):
        return None
    mouth = next((s for s in np.arange(0.0, 1.0, 0.01) if not _overhead(model, data, point + s * toward)), 1.0)
    inside = point + float(np.clip(mouth - half - 0.01, 0.0, SHIFT_STEP * SHIFTS)) * toward
    return inside, point + (mouth + half + 0.04) * toward


def _overhead(model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray) -> bool:
    """Whether scene geometry (not the robot's) is within ``COVER_ROOM`` above ``point``."""
    start, geom = np.asarray(point, float) + 0.01 * UP, np.zeros(1, dtype=np.int32)
    for _ in range(8):
        dist = mujoco.mj_ray(model, data, start, UP, None, 1, -1, geom)
        if dist < 0 or start[2] + dist - point[2] > COVER_ROOM:
            return False
        if not model.body(model.geom_bodyid[geom[0]]).name.startswith(ROBOT_PREFIX):
            return True
        start = start + (dist + 0.001) * UP  # through the robot's arm
    return False


def _position(model: mujoco.MjModel, data: mujoco.MjData, ref: str, objects: dict) -> np.ndarray | None:
    """Where the hand works for ``ref``: a free object's origin, a site, a body, the centre of mass of
    a joint's moving part (a lid, not its hinge axis); None for a whole fixed object (an instrument
    counts where the program names a part of it)."""
    obj, _, part = ref.partition("/")
    if obj not in objects:
        return None
    if not part:
        if not objects[obj].free:
            return None
        return data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, objects[obj].root_body)].copy()
    for kind, table in ((mujoco.mjtObj.mjOBJ_SITE, data.site_xpos), (mujoco.mjtObj.mjOBJ_BODY, data.xpos)):
        index = mujoco.mj_name2id(model, kind, ref)
        if index >= 0:
            return table[index].copy()
    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, ref)
    if index >= 0:
        return data.xipos[model.jnt_bodyid[index]].copy()
    return None


def check_payload(task: TaskSpec, config: RobotSpec, space: Workspace) -> None:
    """Refuse a task whose program carries an object heavier than the robot's payload."""
    for name, mass in space.carried.items():
        if mass > config.payload_kg:
            raise InfeasibleTask(
                f"{task.id} on the {config.name}: payload: {name!r} weighs {mass:.2f} kg, "
                f"over the robot's {config.payload_kg:.2f} kg payload"
            )


def reachable_base(task: TaskSpec, config: RobotSpec, space: Workspace) -> tuple[PoseSpec, list[float]]:
    """The task's base pose if every work point is within ``COMFORT`` of the robot's reach (and no
    closer than its ``min_reach``), else the nearest such pose on the bench top clear of the objects;
    with the arm joints the robot starts in there: its home pose, or its stow pose (``arm.stow``)
    where the home pose's arm would come within ``CLEARANCE`` of an object.

    Raises:
        InfeasibleTask: no base pose on the bench reaches every work point.
    """
    home = np.asarray(task.embodiment.base.pos, dtype=float)
    offsets = np.round(np.arange(-MAX_SHIFT, MAX_SHIFT + 1e-9, STEP), 6)
    grid = np.array([(dx, dy) for dx in offsets for dy in offsets])
    grid = grid[np.argsort(np.abs(grid[:, 0]) + 2.0 * np.abs(grid[:, 1]) + 1e-6 * np.arange(len(grid)), kind="stable")]
    points3 = np.array(list(space.points.values())).reshape(-1, 3)
    # what the program picks up off the bench top is grasped from above: the hand-down reach applies
    # (not to a flat object pinched at its rim, the hand pitched)
    low = points3[:, 2] < home[2] + LOW
    from_above = np.isin(list(space.points), list(set(space.carried) - space.pinched))
    limit = COMFORT * np.where(low & from_above, config.top_down_reach, config.reach)
    points = points3[:, :2]
    r = config.footprint_radius
    x0, y0, x1, y1 = space.bench
    poses = [config.arm.home] + ([config.arm.stow] if config.arm.stow is not None else [])
    arms = []
    for joints in poses:
        arm = robot_boxes(config.name, tuple(home), tuple(joints))
        arms.append((joints, arm[arm[:, 5] > home[2] + 0.002]))  # the arm above the bench top
    best_miss = (np.inf, "")
    for dx, dy in grid:
        xy = home[:2] + (dx, dy)
        if not (x0 + r <= xy[0] <= x1 - r and y0 + r <= xy[1] <= y1 - r):
            continue
        if len(space.boxes) and _box_distance(space.boxes, xy).min() < r + CLEARANCE:
            continue
        clear = [
            j for j, arm in arms if not len(space.boxes) or not _overlap(arm + [dx, dy, 0.0, dx, dy, 0.0], space.boxes)
        ]
        if not clear:
            continue
        dist = np.linalg.norm(points - xy, axis=1)
        far = dist - limit
        near = config.min_reach - dist
        worst = max(far.max(initial=-np.inf), near.max(initial=-np.inf))
        if worst <= 0:
            if dx == 0 and dy == 0:
                return task.embodiment.base, list(clear[0])
            return PoseSpec(
                pos=(round(float(xy[0]), 4), round(float(xy[1]), 4), float(home[2])),
                euler_deg=task.embodiment.base.euler_deg,
            ), list(clear[0])
        if worst < best_miss[0]:
            i = int(np.argmax(np.maximum(far, near)))
            best_miss = (worst, f"{list(space.points)[i]} is {dist[i]:.2f} m away")
    raise InfeasibleTask(
        f"{task.id} on the {config.name}: reach: no base pose on the bench puts every work point between "
        f"{config.min_reach:.2f} m and {100 * COMFORT:.0f} % of its reach ({config.reach:.2f} m; "
        f"{config.top_down_reach:.2f} m hand down, for what it picks up) from the base (best: {best_miss[1]})"
    )


def reach_problems(task: TaskSpec, config: RobotSpec, space: Workspace) -> list[tuple[str, str]]:
    """``(work point, why)`` for each work point of ``space`` out of the robot's reach from the task's
    own base: farther than its ``reach`` or nearer than its ``min_reach`` (the hard limits; where
    :func:`reachable_base` places a robot it keeps inside them by a margin, and takes what it picks
    up from above within its ``top_down_reach``, a limit the grasp pitches the hand past)."""
    base = np.asarray(task.embodiment.base.pos[:2], dtype=float)
    out = []
    for ref, point in space.points.items():
        dist = float(np.linalg.norm(point[:2] - base))
        where = f"{ref!r} is {dist:.2f} m from the {config.name} base axis"
        if dist > config.reach:
            out.append((ref, f"{where}, beyond its {config.reach:.2f} m reach"))
        elif dist < config.min_reach:
            out.append((ref, f"{where}, inside its {config.min_reach:.2f} m minimum reach"))
    return out


def _box_distance(boxes: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Horizontal distance from ``xy`` to each box (0 inside)."""
    nearest = np.clip(xy, boxes[:, :2], boxes[:, 3:5])
    return np.linalg.norm(nearest - xy, axis=1)


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether any box of ``a`` comes within :data:`CLEARANCE` of any box of ``b`` (n, 6 each)."""
    lo = np.maximum(a[:, None, :3], b[None, :, :3])
    hi = np.minimum(a[:, None, 3:], b[None, :, 3:])
    return bool(np.any(np.all(hi - lo > -CLEARANCE, axis=2)))
