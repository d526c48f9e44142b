"""Skill frames: rotations and interpolation through MuJoCo's quaternion functions, checked against
closed forms (mink's SO3 was tried: its log of a half turn whose quaternion has w == 0 exactly is zero,
and the skills build exact half turns: a parallel gripper's flip)."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.sim.controllers import rotation_error
from pipette_cli.skills.frames import axis_rotation, rotation_angle, slerp


def about_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_axis_rotation_is_the_closed_form_about_any_axis_length() -> None:
    np.testing.assert_allclose(axis_rotation(np.array([0.0, 0.0, 3.0]), 0.7), about_z(0.7), atol=1e-12)
    r = axis_rotation(np.array([1.0, 2.0, -1.0]), 2.5)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r @ np.array([1.0, 2.0, -1.0]), [1.0, 2.0, -1.0], atol=1e-12)  # the axis stays


def test_rotation_angle_is_the_angle_between_two_frames() -> None:
    base = axis_rotation(np.array([0.3, -1.0, 0.2]), 1.1)
    for angle in (0.0, 1e-7, 0.4, 3.0):
        assert rotation_angle(base, base @ axis_rotation(np.array([1.0, 1.0, 0.0]), angle)) == pytest.approx(
            angle, abs=1e-12
        )


def test_slerp_runs_at_constant_rate_along_the_shorter_arc() -> None:
    r0, r1 = about_z(0.2), about_z(0.2 + 1.2)
    np.testing.assert_allclose(slerp(r0, r1, 0.0), r0, atol=1e-12)
    np.testing.assert_allclose(slerp(r0, r1, 1.0), r1, atol=1e-12)
    np.testing.assert_allclose(slerp(r0, r1, 0.25), about_z(0.2 + 0.3), atol=1e-12)
    # 300 degrees one way is 60 the other: the halfway frame is 30 degrees back
    np.testing.assert_allclose(slerp(about_z(0.0), about_z(np.deg2rad(300)), 0.5), about_z(np.deg2rad(-30)), atol=1e-12)


def test_rotation_error_is_the_world_axis_angle_from_current_to_target() -> None:
    current = axis_rotation(np.array([0.0, 1.0, 1.0]), 0.5)
    turn = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(rotation_error(axis_rotation(turn, np.linalg.norm(turn)) @ current, current), turn)


def test_an_exact_half_turn_is_half_a_turn() -> None:
    r = axis_rotation(np.array([0.2, 0.1, 1.0]), 0.3)
    flipped = r @ np.diag([-1.0, -1.0, 1.0])  # the gripper's flip about its approach axis
    assert rotation_angle(r, flipped) == pytest.approx(np.pi)
    assert rotation_angle(r, slerp(r, flipped, 0.5)) == pytest.approx(np.pi / 2)
    assert np.linalg.norm(rotation_error(flipped, r)) == pytest.approx(np.pi)
