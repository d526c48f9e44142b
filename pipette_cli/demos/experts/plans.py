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
    """Register ``plan`` as the expert of the named benchmark tasks (namespace ``pipette``)."""

    def decorate(plan: Plan) -> Plan:
        register_expert(*(f"pipette/{name}" for name in names))(lambda: PlanExpert(plan))
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
    drop = pan + (height - 0.002) * UP  # the tube sits ~3 mm higher in the grasp than aimed: set it down
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


@expert("OpenCentrifugeLid")
def open_centrifuge_lid(world: World, rng: np.random.Generator) -> list[Segment]:
    button = world.position("centrifuge/button")
    rot = yaw_down(0.0)
    front = np.array([button[0] - 0.12, button[1], 0.9])
    return [
        seg(front, rot, CLOSED, 1.0, world),
        seg(button + np.array([-0.08, 0.0, 0.0]), rot, CLOSED, 0.8, world),
        seg(button + np.array([-0.005, 0.0, 0.0]), rot, CLOSED, 0.6, world),
        seg(button + np.array([-0.08, 0.0, 0.0]), rot, CLOSED, 0.6, world),
        seg(button + np.array([-0.08, 0.0, 0.0]), rot, CLOSED, 3.0, world),
    ]


@expert("PipetteToPetriDish")
def pipette_to_petri_dish(world: World, rng: np.random.Generator) -> list[Segment]:
    tip, grasp = world.position("pipette/tip"), world.position("pipette/grasp")
    axis = grasp - tip
    yaw = float(np.arctan2(axis[1], axis[0]))
    rot = yaw_down(yaw)  # hand x along the pipette: the fingers close across it
    hold = grasp + np.array([0.0, 0.0, -0.004])
    dish = world.position("dish/center")
    # carry so that the pipette's origin (its tip) ends over the dish, 15 cm up
    over = dish + np.array([axis[0], axis[1], 0.0]) + np.array([0.0, 0.0, 0.15 + (grasp[2] - tip[2])])
    return [
        *pick(world, hold, rot),
        seg(hold + 0.15 * UP, rot, CLOSED, 0.8, world),
        seg(over, rot, CLOSED, 1.2, world),
        seg(over, rot, CLOSED, 2.0, world),
    ]


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` radians about unit ``axis`` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def close_lid_by_arc(world: World, joint: str, handle: str, reach: float, standoff: float = 0.03) -> list[Segment]:
    """Sweep the closed gripper along the lid's arc, pushing on the face that closes it.

    The push point sits ``reach`` (a fraction of the handle's distance) out from the hinge,
    ``standoff`` metres off the lid's surface on the side opposite to the closing motion.
    """
    jid = world.joint_id(joint)
    anchor = world.data.xanchor[jid].copy()
    axis = world.data.xaxis[jid].copy()
    theta0 = np.deg2rad(world.joint(joint))
    v0 = world.position(handle) - anchor
    v0 *= reach

    def point(theta: float, off: float) -> np.ndarray:
        v = axis_rotation(axis, theta - theta0) @ v0
        push = np.sign(-theta0) * np.cross(axis, v)
        push /= np.linalg.norm(push)
        return anchor + v - off * push

    rot = yaw_down(0.0)
    shut = -np.sign(theta0) * np.deg2rad(2)

    def sweep(start: float) -> list[Segment]:
        approach = point(start, standoff + 0.10) + 0.05 * UP
        via = approach + np.array([-0.15, 0.0, 0.10])  # come round the lid's edge from the robot's side
        out = [seg(via, rot, CLOSED, 0.8, world), seg(approach, rot, CLOSED, 0.5, world)]
        out += [seg(point(start, standoff), rot, CLOSED, 0.4, world)]
        return out + [seg(point(a, standoff), rot, CLOSED, 0.25, world) for a in np.linspace(start, shut, 8)[1:]]

    # the second pass catches a lid that fell ahead of the hand and stopped on its friction
    first = theta0 + np.sign(theta0) * np.deg2rad(4)  # a little behind the lid as it stands
    segments = sweep(first) + sweep(np.sign(theta0) * min(abs(first), np.deg2rad(95)))
    angles = [shut]
    end = point(angles[-1], standoff)
    segments += [seg(end + 0.02 * UP, rot, CLOSED, 0.3, world), seg(end + 0.12 * UP, rot, CLOSED, 0.6, world)]
    segments += [seg(end + 0.12 * UP, rot, CLOSED, 1.5, world)]
    return segments


@expert("CloseSpectrophotometerLid")
def close_spectrophotometer_lid(world: World, rng: np.random.Generator) -> list[Segment]:
    return close_lid_by_arc(world, "spectro/lid_hinge", "spectro/lid_handle", reach=0.85, standoff=0.02)


def close_lid_by_pulling(world: World, joint: str, handle: str, release_deg: float) -> list[Segment]:
    """Pinch the lid's front edge (its top while open), pull it along its arc toward shut,
    and let go at ``release_deg``: gravity, stronger than the hinge friction there, shuts it."""
    jid = world.joint_id(joint)
    anchor, axis = world.data.xanchor[jid].copy(), world.data.xaxis[jid].copy()
    theta0 = np.deg2rad(world.joint(joint))
    v0 = world.position(handle) - anchor
    rot = yaw_down(np.pi / 2)  # fingers close along x, across the lid's edge

    def edge(theta: float) -> np.ndarray:
        return anchor + axis_rotation(axis, theta - theta0) @ v0

    grip = edge(theta0) - 0.01 * UP
    segments = [
        seg(grip + 0.12 * UP, rot, OPEN, 1.2, world),
        seg(grip, rot, OPEN, 0.7, world),
        seg(grip, rot, OPEN, 0.2, world),
        seg(grip, rot, CLOSED, 0.5, world),
    ]
    angles = np.linspace(theta0, np.deg2rad(release_deg), 6)[1:]
    segments += [seg(edge(a) - 0.01 * UP, rot, CLOSED, 0.4, world) for a in angles]
    last = edge(angles[-1]) - 0.01 * UP
    segments += [seg(last, rot, OPEN, 0.4, world), seg(last + np.array([-0.1, 0.0, 0.1]), rot, OPEN, 0.6, world)]
    segments += [seg(last + np.array([-0.1, 0.0, 0.1]), rot, OPEN, 2.5, world)]
    return segments


@expert("CloseCentrifugeLid")
def close_centrifuge_lid(world: World, rng: np.random.Generator) -> list[Segment]:
    return close_lid_by_arc(world, "centrifuge/lid_hinge", "centrifuge/lid_handle", reach=0.85)


def pitched(toward: np.ndarray, pitch_deg: float) -> np.ndarray:
    """Tcp rotation whose z (approach) axis points horizontally along ``toward``, tilted
    ``pitch_deg`` below the horizon; fingers close along the horizontal perpendicular."""
    radial = np.array([toward[0], toward[1], 0.0])
    radial /= np.linalg.norm(radial)
    th = np.deg2rad(pitch_deg)
    z = np.cos(th) * radial + np.array([0.0, 0.0, -np.sin(th)])
    y = np.array([-radial[1], radial[0], 0.0])
    return np.column_stack([np.cross(y, z), y, z])


@expert("PlaceFlaskOnShaker")
def place_flask_on_shaker(world: World, rng: np.random.Generator) -> list[Segment]:
    """AgileX Piper: it cannot point straight down here, so it grasps the neck from above-behind
    with the approach axis pitched 55 degrees down, radially from its base."""
    base = np.asarray(world.task.embodiment.base.pos)
    flask, neck = world.position("flask"), world.position("flask/neck") - 0.012 * UP
    platform = world.position("shaker/platform_center")
    grab = pitched(neck - base, 55.0)
    put = pitched(platform - base, 55.0)
    offset = neck - flask
    place = platform + offset + 0.01 * UP
    back = lambda rot: -0.07 * rot[:, 2]  # noqa: E731  (retreat along the approach axis)
    return [
        seg(neck + back(grab) + 0.05 * UP, grab, OPEN, 1.0, world),
        seg(neck + back(grab), grab, OPEN, 0.5, world),
        seg(neck, grab, OPEN, 0.6, world),
        seg(neck, grab, OPEN, 0.2, world),
        seg(neck, grab, CLOSED, 0.6, world),
        seg(neck + 0.10 * UP, grab, CLOSED, 0.8, world),
        seg(place + 0.10 * UP, put, CLOSED, 1.4, world),
        seg(place, put, CLOSED, 0.8, world),
        seg(place, put, OPEN, 0.5, world),
        seg(place + back(put), put, OPEN, 0.6, world),
        seg(place + back(put) + 0.06 * UP, put, OPEN, 2.0, world),
    ]


@expert("PlacePipetteInRack")
def place_pipette_in_rack(world: World, rng: np.random.Generator) -> list[Segment]:
    """Grasp the lying pipette across its body, turn it tip-down with the hand pointing +x, slide
    it into a slot of the stand from the open front, lower it onto the prongs, let go."""
    tip, grasp = world.position("pipette/tip"), world.position("pipette/grasp")
    axis = grasp - tip
    down = yaw_down(float(np.arctan2(axis[1], axis[0])))
    hold = grasp - 0.004 * UP
    along = float(np.linalg.norm(axis))  # grasp point's distance from the tip
    upright = axis_rotation(np.array([0.0, 1.0, 0.0]), -np.pi / 2) @ yaw_down(0.0)  # hand points +x
    slot = world.position("rack/slot_1")
    hang = 0.112  # pipette_single_channel semantics: tip to collar
    hung = np.array([slot[0], slot[1], slot[2] - hang + along])
    above = hung + 0.012 * UP  # collar just above the prongs
    front = above + np.array([-0.12, 0.0, 0.0])
    return [
        *pick(world, hold, down),
        seg(hold + 0.2 * UP, down, CLOSED, 0.8, world),
        seg(front + 0.05 * UP, upright, CLOSED, 1.6, world),
        seg(front, upright, CLOSED, 0.5, world),
        seg(above, upright, CLOSED, 1.0, world),
        seg(hung - 0.004 * UP, upright, CLOSED, 0.6, world),
        seg(hung - 0.004 * UP, upright, OPEN, 0.5, world),
        seg(hung + np.array([-0.10, 0.0, 0.0]), upright, OPEN, 0.8, world),
        seg(hung + np.array([-0.10, 0.0, 0.05]), upright, OPEN, 2.0, world),
    ]


DISH_CHORD = 0.026
"""How far behind a 90 mm dish's centre the fingers pinch it: across a 76 mm chord, just inside the
Panda's 80 mm opening (the diameter is not). Pinching further back makes the contact normals lean
toward the friction cone's edge and the dish squeezes out like a pip (tuned over 50 seeds)."""
DISH_PITCH = 30.0
"""Degrees the hand points below the horizon: low enough to fit between incubator shelves,
high enough that the palm clears the surface the dish stands on."""


def dish_pinch(world: World, dish: str, toward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tcp pose pinching ``dish`` from the side facing the robot, hand pitched down."""
    radial = np.array([toward[0], toward[1], 0.0]) / np.linalg.norm(toward[:2])
    rot = pitched(radial, DISH_PITCH)
    return world.position(dish) - DISH_CHORD * radial + 0.0095 * UP, rot


@expert("RemovePetriDishFromIncubator")
def remove_petri_dish_from_incubator(world: World, rng: np.random.Generator) -> list[Segment]:
    pinch, rot = dish_pinch(world, "dish", np.array([1.0, 0.0, 0.0]))
    out = np.array([0.44, pinch[1], pinch[2] + 0.06])  # clear of the shelf's front edge
    return [
        seg(np.array([0.36, pinch[1], pinch[2] + 0.05]), rot, OPEN, 1.2, world),
        seg(pinch + np.array([-0.12, 0.0, 0.022]), rot, OPEN, 0.8, world),
        seg(pinch + 0.022 * UP, rot, OPEN, 0.6, world),  # fingertips pass over the rim
        seg(pinch, rot, OPEN, 0.5, world),
        seg(pinch, rot, OPEN, 0.2, world),
        seg(pinch, rot, CLOSED, 0.5, world),
        seg(pinch + 0.05 * UP, rot, CLOSED, 0.6, world),
        seg(out, rot, CLOSED, 1.6, world),
        seg(out, rot, CLOSED, 2.0, world),
    ]


@expert("PlacePetriDishInIncubator")
def place_petri_dish_in_incubator(world: World, rng: np.random.Generator) -> list[Segment]:
    shelf = world.position("incubator/shelf_0_center")
    pinch, rot = dish_pinch(world, "dish", np.array([1.0, 0.0, 0.0]))
    # carry the dish so that its centre lands on the shelf's centre line, well inside
    offset = world.position("dish") - pinch
    target_dish = np.array([shelf[0] - 0.02, shelf[1], shelf[2] + 0.004])
    place = target_dish - offset
    front = np.array([0.38, place[1], place[2] + 0.03])
    return [
        seg(pinch + np.array([-0.10, 0.0, 0.06]), rot, OPEN, 1.2, world),
        seg(pinch + 0.022 * UP, rot, OPEN, 0.6, world),
        seg(pinch, rot, OPEN, 0.5, world),
        seg(pinch, rot, OPEN, 0.2, world),
        seg(pinch, rot, CLOSED, 0.5, world),
        seg(pinch + 0.05 * UP, rot, CLOSED, 0.6, world),
        seg(front, rot, CLOSED, 1.4, world),
        seg(place + 0.012 * UP, rot, CLOSED, 1.2, world),
        seg(place, rot, CLOSED, 0.4, world),
        seg(place, rot, OPEN, 0.4, world),
        seg(place + np.array([-0.12, 0.0, 0.01]), rot, OPEN, 0.8, world),
        seg(front, rot, OPEN, 0.8, world),
        seg(front, rot, OPEN, 2.0, world),
    ]
