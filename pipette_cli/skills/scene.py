"""What skills read off the scene: surfaces under a path, covers over a target, ways out of an
enclosure, free spots on the bench and the shape of an object, all from collision geometry.

Rays (``mj_ray``) see only collision geoms (groups 0 and 3), never the robot or the bodies a
caller excludes (the object in the hand, the object being approached).
"""

from __future__ import annotations

from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from functools import cached_property

import mujoco
import numpy as np

from pipette_cli.assets.library import load_asset_library
from pipette_cli.sim.scene import ROBOT_PREFIX
from pipette_cli.sim.world import World

COLLISION_GROUPS = np.array([1, 0, 0, 1, 0, 0], dtype=np.uint8)
FAR = 10.0


@dataclass(frozen=True)
class Shape:
    """An object's collision geometry as an oriented box in the world: ``center``, ``axes`` (columns:
    the object's own x, y, z in the world) and ``half`` extents along them."""

    center: np.ndarray
    axes: np.ndarray
    half: np.ndarray

    @property
    def bottom(self) -> float:
        return float(self.center[2] - np.abs(self.axes[2]) @ self.half)

    @property
    def top(self) -> float:
        return float(self.center[2] + np.abs(self.axes[2]) @ self.half)

    def world_half(self) -> np.ndarray:
        """Half extents of the world-axis-aligned box around the oriented one."""
        return np.abs(self.axes) @ self.half

    def long_axis(self) -> np.ndarray:
        """The world direction of the object's longest own axis."""
        return self.axes[:, int(np.argmax(self.half))]

    def vertical_axis(self) -> int:
        """Index of the object's own axis closest to the world vertical."""
        return int(np.argmax(np.abs(self.axes[2])))


class SceneQuery:
    """Ray casts and shapes over one world (cached per world; geometry moves, names do not)."""

    def __init__(self, world: World) -> None:
        self.world = world
        m = world.model
        self.robot_bodies = {b for b in range(m.nbody) if m.body(b).name.startswith(ROBOT_PREFIX)}
        self._geom = np.zeros(1, dtype=np.int32)

    # ------------------------------------------------------------------ bodies
    def bodies(self, name: str) -> set[int]:
        """Every body of scene object ``name`` (its root and what hangs from it)."""
        return set(self._object_bodies.get(name, ()))

    @cached_property
    def _object_bodies(self) -> dict[str, list[int]]:
        m = self.world.model
        out: dict[str, list[int]] = {}
        for b in range(1, m.nbody):
            head = m.body(b).name.split("/", 1)[0]
            if head in self.world.objects:
                out.setdefault(head, []).append(b)
        return out

    def owner(self, body: int) -> str | None:
        """The scene object a body belongs to (``None`` for the robot, floor and bench)."""
        head = self.world.model.body(body).name.split("/", 1)[0]
        return head if head in self.world.objects and head != "bench" else None

    # ------------------------------------------------------------------ rays
    def ray(
        self, start: np.ndarray, direction: np.ndarray, exclude: AbstractSet[int] = frozenset()
    ) -> tuple[float, int]:
        """Distance along unit ``direction`` to the first collision geom not on the robot or in
        ``exclude`` (bodies), and that geom's body; ``(inf, -1)`` when nothing is hit."""
        m, d = self.world.model, self.world.data
        point = np.asarray(start, dtype=float).copy()
        direction = np.asarray(direction, dtype=float)
        travelled = 0.0
        for _ in range(32):
            dist = mujoco.mj_ray(m, d, point, direction, COLLISION_GROUPS, 1, -1, self._geom)
            if dist < 0 or travelled + dist > FAR:
                return np.inf, -1
            body = int(m.geom_bodyid[self._geom[0]])
            if body not in self.robot_bodies and body not in exclude:
                return travelled + dist, body
            step = dist + 1e-4
            point = point + step * direction
            travelled += step
        return np.inf, -1

    def surface_below(self, x: float, y: float, exclude: AbstractSet[int] = frozenset(), from_z: float = 3.0) -> float:
        """Height of the first surface under ``(x, y)`` looking down from ``from_z``."""
        dist, _ = self.ray(np.array([x, y, from_z]), np.array([0.0, 0.0, -1.0]), exclude)
        return from_z - dist if np.isfinite(dist) else 0.0

    def clearance_above(self, point: np.ndarray, exclude: AbstractSet[int] = frozenset()) -> float:
        """Free height above ``point`` before something covers it (``inf`` under open sky)."""
        return self.ray(point, np.array([0.0, 0.0, 1.0]), exclude)[0]

    def corridor_top(
        self, a: np.ndarray, b: np.ndarray, radius: float, exclude: AbstractSet[int] = frozenset(), below: float = 3.0
    ) -> float:
        """Highest surface under a horizontal corridor of half-width ``radius`` from ``a`` to ``b``, looking
        down from height ``below`` (what is higher, an overhang, is not counted). The columns over the
        two ends are the caller's: the hand stands in one and descends the other."""
        a2, b2 = np.asarray(a[:2], float), np.asarray(b[:2], float)
        along = b2 - a2
        length = float(np.linalg.norm(along))
        u = along / length if length > 1e-9 else np.array([1.0, 0.0])
        n = np.array([-u[1], u[0]])
        count = max(2, int(length / 0.02) + 2)
        points = [a2 + t * u + s * n for t in np.linspace(0.0, length, count) for s in (-radius, 0.0, radius)]
        # the ends are round: a corridor of no length is a disc, not a line across it
        ring = [radius * np.array([np.cos(k), np.sin(k)]) for k in np.linspace(0.0, 2 * np.pi, 8, endpoint=False)]
        points += [end + r for end in (a2, b2) for r in ring]
        return max(0.0, *(self.surface_below(p[0], p[1], exclude, from_z=below) for p in points))

    def way_out(
        self, point: np.ndarray, exclude: AbstractSet[int] = frozenset(), prefer: np.ndarray | None = None
    ) -> tuple[np.ndarray, float]:
        """The horizontal direction out of an enclosure from ``point`` and the distance to its mouth:
        of 24 directions, those that leave the enclosure (no hit within 1.5 m), the one closest to
        ``prefer``; else the longest free one."""
        best: tuple[float, np.ndarray, float] | None = None
        hint = np.array([-point[0], -point[1], 0.0]) if prefer is None else np.asarray(prefer, float)
        hint = hint / (np.linalg.norm(hint) + 1e-12)
        for angle in np.linspace(0.0, 2 * np.pi, 24, endpoint=False):
            direction = np.array([np.cos(angle), np.sin(angle), 0.0])
            dist, _ = self.ray(point, direction, exclude)
            score = (2.0 if not np.isfinite(dist) or dist > 1.5 else min(dist, 1.5)) + 0.5 * float(direction @ hint)
            if best is None or score > best[0]:
                best = (score, direction, dist)
        assert best is not None
        _, direction, _ = best
        mouth = self._mouth(point, direction, exclude)
        return direction, mouth

    def _mouth(self, point: np.ndarray, direction: np.ndarray, exclude: AbstractSet[int]) -> float:
        """How far along ``direction`` until nothing is overhead any more (the enclosure's mouth)."""
        for s in np.arange(0.0, 1.0, 0.01):
            if not np.isfinite(self.clearance_above(point + s * direction, exclude)):
                return float(s)
        return 1.0

    def face_normal(self, point: np.ndarray, owner: str | None = None, prefer: np.ndarray | None = None) -> np.ndarray:
        """The outward normal of the face a site sits on: of the horizontal directions and up, the one
        with free space in front of the site and the owner's geometry right behind it (the one facing
        ``prefer`` when several are)."""
        up = np.array([0.0, 0.0, 1.0])
        best, best_score = up, -np.inf
        hint = np.zeros(3) if prefer is None else np.asarray(prefer, float) / (np.linalg.norm(prefer) + 1e-12)
        for direction in (
            np.array([-1.0, 0, 0]),
            np.array([1.0, 0, 0]),
            np.array([0, -1.0, 0]),
            np.array([0, 1.0, 0]),
            up,
        ):
            free, _ = self.ray(point + 0.003 * direction, direction)
            behind, body = self.ray(point + 0.003 * direction, -direction)
            solid = np.isfinite(behind) and behind < 0.03 and (owner is None or self.owner(body) == owner)
            score = min(free, 0.3) + (0.3 if solid else 0.0) + 0.05 * float(direction @ hint)
            if score > best_score:
                best, best_score = direction, score
        return best

    def semantics(self, name: str) -> dict:
        """The ``pipette:*`` semantics of object ``name``'s asset (sites, hang height, lid angles, ...)."""
        return load_asset_library().get(self.world.objects[name].asset).semantics()

    # ------------------------------------------------------------------ shapes
    def shape(self, name: str) -> Shape:
        """Oriented box around the collision geometry of object ``name``'s root body."""
        w = self.world
        m, d = w.model, w.data
        body = w.body_id(name)
        rot = d.xmat[body].reshape(3, 3)
        origin = d.xpos[body]
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for g in np.flatnonzero(m.geom_bodyid == body):
            if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                continue
            grot = rot.T @ d.geom_xmat[g].reshape(3, 3)
            center = rot.T @ (d.geom_xpos[g] - origin) + grot @ m.geom_aabb[g, :3]
            half = np.abs(grot) @ m.geom_aabb[g, 3:]
            lo, hi = np.minimum(lo, center - half), np.maximum(hi, center + half)
        if not np.all(np.isfinite(lo)):
            raise ValueError(f"{name} has no collision geometry")
        center_local = (lo + hi) / 2
        return Shape(origin + rot @ center_local, rot.copy(), (hi - lo) / 2)

    def free_spot(
        self,
        near: np.ndarray,
        footprint: float,
        exclude: set[int],
        reach: tuple[float, float],
        base: np.ndarray,
        bench_top: float,
    ) -> np.ndarray | None:
        """A point on the bench top near ``near`` with a clear square of half-size ``footprint``
        around it (nothing standing on the bench there), within the robot's ``reach`` band."""
        candidates = []
        for r in np.arange(0.12, 0.45, 0.03):
            for angle in np.linspace(0.0, 2 * np.pi, 16, endpoint=False):
                p = np.asarray(near[:2], float) + r * np.array([np.cos(angle), np.sin(angle)])
                dist = float(np.linalg.norm(p - base[:2]))
                if not reach[0] + 0.05 <= dist <= reach[1] - 0.05:
                    continue
                candidates.append((r + 0.3 * abs(dist - 0.5 * (reach[0] + reach[1])), p))
        for _, p in sorted(candidates, key=lambda c: c[0]):
            grid = [(dx, dy) for dx in (-footprint, 0, footprint) for dy in (-footprint, 0, footprint)]
            if all(self.surface_below(p[0] + dx, p[1] + dy, exclude) <= bench_top + 0.003 for dx, dy in grid):
                return np.array([p[0], p[1], bench_top])
        return None
