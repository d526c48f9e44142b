"""The perturbation formulas of paper A.7 as small pure numpy functions.

Every function takes its random numbers from a ``numpy.random.Generator`` passed in, so a
variant is a function of its seed. Nothing here knows about MuJoCo.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

Interpolation = Literal["catmull_rom", "linear"]

WARP_MIN, WARP_MAX = 0.2, 3.0
"""Bounds of the local speed multiplier ``m_i`` (paper A.7)."""


def smoothed_noise(rng: np.random.Generator, n: int, window: int = 11) -> np.ndarray:
    """Gaussian noise smoothed by a moving average of length ``window``, normalised to zero mean, unit std."""
    if n <= 0:
        return np.zeros(0)
    raw = rng.standard_normal(n + window - 1)
    smooth = np.convolve(raw, np.ones(window) / window, mode="valid")  # exactly n values
    std = smooth.std()
    return (smooth - smooth.mean()) / std if std > 0 else np.zeros(n)


def speed_multipliers(eps: np.ndarray, rho: float = 0.10) -> np.ndarray:
    """``m_i = clip(1 + rho * eps_i, 0.2, 3.0)``."""
    return np.clip(1.0 + rho * np.asarray(eps, dtype=float), WARP_MIN, WARP_MAX)


def warp_positions(
    num_knots: int, s_v: float, rng: np.random.Generator, *, rho: float = 0.10, window: int = 11
) -> np.ndarray:
    """Source positions ``x_0 = 0, x_i = x_{i-1} + s_v m_i`` until the last knot ``num_knots - 1``.

    The sequence stops at the last position inside the trajectory and ends exactly on its
    last knot (appended when the warp stepped over it), so the resampled trajectory starts at
    the first frame and finishes at the last one. Strictly increasing.
    """
    if s_v <= 0:
        raise ValueError("the speed factor s_v must be > 0")
    end = float(num_knots - 1)
    if end <= 0:
        return np.zeros(1)
    n = math.ceil(end / (s_v * WARP_MIN)) + 1  # enough steps even at the slowest multiplier
    steps = s_v * speed_multipliers(smoothed_noise(rng, n, window), rho)
    x = np.concatenate([[0.0], np.cumsum(steps)])
    x = x[x < end]
    return np.append(x, end)


def catmull_rom(knots: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Catmull-Rom cubic interpolation of ``knots`` (T, D) at fractional indices ``x``.

    ``a(x) = 1/2 (2 p1 + (-p0 + p2) t + (2 p0 - 5 p1 + 4 p2 - p3) t^2 + (-p0 + 3 p1 - 3 p2 + p3) t^3)``
    with ``p0..p3`` the knots at ``floor(x) - 1 .. floor(x) + 2`` (indices clamped at the ends)
    and ``t = x - floor(x)``. Passes through every knot.
    """
    p = np.asarray(knots, dtype=float)
    x = np.asarray(x, dtype=float)
    last = len(p) - 1
    i = np.clip(np.floor(x).astype(int), 0, last)
    t = (x - i)[:, None]
    p0, p1 = p[np.clip(i - 1, 0, last)], p[i]
    p2, p3 = p[np.clip(i + 1, 0, last)], p[np.clip(i + 2, 0, last)]
    return 0.5 * (
        2 * p1 + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2 + (-p0 + 3 * p1 - 3 * p2 + p3) * t**3
    )


def linear(knots: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Piecewise-linear interpolation of ``knots`` (T, D) at fractional indices ``x``."""
    p = np.asarray(knots, dtype=float)
    x = np.asarray(x, dtype=float)
    last = len(p) - 1
    i = np.clip(np.floor(x).astype(int), 0, last)
    j = np.clip(i + 1, 0, last)
    t = (x - i)[:, None]
    return (1 - t) * p[i] + t * p[j]


def resample_actions(actions: np.ndarray, x: np.ndarray, method: Interpolation = "catmull_rom") -> np.ndarray:
    """Resample a (T, D) action sequence at positions ``x``: arm targets interpolated, the
    gripper command (last column) not: it takes the value of the knot at ``floor(x)``."""
    actions = np.asarray(actions, dtype=float)
    interp = catmull_rom if method == "catmull_rom" else linear
    out = np.empty((len(x), actions.shape[1]))
    out[:, :-1] = interp(actions[:, :-1], x)
    out[:, -1] = actions[np.clip(np.floor(x).astype(int), 0, len(actions) - 1), -1]
    return out


def joint_noise(
    rng: np.random.Generator, shape: tuple[int, int], sigma: float = 0.005, bound: float = 0.02, window: int = 1
) -> np.ndarray:
    """``eta ~ N(0, sigma^2)`` clipped to ``[-bound, bound]`` (radians), shape (steps, joints). With
    ``window`` > 1 each joint's noise is a moving average over ``window`` steps (:func:`smoothed_noise`)
    scaled to std ``sigma``: a slow drift off the path instead of a jitter the arm's controller filters out."""
    if window <= 1:
        return np.clip(rng.normal(0.0, sigma, size=shape), -bound, bound)
    steps, joints = shape
    drift = np.stack([smoothed_noise(rng, steps, window) for _ in range(joints)], axis=1)
    return np.clip(sigma * drift, -bound, bound)


def ball_offset(rng: np.random.Generator, radius: float, size: int | None = None) -> np.ndarray:
    """``delta = r U^(1/3) n / |n|``: uniform in the volume of a ball of radius ``r``.

    Returns shape (3,) or (size, 3).
    """
    n = rng.standard_normal((1 if size is None else size, 3))
    u = rng.uniform(0.0, 1.0, size=(len(n), 1))
    delta = radius * np.cbrt(u) * n / np.linalg.norm(n, axis=1, keepdims=True)
    return delta[0] if size is None else delta
