"""What skills are made of: tool moves, planned legs, the object in the hand, and the speeds and
clearances they are planned with (shared by the skill context and its path planner)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipette_cli.errors import PipetteError

OPEN, CLOSED = 1.0, 0.0
TRANSIT_SPEED = 0.30
"""m/s of the tool through free space."""
HELD_SPEED = 0.15
"""m/s at most with an object in the hand (a friction grasp slips when jerked)."""
APPROACH_SPEED = 0.12
"""m/s for the last centimetres toward a grasp or a surface."""
FINE_SPEED = 0.05
"""m/s in contact: inserting, pushing a lid, pressing."""
TURN_SPEED = 1.6
"""rad/s of the tool's rotation."""
MIN_SECONDS = 0.2
MAX_SWING = 0.2
"""Radians a held object may turn away from the straight (slerped) rotation on a joint-space move."""
TRANSIT_ROOM = 0.015
"""Metres a transit through joint space keeps the arm from the scene where it can: a fast move's
joints trail their targets (2-3 cm at the Piper's hand), so the arm leaves the planned path."""
FREE_TOLERANCE = 0.015
"""Metres a waypoint through free space may be missed by (what matters there is clearance)."""
EASY_TRAVEL = 1.5
"""Radians of summed joint travel below which a solution is taken without trying its flip."""
FLIP = np.diag([-1.0, -1.0, 1.0])
"""Half a turn about the tool's approach axis."""
CLEARANCE = 0.04
"""Metres kept between what the hand carries and the surfaces under its path."""
FINAL_APPROACH = 0.04
"""Metres of the last descent onto a target done as a straight tool line (the rest through free space)."""
HAND_HEIGHT = 0.15
"""Metres the hand stands above its tcp (pointing down): the band a path must keep free."""
COVER_ROOM = 0.4
"""Metres: something overhead closer than this (a shelf, a roof) means a place is reached level, not from above."""
SHIFT_STEP = 0.02
SHIFTS = 8
"""Where the exact spot is out of reach, how far (steps of SHIFT_STEP) toward the robot a placement
may move while staying on the same surface."""
COMFORT = 0.25
"""Radians every arm joint should keep from its limits for a pose to count as comfortable."""
ENOUGH = 3
"""Feasible but uncomfortable candidates looked at before taking the best of them."""


class SkillFailure(PipetteError):
    """A skill cannot do its job here (out of reach, no grasp, a joint that does not move)."""


@dataclass(frozen=True)
class Move:
    """Bring the tcp to ``pos``/``rot`` over ``seconds`` with the gripper at ``gripper`` (1 open)."""

    pos: np.ndarray
    rot: np.ndarray
    gripper: float
    seconds: float
    q: np.ndarray
    """Arm joints that reach the end pose (from the planning dry run)."""
    free: bool = False
    """Through free space: interpolate the joints to ``q`` (the dry run's solution) instead of
    following a straight tool line, so the arm never has to find its way by itself."""


@dataclass(frozen=True)
class Leg:
    """A planned tool pose with the arm joints that reach it, and the speed to get there."""

    pos: np.ndarray
    rot: np.ndarray
    q: np.ndarray
    speed: float
    straight: bool = False
    """Along a straight tool line (IK every control step) rather than through joint space."""
    joints: bool = False
    """Through joint space even below transit speed: a slow final leg whose straight tool line the arm
    cannot follow (a big turn on a short way, a wrist that would run into its limit)."""


@dataclass(frozen=True)
class Held:
    """An object in the hand: its origin and rotation in the tcp frame, measured after the grasp."""

    name: str
    pos: np.ndarray
    rot: np.ndarray


def fmt(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in p) + ")"
