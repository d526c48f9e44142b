"""Scripted experts for the 12 benchmark tasks: object-relative waypoint plans.

Every plan is computed at reset from the randomised object poses (privileged state), so it
follows the task's initial-state randomisation. Motions are straight tcp lines solved by
damped-least-squares IK (:mod:`.motion`); grasps are top-down unless noted.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pipette_cli.demos.experts.base import register_expert
from pipette_cli.demos.experts.motion import Segment, WaypointFollower, yaw_down
from pipette_cli.sim.world import World

OPEN, CLOSED = 1.0, 0.0
UP = np.array([0.0, 0.0, 1.0])

Plan = Callable[[World, np.random.Generator], list[Segment]]


class PlanExpert:
    """An expert that follows a plan computed at reset."""

    def __init__(self, plan: Plan) -> None:
        self.plan = plan
        self.follower: WaypointFollower | None = None

    def reset(self, world: World, rng: np.random.Generator) -> None:
        self.follower = WaypointFollower(world, self.plan(world, rng))

    def act(self, world: World) -> np.ndarray:
        if self.follower is None:
            raise RuntimeError("call reset() before act()")
        return self.follower.act()


def expert(*names: str) -> Callable[[Plan], Plan]:
    """Register ``plan`` as the expert of the named tasks."""

    def decorate(plan: Plan) -> Plan:
        register_expert(*names)(lambda: PlanExpert(plan))
        return plan

    return decorate


def seg(pos, rot, gripper: float, seconds: float, world: World) -> Segment:
    return Segment(np.asarray(pos, dtype=float), rot, gripper, max(1, int(round(seconds / world.control_dt))))


def pick(world: World, grasp: np.ndarray, rot: np.ndarray, clearance: float = 0.12) -> list[Segment]:
    """Approach above ``grasp``, descend, close; ends holding the object at the grasp pose."""
    above = grasp + clearance * UP
    return [
        seg(above, rot, OPEN, 0.9, world),
        seg(grasp, rot, OPEN, 0.7, world),
        seg(grasp, rot, OPEN, 0.25, world),  # let the arm's servos catch up before closing
        seg(grasp, rot, CLOSED, 0.5, world),
    ]


def cylinder_grasp(world: World, obj: str, height: float) -> np.ndarray:
    """Grasp point on an upright object's axis, ``height`` above its origin (its base)."""
    return world.position(obj) + height * UP


@expert("PickUpTestTube")
def pick_up_test_tube(world: World, rng: np.random.Generator) -> list[Segment]:
    grasp = cylinder_grasp(world, "tube", 0.11)
    rot = yaw_down(np.pi / 2)
    return [*pick(world, grasp, rot), seg(grasp + 0.12 * UP, rot, CLOSED, 0.8, world), seg(grasp + 0.12 * UP, rot, CLOSED, 1.5, world)]


@expert("PlaceTubeOnBalance")
def place_tube_on_balance(world: World, rng: np.random.Generator) -> list[Segment]:
    height = 0.085  # under the cap: the hand's underside is only ~4 cm above the fingertips
    grasp = cylinder_grasp(world, "tube", height)
    rot = yaw_down(np.pi / 2)
    pan = world.position("balance/pan_center")
    drop = pan + (height + 0.004) * UP
    carry = 0.16
    return [
        *pick(world, grasp, rot),
        seg(grasp + carry * UP, rot, CLOSED, 0.7, world),
        seg(drop + carry * UP, rot, CLOSED, 1.0, world),
        seg(drop, rot, CLOSED, 0.8, world),
        seg(drop, rot, OPEN, 0.35, world),
        seg(drop + 0.12 * UP, rot, OPEN, 0.7, world),
        seg(drop + 0.12 * UP, rot, OPEN, 2.0, world),
    ]


@expert("RemoveTubeFromBalance")
def remove_tube_from_balance(world: World, rng: np.random.Generator) -> list[Segment]:
    height = 0.085  # under the cap: the hand's underside is only ~4 cm above the fingertips
    grasp = cylinder_grasp(world, "tube", height)
    rot = yaw_down(np.pi / 2)
    lifted = grasp + 0.06 * UP
    aside = grasp + np.array([0.0, 0.28, -0.14])
    return [
        *pick(world, grasp, rot),
        seg(lifted, rot, CLOSED, 0.5, world),
        seg(lifted + np.array([0.0, 0.28, 0.0]), rot, CLOSED, 1.0, world),
        seg(aside, rot, CLOSED, 0.8, world),
        seg(aside, rot, CLOSED, 2.0, world),
    ]


@expert("OpenWaterBathLid")
def open_water_bath_lid(world: World, rng: np.random.Generator) -> list[Segment]:
    handle = world.position("lid/lid_handle")
    rot = yaw_down(np.pi / 2)  # fingers close along x, across the handle bar (which runs along y)
    grasp = handle + np.array([0.0, 0.0, -0.005])
    lifted = grasp + 0.14 * UP
    back = lifted + np.array([-0.34, 0.0, 0.0])
    return [*pick(world, grasp, rot), seg(lifted, rot, CLOSED, 0.8, world), seg(back, rot, CLOSED, 1.2, world), seg(back, rot, CLOSED, 1.5, world)]
