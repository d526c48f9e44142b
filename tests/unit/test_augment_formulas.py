"""The formulas of paper A.7, pinned one by one."""

from __future__ import annotations

import numpy as np
import pytest

from pipette_cli.augment import formulas as f


def test_catmull_rom_passes_through_its_knots_and_is_exact_on_lines() -> None:
    rng = np.random.default_rng(0)
    knots = rng.normal(size=(12, 3))
    np.testing.assert_allclose(f.catmull_rom(knots, np.arange(12.0)), knots, atol=1e-12)
    line = np.arange(10.0)[:, None] * [0.5, -2.0]
    x = np.linspace(1.0, 8.0, 29)  # interior: the spline reproduces a straight line
    np.testing.assert_allclose(f.catmull_rom(line, x), x[:, None] * [0.5, -2.0], atol=1e-12)


def test_catmull_rom_matches_the_paper_polynomial_between_knots() -> None:
    p = np.array([[0.0], [1.0], [4.0], [2.0], [5.0]])
    t = 0.3
    expected = 0.5 * (2 * 1.0 + (-0.0 + 4.0) * t + (0 - 5 * 1 + 4 * 4 - 2) * t**2 + (-0 + 3 * 1 - 3 * 4 + 2) * t**3)
    assert f.catmull_rom(p, np.array([1.3]))[0, 0] == pytest.approx(expected)
    assert f.linear(p, np.array([1.25]))[0, 0] == pytest.approx(1.75)


def test_smoothed_noise_is_normalised() -> None:
    eps = f.smoothed_noise(np.random.default_rng(1), 500, 11)
    assert eps.shape == (500,)
    assert abs(eps.mean()) < 1e-12 and eps.std() == pytest.approx(1.0)
    assert np.corrcoef(eps[:-1], eps[1:])[0, 1] > 0.8  # smoothed: neighbours correlate


@pytest.mark.parametrize("s_v", [0.5, 1.2, 3.0])
def test_warp_positions_stay_within_bounds(s_v: float) -> None:
    x = f.warp_positions(200, s_v, np.random.default_rng(2), rho=5.0)  # huge rho: the clip bites
    steps = np.diff(x)
    assert x[0] == 0.0 and x[-1] == 199.0
    assert np.all(steps > 0)
    assert np.all(steps[:-1] >= 0.2 * s_v - 1e-12) and np.all(steps[:-1] <= 3.0 * s_v + 1e-12)
    assert steps[-1] <= 3.0 * s_v + 1e-12


def test_warp_without_noise_is_uniform_time_scaling() -> None:
    x = f.warp_positions(97, 1.2, np.random.default_rng(3), rho=0.0)
    np.testing.assert_allclose(x[:-1], 1.2 * np.arange(len(x) - 1))
    assert len(x) == int(np.ceil(96 / 1.2)) + 1
    with pytest.raises(ValueError):
        f.warp_positions(10, -1.0, np.random.default_rng(0))


def test_gripper_channel_is_not_interpolated() -> None:
    actions = np.zeros((10, 3))
    actions[:, 0] = np.arange(10.0)
    actions[5:, -1] = 1.0
    out = f.resample_actions(actions, np.array([0.0, 4.5, 4.99, 5.0, 9.0]))
    assert out[:, -1].tolist() == [0.0, 0.0, 0.0, 1.0, 1.0]
    np.testing.assert_allclose(out[:, 0], [0.0, 4.5, 4.99, 5.0, 9.0])


def test_joint_noise_is_clipped_with_the_right_scale() -> None:
    eta = f.joint_noise(np.random.default_rng(4), (20000, 7), 0.005, 0.02)
    assert np.abs(eta).max() <= 0.02
    assert eta.std() == pytest.approx(0.005, rel=0.03)
    assert np.abs(f.joint_noise(np.random.default_rng(4), (1000, 7), 1.0, 0.02)).max() == 0.02


def test_ball_samples_are_inside_and_uniform_in_volume() -> None:
    r = 0.2
    d = f.ball_offset(np.random.default_rng(5), r, size=40000)
    norm = np.linalg.norm(d, axis=1)
    assert norm.max() <= r
    # uniform in volume: P(|d| < r/2) = 1/8 and (|d|/r)^3 ~ U(0, 1)
    assert np.mean(norm < r / 2) == pytest.approx(1 / 8, abs=0.01)
    u = np.sort((norm / r) ** 3)
    assert np.max(np.abs(u - np.arange(1, len(u) + 1) / len(u))) < 0.01  # Kolmogorov-Smirnov distance
    np.testing.assert_allclose(d.mean(axis=0), 0.0, atol=0.003)  # isotropic
    assert f.ball_offset(np.random.default_rng(6), 0.002).shape == (3,)


def test_joint_noise_with_a_window_drifts_slowly_with_the_same_scale_and_bound() -> None:
    white = f.joint_noise(np.random.default_rng(3), (600, 7), sigma=0.01, bound=0.03)
    drift = f.joint_noise(np.random.default_rng(3), (600, 7), sigma=0.01, bound=0.03, window=15)
    again = f.joint_noise(np.random.default_rng(3), (600, 7), sigma=0.01, bound=0.03, window=15)
    assert drift.shape == white.shape and drift.tobytes() == again.tobytes()  # same seed, same drift
    assert np.abs(drift).max() <= 0.03 and 0.008 < drift.std() < 0.0105
    lag1 = [np.corrcoef(joint[:-1], joint[1:])[0, 1] for noise in (white, drift) for joint in noise.T]
    assert max(lag1[:7]) < 0.2 and min(lag1[7:]) > 0.8  # independent steps vs a slow drift
    same = f.joint_noise(np.random.default_rng(3), (600, 7), sigma=0.01, bound=0.03, window=1)
    assert same.tobytes() == white.tobytes()  # window 1 draws as before
