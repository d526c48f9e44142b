"""End-effector control by damped least squares (paper A.5), shared by teleop and experts.

Delta q = J^T (J J^T + lambda^2 I)^-1 e with lambda = 0.05, where J is the 6 x n Jacobian of
the tool centre point over the arm joints and e stacks the position error and the rotation
error (axis-angle of R* R^T). It iterates on a scratch ``MjData`` so the simulation is never
disturbed, and keeps the result inside the joint limits.

We wrote this instead of using mink: the paper specifies exactly this solver and its
damping, it needs only the arm's columns of one Jacobian, and it runs per control step with
no QP solve; mink remains the better tool for multi-task IK with constraints.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from pipette_cli.sim.quaternions import mat_to_quat
from pipette_cli.sim.world import World

DAMPING = 0.05


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Axis-angle vector (world frame) rotating ``current`` onto ``target`` (3x3 matrices)."""
    axis_angle = np.empty(3)
    mujoco.mju_quat2Vel(axis_angle, mat_to_quat(target @ current.T), 1.0)  # an exact half turn (w == 0) is pi
    return axis_angle


@dataclass
class IKResult:
    qpos: np.ndarray
    position_error: float
    rotation_error: float
    iterations: int


class DifferentialIK:
    """Damped-least-squares IK for a world's arm, targeting its ``tcp`` site."""

    def __init__(self, world: World, damping: float = DAMPING, max_step: float = 0.2) -> None:
        self.world = world
        self.damping = damping
        self.max_step = max_step
        self.scratch = mujoco.MjData(world.model)
        self._jacp = np.zeros((3, world.model.nv))
        self._jacr = np.zeros((3, world.model.nv))

    def tcp_pose(self, qpos_arm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the tcp for arm joints ``qpos_arm`` (rest of the state as now)."""
        w, d = self.world, self.scratch
        d.qpos[:] = w.data.qpos
        d.qpos[w.arm_qpos_adr] = qpos_arm
        mujoco.mj_kinematics(w.model, d)
        return d.site_xpos[w.tcp_site_id].copy(), d.site_xmat[w.tcp_site_id].reshape(3, 3).copy()

    def solve(
        self,
        target_pos: np.ndarray,
        target_rot: np.ndarray | None = None,
        q_start: np.ndarray | None = None,
        iterations: int = 30,
        tolerance: float = 1e-4,
    ) -> IKResult:
        """Joint targets placing the tcp at ``target_pos`` (and ``target_rot`` if given)."""
        w, d = self.world, self.scratch
        q = np.array(w.arm_qpos() if q_start is None else q_start, dtype=float)
        lo, hi = w.arm_range[:, 0], w.arm_range[:, 1]
        pos_err = rot_err = np.inf
        for it in range(1, iterations + 1):
            pos, rot = self.tcp_pose(q)
            e_pos = target_pos - pos
            e_rot = rotation_error(target_rot, rot) if target_rot is not None else np.zeros(3)
            pos_err, rot_err = float(np.linalg.norm(e_pos)), float(np.linalg.norm(e_rot))
            if pos_err < tolerance and rot_err < 10 * tolerance:
                return IKResult(q, pos_err, rot_err, it - 1)
            mujoco.mj_comPos(w.model, d)
            mujoco.mj_jacSite(w.model, d, self._jacp, self._jacr, w.tcp_site_id)
            if target_rot is not None:
                jac = np.vstack([self._jacp[:, w.arm_dof_adr], self._jacr[:, w.arm_dof_adr]])
                err = np.concatenate([e_pos, e_rot])
            else:
                jac, err = self._jacp[:, w.arm_dof_adr], e_pos
            dq = jac.T @ np.linalg.solve(jac @ jac.T + self.damping**2 * np.eye(jac.shape[0]), err)
            scale = np.max(np.abs(dq)) / self.max_step
            if scale > 1.0:
                dq /= scale
            q = np.clip(q + dq, lo, hi)
        return IKResult(q, pos_err, rot_err, iterations)
