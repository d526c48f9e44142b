"""Object-centric adaptation of a joint-space demo to a moved object (as in MimicGen).

For every control step the TCP pose commanded by the recorded joint targets (forward
kinematics) is expressed in the object's frame at reset and carried to the object's new
frame: ``T'_k = T_obj' T_obj^-1 T_k``, blended in linearly over the first ``ramp`` steps
(the start pose belongs to the robot, not to the object). Damped least-squares IK, warm
started from the previous solution, turns the new poses back into joint targets; the gripper
command is kept. The whole demo is treated as one object-centric segment: right for tasks
whose motion is all about the moved object (pick, lift, lids); anything else is caught by the
evaluator like every other variant.
"""

from __future__ import annotations

import mujoco
import numpy as np

from pipette_cli.augment.simulate import ObjectOffset
from pipette_cli.demos.recorder import SIM_STATE
from pipette_cli.sim.world import World

IK_ITERATIONS = 30
IK_DAMPING = 1e-3


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.deg2rad(deg)), np.sin(np.deg2rad(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _fk(world: World, data: mujoco.MjData, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    data.qpos[world.arm_qpos_adr] = q
    mujoco.mj_kinematics(world.model, data)
    return data.site_xpos[world.tcp_site_id].copy(), data.site_xmat[world.tcp_site_id].reshape(3, 3).copy()


def _ik(world: World, data: mujoco.MjData, q0: np.ndarray, pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
    m = world.model
    q = q0.copy()
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    cols = world.arm_dof_adr
    for _ in range(IK_ITERATIONS):
        p, r = _fk(world, data, q)
        err_p = pos - p
        quat_err, q_now, q_want = np.zeros(3), np.zeros(4), np.zeros(4)
        mujoco.mju_mat2Quat(q_now, r.ravel())
        mujoco.mju_mat2Quat(q_want, rot.ravel())
        mujoco.mju_subQuat(quat_err, q_want, q_now)
        err_r = r @ quat_err  # mju_subQuat gives a local-frame rotation vector
        err = np.concatenate([err_p, err_r])
        if np.linalg.norm(err_p) < 1e-5 and np.linalg.norm(err_r) < 1e-4:
            break
        mujoco.mj_comPos(m, data)
        mujoco.mj_jacSite(m, data, jacp, jacr, world.tcp_site_id)
        jac = np.vstack([jacp[:, cols], jacr[:, cols]])
        dq = jac.T @ np.linalg.solve(jac @ jac.T + IK_DAMPING * np.eye(6), err)
        q = np.clip(q + dq, world.arm_range[:, 0], world.arm_range[:, 1])
    return q


def adapt_actions(
    world: World, seed: int, state0: np.ndarray, actions: np.ndarray, offset: ObjectOffset, ramp: int = 15
) -> np.ndarray:
    """The demo's joint targets re-targeted to the object moved by ``offset`` (see module doc)."""
    world.reset(seed)
    mujoco.mj_setState(world.model, world.data, state0, SIM_STATE)
    mujoco.mj_forward(world.model, world.data)
    center = world.position(offset.name)
    data = mujoco.MjData(world.model)
    mujoco.mj_setState(world.model, data, state0, SIM_STATE)
    out = np.asarray(actions, dtype=np.float64).copy()
    q = out[0, :-1].copy()
    shift = np.array([offset.dx, offset.dy, 0.0])
    for k in range(len(out)):
        w = 1.0 if ramp <= 0 else min(1.0, k / ramp)
        if w == 0.0:
            continue
        rz = _rz(offset.dyaw_deg * w)
        p, r = _fk(world, data, out[k, :-1])
        q = _ik(world, data, q if k else out[k, :-1], center + rz @ (p - center) + w * shift, rz @ r)
        out[k, :-1] = q
    return out
