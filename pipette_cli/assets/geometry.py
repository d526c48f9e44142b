"""Parametric mesh building blocks: revolved profiles, extrusions, boxes.

Meshes are closed, outward-facing polygon soups held in numpy arrays, so they can be
written to USD as ``UsdGeom.Mesh`` and compiled by MuJoCo (which needs a positive volume
even for visual-only meshes). Units are metres, Z up. No pxr or mujoco imports here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

_EPS = 1e-9


@dataclass(frozen=True)
class Mesh:
    """A polygon mesh: ``points`` (N, 3), ``counts`` (F,) vertices per face, ``indices``."""

    points: np.ndarray
    counts: np.ndarray
    indices: np.ndarray

    def moved(self, offset: Sequence[float] = (0.0, 0.0, 0.0), rotation: np.ndarray | None = None) -> Mesh:
        """Return a copy rotated by the 3x3 ``rotation`` (about the origin), then translated."""
        pts = self.points if rotation is None else self.points @ np.asarray(rotation, dtype=float).T
        return Mesh(pts + np.asarray(offset, dtype=float), self.counts, self.indices)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.points.min(axis=0), self.points.max(axis=0)


def merge(meshes: Sequence[Mesh]) -> Mesh:
    """Concatenate meshes into one (faces keep their own vertices)."""
    points, counts, indices, base = [], [], [], 0
    for m in meshes:
        points.append(m.points)
        counts.append(m.counts)
        indices.append(m.indices + base)
        base += len(m.points)
    return Mesh(np.concatenate(points), np.concatenate(counts), np.concatenate(indices))


def revolve(profile: Sequence[tuple[float, float]], segments: int = 32) -> Mesh:
    """Revolve a (radius, z) polyline about the Z axis.

    The profile should start and end on the axis (radius 0) so the surface is closed: for a
    hollow container go up the outside, over the rim and down the inside. Traversing the
    profile in that order makes every face point out of the solid.
    """
    rings: list[list[int]] = []
    points: list[tuple[float, float, float]] = []
    angles = [2 * math.pi * k / segments for k in range(segments)]
    for r, z in profile:
        if r < _EPS:
            points.append((0.0, 0.0, z))
            rings.append([len(points) - 1] * segments)
        else:
            start = len(points)
            points.extend((r * math.cos(a), r * math.sin(a), z) for a in angles)
            rings.append(list(range(start, start + segments)))
    counts: list[int] = []
    indices: list[int] = []
    for lower, upper in zip(rings[:-1], rings[1:], strict=True):
        for j in range(segments):
            k = (j + 1) % segments
            quad = [lower[j], lower[k], upper[k], upper[j]]
            face = [v for i, v in enumerate(quad) if v != quad[i - 1]]
            if len(face) >= 3:
                counts.append(len(face))
                indices.extend(face)
    return Mesh(np.array(points, dtype=float), np.array(counts, dtype=np.int32), np.array(indices, dtype=np.int32))


def extrude(polygon: Sequence[tuple[float, float]], z0: float, z1: float) -> Mesh:
    """Extrude a convex counter-clockwise polygon (x, y) from ``z0`` to ``z1``."""
    n = len(polygon)
    bottom = [(x, y, z0) for x, y in polygon]
    top = [(x, y, z1) for x, y in polygon]
    counts = [n, n]
    indices = list(reversed(range(n))) + [n + i for i in range(n)]
    for i in range(n):
        j = (i + 1) % n
        counts.append(4)
        indices.extend([i, j, n + j, n + i])
    return Mesh(
        np.array(bottom + top, dtype=float), np.array(counts, dtype=np.int32), np.array(indices, dtype=np.int32)
    )


def rounded_rect(width: float, depth: float, radius: float, corner_segments: int = 4) -> list[tuple[float, float]]:
    """Counter-clockwise outline of a ``width`` (x) by ``depth`` (y) rectangle with round corners."""
    radius = min(radius, width / 2 - 1e-6, depth / 2 - 1e-6)
    if radius <= 1e-6:
        w, d = width / 2, depth / 2
        return [(-w, -d), (w, -d), (w, d), (-w, d)]
    cx, cy = width / 2 - radius, depth / 2 - radius
    out: list[tuple[float, float]] = []
    for sx, sy, a0 in ((1, -1, -90.0), (1, 1, 0.0), (-1, 1, 90.0), (-1, -1, 180.0)):
        for k in range(corner_segments + 1):
            a = math.radians(a0 + 90.0 * k / corner_segments)
            out.append((sx * cx + radius * math.cos(a), sy * cy + radius * math.sin(a)))
    return out


def box(size: Sequence[float], center: Sequence[float] = (0.0, 0.0, 0.0), radius: float = 0.0) -> Mesh:
    """An axis-aligned box of full ``size`` centred at ``center``, optionally with round vertical edges."""
    sx, sy, sz = size
    mesh = extrude(rounded_rect(sx, sy, radius), -sz / 2, sz / 2)
    return mesh.moved(center)


def cylinder(radius: float, height: float, center: Sequence[float] = (0.0, 0.0, 0.0), segments: int = 24) -> Mesh:
    """A Z-axis cylinder of full ``height`` centred at ``center``."""
    h = height / 2
    return revolve([(0, -h), (radius, -h), (radius, h), (0, h)], segments).moved(center)


def rotation(axis: str, degrees: float) -> np.ndarray:
    """3x3 rotation matrix about the x, y or z axis."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def quat_from_matrix(m: np.ndarray) -> tuple[float, float, float, float]:
    """(w, x, y, z) unit quaternion of a proper rotation matrix."""
    t = np.trace(m)
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        q = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    n = math.sqrt(sum(v * v for v in q))
    w, x, y, z = (v / n for v in q)
    return (w, x, y, z) if w >= 0 else (-w, -x, -y, -z)


def matrix_from_quat(q: Sequence[float]) -> np.ndarray:
    """3x3 rotation matrix of a (w, x, y, z) quaternion."""
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
