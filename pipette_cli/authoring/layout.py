"""Deterministic scene layout: where each object stands so the robot reaches it.

Objects are placed one after another on a grid over the bench. A position is accepted when
the object's collision boxes (in every joint state the task visits) keep clear of the robot
in its home pose and of the objects already placed, the object stays on the bench top, and
its key point (the site the robot works at) lies within the robot's comfortable reach. Among
accepted positions the one whose key point is closest to the role's preferred spot wins.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pipette_cli.sim.scene import robot_boxes
from pipette_cli.specs.robot import robot_spec

BENCH_Z = 0.55
BENCH_X = (-0.3, 1.2)
BENCH_Y = (-0.47, 0.47)
GRID_STEP = 0.025
CLEARANCE = 0.02
"""Metres kept between any two objects, and between an object and the robot at home."""


@dataclass
class PlacedObject:
    """One scene object as the template writes it."""

    name: str
    asset: str
    pos: tuple[float, float, float]
    euler_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    randomize: dict[str, Any] | None = None
    comment: str = ""


@dataclass
class Footprint:
    """What the layout needs of one object: its boxes and key point in its own frame."""

    boxes: np.ndarray  # (n, 6) in the asset frame, z from the resting surface
    key: tuple[float, float]  # key point (x, y) in the asset frame
    preferred: tuple[float, float]  # where the key point should be in the world
    margin: float = 0.0  # extra clearance (randomisation amplitude)


class Layout:
    """Places footprints one by one; remembers the placed boxes as obstacles."""

    def __init__(self, robot: str) -> None:
        self.workspace = robot_spec(robot).workspace
        self.obstacles = robot_boxes(robot).copy()
        self.obstacles = self.obstacles[self.obstacles[:, 5] > BENCH_Z + 0.002]  # parts below the bench top never collide
        xs = np.arange(0.1, BENCH_X[1] + 1e-9, GRID_STEP)
        ys = np.arange(-0.45, 0.45 + 1e-9, GRID_STEP)
        self.grid = np.array([(x, y) for x in xs for y in ys])

    def place(self, fp: Footprint, z: float = BENCH_Z) -> tuple[float, float] | None:
        """Best free position (x, y) of ``fp``'s origin, or None when there is none."""
        grid = self.grid
        boxes = fp.boxes
        world = np.repeat(boxes[None], len(grid), axis=0).copy()
        world[:, :, [0, 3]] += grid[:, None, 0:1]
        world[:, :, [1, 4]] += grid[:, None, 1:2]
        world[:, :, [2, 5]] += z
        lo, hi = world[:, :, :3].min(axis=1), world[:, :, 3:].max(axis=1)
        on_bench = (lo[:, 0] >= BENCH_X[0]) & (hi[:, 0] <= BENCH_X[1]) & (lo[:, 1] >= BENCH_Y[0]) & (hi[:, 1] <= BENCH_Y[1])
        key = grid + np.asarray(fp.key)
        reach = np.hypot(key[:, 0], key[:, 1])
        ws = self.workspace
        ok = on_bench & (reach >= ws.min_reach) & (reach <= ws.max_reach)
        if len(self.obstacles):
            pad = CLEARANCE + fp.margin
            obs = self.obstacles
            a_lo = world[ok][:, :, None, :3] - pad
            a_hi = world[ok][:, :, None, 3:] + pad
            overlap = np.all((a_lo < obs[None, None, :, 3:]) & (a_hi > obs[None, None, :, :3]), axis=3)
            clear = ~overlap.any(axis=(1, 2))
            idx = np.flatnonzero(ok)
            ok[idx[~clear]] = False
        if not ok.any():
            return None
        cost = np.hypot(key[:, 0] - fp.preferred[0], key[:, 1] - fp.preferred[1])
        cost[~ok] = np.inf
        best = int(np.argmin(cost))
        x, y = (round(float(v), 3) for v in grid[best])
        self.add_obstacle(fp.boxes, (x, y, z), fp.margin)
        return x, y

    def add_obstacle(self, boxes: np.ndarray, pos: tuple[float, float, float], margin: float = 0.0) -> None:
        shifted = boxes.copy()
        shifted[:, [0, 3]] += pos[0]
        shifted[:, [1, 4]] += pos[1]
        shifted[:, [2, 5]] += pos[2]
        shifted[:, :2] -= margin
        shifted[:, 3:5] += margin
        self.obstacles = np.vstack([self.obstacles, shifted])
