"""In-memory description of one asset, built by the generators and written by :mod:`.usd_writer`.

An :class:`AssetDef` is plain data: rigid bodies holding visual meshes, primitive
colliders and named sites; joints between bodies; MuJoCo actuators; and task semantics.
Mass properties are computed here from the colliders (uniform density scaled to the real
mass), so the USD file carries explicit mass, centre of mass and diagonal inertia.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from pipette_cli.assets.geometry import Mesh, matrix_from_quat, quat_from_matrix

ShapeKind = Literal["box", "cylinder", "sphere", "capsule"]
IDENTITY = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Material:
    """A display material (``UsdPreviewSurface``); ``opacity`` < 1 for glass and clear plastic."""

    name: str
    color: tuple[float, float, float]
    opacity: float = 1.0
    roughness: float = 0.5
    metallic: float = 0.0


@dataclass(frozen=True)
class Visual:
    name: str
    mesh: Mesh
    material: Material


@dataclass(frozen=True)
class Collider:
    """A primitive collision shape in its body's frame.

    ``size`` is half-extents for a box, (radius, half-height) for a Z-axis cylinder or
    capsule, (radius,) for a sphere.
    """

    name: str
    kind: ShapeKind
    size: tuple[float, ...]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = IDENTITY

    def volume(self) -> float:
        if self.kind == "box":
            return 8 * self.size[0] * self.size[1] * self.size[2]
        if self.kind == "sphere":
            return 4 / 3 * math.pi * self.size[0] ** 3
        r, h = self.size[0], self.size[1]
        caps = 4 / 3 * math.pi * r**3 if self.kind == "capsule" else 0.0
        return math.pi * r * r * 2 * h + caps

    def local_inertia(self, mass: float) -> np.ndarray:
        """Inertia tensor about the shape's own centre, in the shape's frame."""
        if self.kind == "box":
            a, b, c = (2 * s for s in self.size)
            return mass / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
        if self.kind == "sphere":
            return np.eye(3) * 0.4 * mass * self.size[0] ** 2
        r, h = self.size[0], 2 * self.size[1]
        if self.kind == "capsule":
            h += 4 * r / 3  # the caps act roughly like a longer cylinder
        ixx = mass * (3 * r * r + h * h) / 12
        return np.diag([ixx, ixx, 0.5 * mass * r * r])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds in the body frame."""
        if self.kind == "box":
            half = np.array(self.size)
        elif self.kind == "sphere":
            half = np.full(3, self.size[0])
        else:
            r, h = self.size[0], self.size[1] + (self.size[0] if self.kind == "capsule" else 0.0)
            half = np.array([r, r, h])
        rot = np.abs(matrix_from_quat(self.quat))
        extent = rot @ half
        return np.array(self.pos) - extent, np.array(self.pos) + extent


@dataclass(frozen=True)
class Site:
    """A named point of interest (``grasp``, ``button``, ``slot_0``...) in its body's frame."""

    name: str
    pos: tuple[float, float, float]
    radius: float = 0.005


@dataclass
class Body:
    """A rigid body; ``pos`` is its frame's origin in the asset frame (no rotation)."""

    name: str
    mass: float
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    visuals: list[Visual] = field(default_factory=list)
    colliders: list[Collider] = field(default_factory=list)
    sites: list[Site] = field(default_factory=list)
    condim: int = 3
    """Contact dimensionality of its colliders (MuJoCo ``condim``): 6 adds rolling and torsional
    friction, what keeps a round object lying on its side (a pipette tip) from rolling forever on
    a perfectly flat bench, as real ones stop."""

    def mass_properties(self) -> tuple[np.ndarray, np.ndarray, tuple[float, float, float, float]]:
        """Centre of mass, principal moments and principal-axes quaternion, from the colliders."""
        if not self.colliders:
            raise ValueError(f"body {self.name!r} has no colliders to compute its inertia from")
        volumes = np.array([c.volume() for c in self.colliders])
        masses = self.mass * volumes / volumes.sum()
        com = sum(m * np.array(c.pos) for m, c in zip(masses, self.colliders, strict=True)) / self.mass
        inertia = np.zeros((3, 3))
        for m, c in zip(masses, self.colliders, strict=True):
            rot = matrix_from_quat(c.quat)
            d = np.array(c.pos) - com
            inertia += rot @ c.local_inertia(m) @ rot.T + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
        moments, axes = np.linalg.eigh(inertia)
        if np.allclose(inertia, np.diag(np.diag(inertia)), atol=1e-12 + 1e-6 * moments.max()):
            return com, np.diag(inertia).copy(), IDENTITY
        if np.linalg.det(axes) < 0:
            axes[:, 0] *= -1
        return com, moments, quat_from_matrix(axes)


@dataclass(frozen=True)
class Joint:
    """A revolute or prismatic joint from ``parent`` to ``child`` (body names).

    ``anchor`` is in the asset frame; ``axis`` is a signed unit axis such as ``"-y"``.
    Limits are degrees (revolute) or metres (prismatic); damping and friction are in SI
    per radian (revolute) or per metre (prismatic).
    """

    name: str
    kind: Literal["revolute", "prismatic", "fixed"]
    parent: str
    child: str
    anchor: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: str = "z"
    lower: float = 0.0
    upper: float = 0.0
    damping: float = 0.0
    friction: float = 0.0
    armature: float = 0.0


@dataclass(frozen=True)
class PositionDrive:
    """A MuJoCo position servo on ``joint`` (``MjcActuator``), mirrored as a ``UsdPhysics`` drive.

    ``kp``/``kv`` are per radian (revolute) or per metre; ``ctrl_range`` in the same units.
    """

    name: str
    joint: str
    kp: float
    kv: float
    max_force: float
    ctrl_range: tuple[float, float]
    target: float = 0.0


@dataclass
class AssetDef:
    """Everything the writer needs for one asset.

    ``upright`` says the authored orientation is a stable resting pose on a table; when it is
    not (a conical tube, a pipette), ``rest_quat`` (w, x, y, z) is one that is.
    """

    asset_id: str
    category: str
    description: str
    bodies: list[Body]
    graspable: bool = False
    static: bool = False
    materials: list[Material] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    drives: list[PositionDrive] = field(default_factory=list)
    upright: bool = True
    rest_quat: tuple[float, float, float, float] = IDENTITY
    extra: dict[str, float | str | bool | tuple[float, ...]] = field(default_factory=dict)

    @property
    def main_body(self) -> Body:
        return self.bodies[0]

    def total_mass(self) -> float:
        return float(sum(b.mass for b in self.bodies))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds of every visual and collider, in the asset frame."""
        lows, highs = [], []
        for b in self.bodies:
            offset = np.array(b.pos)
            for v in b.visuals:
                lo, hi = v.mesh.bounds()
                lows.append(lo + offset)
                highs.append(hi + offset)
            for c in b.colliders:
                lo, hi = c.bounds()
                lows.append(lo + offset)
                highs.append(hi + offset)
        return np.min(lows, axis=0), np.max(highs, axis=0)

    def dimensions(self) -> tuple[float, float, float]:
        lo, hi = self.bounds()
        return tuple(float(round(v, 4)) for v in hi - lo)  # type: ignore[return-value]

    def site_names(self) -> list[str]:
        return [s.name for b in self.bodies for s in b.sites]
