"""Deterministic scene layout: where each object stands so the robot reaches it.

Objects are placed one after another on a grid over the bench. A position is accepted when
the object's collision boxes (in every joint state the task visits) keep clear of the robot
in its home pose and of the objects already placed, the object stays on the bench top, its key
points (the sites the robot works at) lie within the robot's comfortable reach, its origin within
the reach the scene check enforces, and (for front-panel buttons) its front stays far enough from
the robot's base for the arm to press it. Among accepted positions the one whose first key point
is closest to the role's preferred spot wins. Reach numbers come from the robot's facts
(``registry/robots/*.yaml``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pipette_cli.sim.scene import robot_boxes
from pipette_cli.specs.base import BENCH_TOP_Z
from pipette_cli.specs.robot import robot_spec

BENCH_X = (-0.3, 1.2)
BENCH_Y = (-0.47, 0.47)
GRID_STEP = 0.025
CLEARANCE = 0.02
"""Metres kept between any two objects, and between an object and the robot at home."""
TIGHT_CLEARANCE = 0.005
"""The same where nothing fits with :data:`CLEARANCE` (the arm leaves its home pose first)."""


INNER_MARGIN = 0.05
OUTER_MARGIN = 0.08
"""Metres kept inside the robot's ``min_reach`` / ``reach`` for the sites it works at."""
RELATIONS: dict[str, tuple[float, float]] = {
    "left_of": (0.0, 1.0),
    "right_of": (0.0, -1.0),
    "behind": (1.0, 0.0),
    "in_front_of": (-1.0, 0.0),
}
"""Unit directions (x, y) of the relations in the bench frame, as seen from the robot (its left is
+y, behind is farther from its base); ``next_to`` tries each in turn."""
BESIDE_GAP = 0.03
"""Metres between a reference's side and an object set down beside it."""
BESIDE_TOLERANCE = 0.07
"""Metres a free spot may lie from the ideal one beside a reference (the layout keeps clearances and
the reference's randomisation margin around it)."""
ORIGIN_MARGIN = 0.02
PRESS_FRONT = 0.45
"""Metres (on a Panda-sized arm, scaled by reach) between the base and an instrument whose button is pressed."""


@dataclass(frozen=True)
class Workspace:
    """Where one robot works comfortably (horizontal distances from its base), from its facts."""

    center_x: float
    lane_y: float
    min_reach: float
    max_reach: float
    origin_reach: float
    press_front: float
    bench_z: float

    @classmethod
    def of(cls, robot: str) -> Workspace:

        facts = robot_spec(robot)
        low, high = facts.min_reach + INNER_MARGIN, facts.reach - OUTER_MARGIN
        return cls(
            center_x=round(0.5 * (low + high), 3),
            lane_y=round(0.2 * facts.reach, 3),
            min_reach=low,
            max_reach=high,
            origin_reach=facts.reach - ORIGIN_MARGIN,
            press_front=min(PRESS_FRONT, 0.55 * facts.reach),
            bench_z=facts.base_height,
        )


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
    """What the layout needs of one object: its boxes and key points in its own frame."""

    boxes: np.ndarray  # (n, 6) in the asset frame, z from the resting surface
    keys: list[tuple[float, float]]  # key points (x, y) in the asset frame; the first is matched to `preferred`
    preferred: tuple[float, float]  # where the first key point should be in the world
    margin: float = 0.0  # extra clearance (randomisation amplitude)
    pressed: bool = False  # a front-panel button is pressed: keep the front at press_front
    origin_in_reach: bool = True  # the scene check wants the origin of a task target within reach
    start_boxes: np.ndarray | None = None  # its boxes as the task starts (default: ``boxes``); only
    # these must clear the robot's home pose: the arm is elsewhere when a door or lid moves later
    press_boxes: np.ndarray | None = None  # its boxes as a button is pressed (default: ``boxes``): an
    # instrument runs shut, so a drawer closed before the run does not push its front away


class Layout:
    """Places footprints one by one; remembers the placed boxes as obstacles."""

    def __init__(self, robot: str) -> None:
        self.workspace = Workspace.of(robot)
        arm = robot_boxes(robot)
        self.robot = arm[arm[:, 5] > BENCH_TOP_Z + 0.002]  # parts below the bench top never collide
        self.obstacles = np.zeros((0, 6))
        xs = np.arange(0.1, BENCH_X[1] + 1e-9, GRID_STEP)
        ys = np.arange(-0.45, 0.45 + 1e-9, GRID_STEP)
        self.grid = np.array([(x, y) for x in xs for y in ys])

    def place(
        self,
        fp: Footprint,
        z: float = BENCH_TOP_Z,
        *,
        commit: bool = True,
        away: tuple[tuple[float, float], float] | None = None,
    ) -> tuple[float, float] | None:
        """Best free position (x, y) of ``fp``'s origin, or None when there is none; with ``commit``
        the object becomes an obstacle there; ``away = (point, d)`` keeps the origin ``d`` from ``point``.

        Key points are first kept within the robot's comfortable reach and :data:`CLEARANCE` from
        everything; where nothing fits (a tall instrument whose open door needs room in front), within
        its full reach and :data:`TIGHT_CLEARANCE` from the robot's home pose and the other objects."""
        spot = self._place(fp, z, commit, away, self.workspace.max_reach, CLEARANCE + fp.margin)
        if spot is None:
            spot = self._place(fp, z, commit, away, self.workspace.origin_reach, TIGHT_CLEARANCE)
        return spot

    def _place(
        self,
        fp: Footprint,
        z: float,
        commit: bool,
        away: tuple[tuple[float, float], float] | None,
        max_reach: float,
        pad: float,
    ) -> tuple[float, float] | None:
        grid = self.grid
        world = _at_grid(fp.boxes, grid, z)
        lo, hi = world[:, :, :3].min(axis=1), world[:, :, 3:].max(axis=1)
        on_bench = (
            (lo[:, 0] >= BENCH_X[0]) & (hi[:, 0] <= BENCH_X[1]) & (lo[:, 1] >= BENCH_Y[0]) & (hi[:, 1] <= BENCH_Y[1])
        )
        ws = self.workspace
        ok = on_bench.copy()
        for k in fp.keys or [(0.0, 0.0)]:
            reach = np.hypot(grid[:, 0] + k[0], grid[:, 1] + k[1])
            ok &= (reach >= ws.min_reach) & (reach <= max_reach + 1e-9)
        if fp.origin_in_reach:
            ok &= np.hypot(grid[:, 0], grid[:, 1]) <= ws.origin_reach + 1e-9
        if fp.pressed:  # the nearest point of every box stays press_front away from the base
            pressing = world if fp.press_boxes is None else _at_grid(fp.press_boxes, grid, z)
            p_lo, p_hi = pressing[:, :, :3].min(axis=1), pressing[:, :, 3:].max(axis=1)
            near_x = np.clip(0.0, p_lo[:, 0], p_hi[:, 0])
            near_y = np.clip(0.0, p_lo[:, 1], p_hi[:, 1])
            ok &= np.hypot(near_x, near_y) >= ws.press_front
        if away is not None:
            ok &= np.hypot(grid[:, 0] - away[0][0], grid[:, 1] - away[0][1]) >= away[1]
        key = grid + np.asarray((fp.keys or [(0.0, 0.0)])[0])
        start = world if fp.start_boxes is None else _at_grid(fp.start_boxes, grid, z)
        for mine, obs in ((world, self.obstacles), (start, self.robot)):
            if len(obs) and ok.any():
                a_lo = mine[ok][:, :, None, :3] - pad
                a_hi = mine[ok][:, :, None, 3:] + pad
                overlap = np.all((a_lo < obs[None, None, :, 3:]) & (a_hi > obs[None, None, :, :3]), axis=3)
                idx = np.flatnonzero(ok)
                ok[idx[overlap.any(axis=(1, 2))]] = False
        if not ok.any():
            return None
        cost = np.hypot(key[:, 0] - fp.preferred[0], key[:, 1] - fp.preferred[1])
        cost[~ok] = np.inf
        best = int(np.argmin(cost))
        x, y = (round(float(v), 3) for v in grid[best])
        if commit:
            self.add_obstacle(fp.boxes, (x, y, z), fp.margin)
        return x, y

    def beside(
        self, boxes: np.ndarray, reference: np.ndarray, relation: str, z: float
    ) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """A free spot (x, y) for an object of ``boxes`` beside the ``reference`` boxes (placed, world
        frame) in ``relation``, kept clear from now on, and its direction; None when there is none."""
        center = 0.5 * (reference[:, :2].min(axis=0) + reference[:, 3:5].max(axis=0))
        r_half = 0.5 * (reference[:, 3:5].max(axis=0) - reference[:, :2].min(axis=0))
        i_low, i_high = boxes[:, :2].min(axis=0), boxes[:, 3:5].max(axis=0)
        i_half, middle = 0.5 * (i_high - i_low), 0.5 * (i_low + i_high)
        for direction in list(RELATIONS.values()) if relation == "next_to" else [RELATIONS[relation]]:
            d = np.asarray(direction)
            ideal = center + d * (np.abs(d) @ r_half + np.abs(d) @ i_half + BESIDE_GAP) - middle
            fp = Footprint(boxes, [(0.0, 0.0)], (float(ideal[0]), float(ideal[1])), margin=0.01)
            spot = self.place(fp, z, commit=False)
            if spot is not None and np.hypot(*(np.asarray(spot) - ideal)) <= BESIDE_TOLERANCE:
                self.place(fp, z)
                return spot, direction
        return None

    def add_obstacle(self, boxes: np.ndarray, pos: tuple[float, float, float], margin: float = 0.0) -> None:
        shifted = boxes.copy()
        shifted[:, [0, 3]] += pos[0]
        shifted[:, [1, 4]] += pos[1]
        shifted[:, [2, 5]] += pos[2]
        shifted[:, :2] -= margin
        shifted[:, 3:5] += margin
        self.obstacles = np.vstack([self.obstacles, shifted])


def _at_grid(boxes: np.ndarray, grid: np.ndarray, z: float) -> np.ndarray:
    """``boxes`` (n, 6, own frame) placed at every grid point: (len(grid), n, 6)."""
    world = np.repeat(boxes[None], len(grid), axis=0).copy()
    world[:, :, [0, 3]] += grid[:, None, 0:1]
    world[:, :, [1, 4]] += grid[:, None, 1:2]
    world[:, :, [2, 5]] += z
    return world
