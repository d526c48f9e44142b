"""Frames for skills: the canonical tool frame, rotations and interpolation (MuJoCo's quaternion
functions: 4-30x faster a call than scipy's ``Rotation`` objects on these hot paths).

Every robot's ``tcp`` site has the same frame (:mod:`pipette_cli.specs.robot`): z is the direction
the fingers point (the approach axis), y the direction they close along. A grasp is therefore
an approach vector and a closing vector, whatever the robot.
"""

from __future__ import annotations

import mujoco
import numpy as np

from pipette_cli.sim.quaternions import mat_to_quat, quat_to_mat

UP = np.array([0.0, 0.0, 1.0])


def unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise ValueError("zero-length vector")
    return np.asarray(v, dtype=float) / n


def tool_frame(approach: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """Rotation of the tcp whose z points along ``approach`` and whose y (the closing direction) is
    ``closing`` made perpendicular to it."""
    z = unit(approach)
    y = unit(closing - np.dot(closing, z) * z)
    return np.column_stack([np.cross(y, z), y, z])


def horizontal(v: np.ndarray) -> np.ndarray:
    return unit(np.array([v[0], v[1], 0.0]))


def down_frame(closing: np.ndarray) -> np.ndarray:
    """Fingers pointing straight down, closing along the horizontal direction ``closing``."""
    return tool_frame(-UP, horizontal(closing))


def pitched_frame(toward: np.ndarray, pitch_deg: float) -> np.ndarray:
    """Fingers pointing horizontally along ``toward``, tilted ``pitch_deg`` below the horizon (90 is
    straight down); they close along the horizontal perpendicular of ``toward``."""
    radial = horizontal(toward)
    th = np.deg2rad(pitch_deg)
    approach = np.cos(th) * radial - np.sin(th) * UP
    return tool_frame(approach, np.array([-radial[1], radial[0], 0.0]))


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` radians about ``axis``."""
    quat = np.empty(4)
    mujoco.mju_axisAngle2Quat(quat, unit(axis), angle)
    return quat_to_mat(quat)


def _turn(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Rotation vector, in ``q0``'s own frame, of the shorter turn taking ``q0`` to ``q1`` (an exact half
    turn, w == 0, is a half turn: ``mju_quat2Vel`` takes the angle from ``atan2``)."""
    rotvec = np.empty(3)
    mujoco.mju_subQuat(rotvec, q1, q0)
    return rotvec


def rotation_angle(r0: np.ndarray, r1: np.ndarray) -> float:
    """Angle in radians of the rotation taking ``r0`` to ``r1``."""
    return float(np.linalg.norm(_turn(mat_to_quat(r0), mat_to_quat(r1))))


def slerp(r0: np.ndarray, r1: np.ndarray, t: float) -> np.ndarray:
    """The rotation ``t`` (0 to 1) of the way from ``r0`` to ``r1`` along the shorter arc."""
    quat = mat_to_quat(r0)
    mujoco.mju_quatIntegrate(quat, _turn(quat, mat_to_quat(r1)), t)
    return quat_to_mat(quat)


def min_jerk(t: float) -> float:
    """Smooth 0 -> 1 time profile with zero velocity and acceleration at both ends."""
    t = min(1.0, max(0.0, t))
    return t**3 * (10 - 15 * t + 6 * t * t)
