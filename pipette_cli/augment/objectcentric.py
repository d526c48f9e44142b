"""Object-centric adaptation of a joint-space demo to a moved object (as in MimicGen).

For every control step the TCP pose commanded by the recorded joint targets (forward
kinematics) is expressed in the object's frame at reset and carried to the object's new
frame: ``T'_k = T_obj' T_obj^-1 T_k``, blended in linearly over the first ``ramp`` steps
(the start pose belongs to the robot, not to the object). Damped least-squares IK
(:class:`~pipette_cli.sim.controllers.DifferentialIK`), warm started from the previous solution,
turns the new poses back into joint targets; the gripper command is kept.

Segments (MimicGen's subtasks, read off the task's skill program by :func:`destination`): up to
the grasp the demo belongs to the moved object. Where the program then takes the held object to a
site of another object (``place_on balance/pan_center``, ``insert_into rack/hole_3``), the rest
belongs to that object, which the variant does not move: once the fingers have closed
(:data:`HANDOFF_LAG_S`) the transform is blended back out over the first half of the carry, so the
descent and the release are the recorded ones. A task whose motion is all about the moved object
(a pick and lift, a lid, a tube taken off and set down beside where it stood) stays one segment.
Anything else is caught by the evaluator like every other variant.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from pipette_cli.augment.simulate import ObjectOffset
from pipette_cli.demos.recorder import SIM_STATE
from pipette_cli.sim.controllers import DifferentialIK
from pipette_cli.sim.world import World
from pipette_cli.specs.expert import StepSpec, TargetSpec

IK_ITERATIONS = 30
IK_DAMPING = 1e-3**0.5
"""Damping of the least-squares steps (their lambda; lambda squared 1e-3): the warm-started steps
between neighbouring poses are small, so they go uncapped."""
IK_TOLERANCE = 1e-5
"""Metres (and ten times as many radians) within which a re-targeted pose counts as reached."""
HANDOFF_LAG_S = 0.5
"""Seconds after the gripper command closes before the hand-off blend starts (the fingers close
while the hand stands still)."""


def destination(program: Sequence[StepSpec], name: str) -> str | None:
    """The object whose frame the held ``name`` is carried to by a task's skill ``program`` (the
    object of a ``target`` or ``to`` site; ``"bench"`` for a fixed point), or ``None`` where no step
    takes it anywhere. A target measured from ``name``'s own start stays in ``name``'s frame."""
    for step in program:
        if getattr(step, "object", None) != name:
            continue
        goal = getattr(step, "target", None) or getattr(step, "to", None)
        if isinstance(goal, str) and goal not in ("bench", "hold"):
            return goal.split("/", 1)[0]
        if isinstance(goal, TargetSpec):
            return "bench" if goal.at is None else goal.at.split("/", 1)[0]
    return None


def hands_over(program: Sequence[StepSpec], name: str) -> bool:
    """Whether the program carries ``name``, once held, to another object's frame (a second segment)."""
    return destination(program, name) not in (None, name)


def handoff_weights(gripper: np.ndarray, lag: int) -> np.ndarray | None:
    """Per step, the share of the object's transform kept after the grasp: 1 until ``lag`` steps
    after the first close, then down to 0 over half the steps left until the fingers open again;
    ``None`` where the demo never closes and opens the fingers in that order."""
    closed = gripper < 0.5
    shut = np.flatnonzero(closed[1:] & ~closed[:-1]) + 1
    if not len(shut):
        return None
    opened = np.flatnonzero(~closed[shut[0] :])
    if not len(opened):
        return None
    start, release = int(shut[0]) + lag, int(shut[0] + opened[0])
    span = max(1, (release - start) // 2)
    return np.clip(1.0 - (np.arange(len(gripper)) - start) / span, 0.0, 1.0)


def adapt_actions(
    world: World,
    seed: int,
    state0: np.ndarray,
    actions: np.ndarray,
    offset: ObjectOffset,
    ramp: int = 15,
    hand_off: bool = False,
) -> np.ndarray:
    """The demo's joint targets re-targeted to the object moved by ``offset`` (see module doc);
    ``hand_off``: the rest after the grasp belongs to an object that stays."""
    from scipy.spatial.transform import Rotation  # deferred: scipy (~0.1 s)

    world.reset(seed)
    mujoco.mj_setState(world.model, world.data, state0, SIM_STATE)
    mujoco.mj_forward(world.model, world.data)
    center = world.position(offset.name)
    ik = DifferentialIK(world, damping=IK_DAMPING, max_step=np.inf)  # its poses: the state at reset
    out = np.asarray(actions, dtype=np.float64).copy()
    q = out[0, :-1].copy()
    shift = np.array([offset.dx, offset.dy, 0.0])
    after = handoff_weights(out[:, -1], round(HANDOFF_LAG_S / world.control_dt)) if hand_off else None
    for k in range(len(out)):
        w = 1.0 if ramp <= 0 else min(1.0, k / ramp)
        if after is not None:
            w = min(w, float(after[k]))
        if w == 0.0:
            continue
        rz = Rotation.from_euler("z", offset.dyaw_deg * w, degrees=True).as_matrix()
        p, r = ik.tcp_pose(out[k, :-1])
        target = center + rz @ (p - center) + w * shift
        q = ik.solve(target, rz @ r, q if k else out[k, :-1], IK_ITERATIONS, IK_TOLERANCE).qpos
        out[k, :-1] = q
    return out
