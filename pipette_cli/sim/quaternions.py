"""Rotation matrices and MuJoCo's (w, x, y, z) quaternions, one home for the conversions (MuJoCo's
own ``mju_mat2Quat`` and ``mju_quat2Mat``: exact at half turns, a few microseconds a call)."""

from __future__ import annotations

import mujoco
import numpy as np


def mat_to_quat(mat: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of the 3x3 rotation ``mat``."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(mat, dtype=float).reshape(9))
    return quat


def quat_to_mat(quat: np.ndarray) -> np.ndarray:
    """The 3x3 rotation of the unit quaternion ``quat`` (w, x, y, z)."""
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float))
    return mat.reshape(3, 3)
