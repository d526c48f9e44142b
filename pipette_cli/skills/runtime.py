"""The skill runtime: a skill is a generator of tool moves, planned against the world it reads.

A skill function takes a :class:`SkillContext` and its step spec and yields :class:`Move` s. The
program runner (:mod:`.program`) executes each move before asking the generator for the next,
so code after a ``yield`` sees the world as the move left it: a skill measures where the object
really sits in the hand after closing, checks that a lid really moved, and plans the next motion
from there. Every move's end pose is checked for reachability when it is planned (a dry run of
the IK); a skill that cannot do its job raises :class:`SkillFailure` with a one-line reason.

The context is what a skill reads and commands: the world and the scene queries, the hand
(:class:`~pipette_cli.skills.hand.Hand`: its planned pose, the gripper, what it holds), and the
moves it plans (:meth:`SkillContext.move`, :meth:`~SkillContext.grip`, :meth:`~SkillContext.hold`).
Reach, clearance and paths are the planner's (``ctx.plan``, :class:`~pipette_cli.skills.transit.Planner`);
motions built of several moves are in :mod:`.motions`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import mujoco
import numpy as np

from pipette_cli.plugins import Plugins
from pipette_cli.sim.world import World
from pipette_cli.skills.frames import UP, rotation_angle
from pipette_cli.skills.hand import Hand
from pipette_cli.skills.ik import ArmIK, IKSolution
from pipette_cli.skills.moves import (
    FREE_TOLERANCE,
    HELD_SPEED,
    MIN_SECONDS,
    TRANSIT_SPEED,
    TURN_SPEED,
    Leg,
    Move,
    SkillFailure,
    fmt,
)
from pipette_cli.skills.scene import SceneQuery
from pipette_cli.skills.transit import Planner
from pipette_cli.specs.expert import SKILLS, StepSpec

Skill = Callable[["SkillContext", Any], Iterator[Move]]


MIN_JERK_PEAK = 1.875
"""Peak over mean speed of a minimum-jerk move (how moves are interpolated)."""
JOINT_SPEED_SHARE = 0.7
"""Share of a joint's top speed a move may ask of it (the rest is for gravity and acceleration)."""


def joint_speeds(world: World) -> np.ndarray:
    """The speed (rad/s) each arm joint's actuator can drive it at: its force limit over the joint's
    damping (the terminal speed at full force), times :data:`JOINT_SPEED_SHARE`; unbounded where the
    joint has no damping or its actuator no force limit. A move timed only by the tool's speed can
    ask a strongly damped wrist (the UR5e's) for more than it can give, and the arm lags its plan."""
    m = world.model
    out = np.full(len(world.arm_joint_ids), np.inf)
    for i, joint in enumerate(world.arm_joint_ids):
        damping = float(m.dof_damping[m.jnt_dofadr[joint]])
        for a in range(m.nu):
            joint_driven = m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == joint
            if joint_driven and m.actuator_forcelimited[a] and damping > 0:
                out[i] = JOINT_SPEED_SHARE * float(m.actuator_forcerange[a, 1]) / damping
    return out


class SkillContext:
    """What a skill reads and commands during one episode: the world, the robot's facts, the scene
    queries, the hand (:attr:`hand`), the planner (:attr:`plan`), and the moves it plans."""

    def __init__(self, world: World, rng: np.random.Generator) -> None:
        self.world = world
        self.robot = world.robot
        self.rng = rng
        self.ik = ArmIK(world)
        self.scene = SceneQuery(world)
        self.hand = Hand(world, self.scene)
        self.plan = Planner(world, self.ik, self.scene, self.hand)
        self.next_step: Any = None
        """The program's step after the running one (a pick looks ahead to where the object goes)."""
        self.start = {name: world.position(name) for name in world.objects}
        self.start_up = {name: world.rotation(name).T @ UP for name in world.objects}
        """Each object's up at the episode's start, in its own frame (how it stands at rest)."""
        self.base = self.plan.base
        self.joint_speed = joint_speeds(world)

    def move(
        self,
        pos: np.ndarray,
        rot: np.ndarray | None = None,
        *,
        gripper: float | None = None,
        speed: float = TRANSIT_SPEED,
        seconds: float | None = None,
        yaw_free: bool = False,
        what: str = "the tool pose",
        check: bool = True,
    ) -> Move:
        """Plan a move of the tcp to ``pos``/``rot``: at transit speed through free space (joints
        interpolated; the end pose may be missed by :data:`FREE_TOLERANCE`), slower along a straight
        tool line; ``seconds``, where given, is the least it takes. Raises :class:`SkillFailure` when
        the end pose is out of reach."""
        hand, plan = self.hand, self.plan
        pos = np.asarray(pos, dtype=float)
        free = speed >= TRANSIT_SPEED
        if rot is None:
            rot = hand.rot
        elif not free:  # a straight line keeps the hand's side: the flip nearest the current rotation
            rot = plan.nearest_flip(np.asarray(rot, dtype=float))
        if not free and check and not yaw_free:  # followed as a straight tool line: check it that way
            reached = plan.straight_line(Leg(hand.pos, hand.rot, hand.q, speed), pos, rot, 0.004)
            if reached is not None:
                solution = IKSolution(reached, 0.0, 0.0)
            else:
                solution = plan.solve(pos, rot, hand.q)
                if solution.ok():
                    raise SkillFailure(
                        f"{what} {fmt(pos)}: no straight way there for the {self.robot.name} "
                        f"that touches nothing but what it works on (it would {plan.obstacle(hand.q, solution.qpos)})"
                    )
        elif rot is hand.rot:
            solution = plan.solve(pos, rot, hand.q, yaw_free=yaw_free)
        else:
            rot, solution = plan.solve_flip(pos, np.asarray(rot, dtype=float), hand.q, yaw_free=yaw_free)
        if not solution.ok(FREE_TOLERANCE if free else 0.004):
            distance = float(np.linalg.norm(pos[:2] - self.base[:2]))
            raise SkillFailure(
                f"{what} {fmt(pos)} is out of reach for the {self.robot.name} "
                f"({distance:.2f} m from its base, reach {self.robot.reach:.2f} m; "
                f"IK misses by {solution.position_error * 1000:.0f} mm, "
                f"{np.rad2deg(solution.rotation_error):.0f} deg)"
            )
        if check and free and not plan.clear_path(hand.q, solution.qpos):
            raise SkillFailure(f"{what} {fmt(pos)}: the {self.robot.name} would {plan.obstacle(hand.q, solution.qpos)}")
        if yaw_free or free:
            pos, rot = self.ik.tool_pose(solution.qpos)
        seconds = max(seconds or 0.0, self.duration(pos, rot, speed, solution.qpos))
        hand.pos, hand.rot, hand.q = pos, rot, solution.qpos
        if gripper is not None:
            hand.gripper = gripper
        return Move(pos, rot, hand.gripper, float(seconds), solution.qpos, free=free)

    def planned(
        self,
        pos: np.ndarray,
        rot: np.ndarray,
        q: np.ndarray,
        *,
        speed: float,
        straight: bool = False,
        joints: bool = False,
    ) -> Move:
        """A move to a pose whose joints ``q`` the planner already found (and checked): through joint
        space at transit speed or where ``joints`` says so, else along a straight line."""
        hand = self.hand
        free = (speed >= TRANSIT_SPEED or joints) and not straight
        if free:  # through joint space the tool ends where the joints put it (within the free tolerance)
            pos, rot = self.ik.tool_pose(q)
        seconds = self.duration(pos, rot, speed, q)
        hand.pos, hand.rot, hand.q = np.asarray(pos, float), rot, q
        return Move(hand.pos, rot, hand.gripper, seconds, q, free=free)

    def duration(self, pos: np.ndarray, rot: np.ndarray, speed: float, q: np.ndarray | None = None) -> float:
        """Duration of a move from the hand's planned pose: its length at ``speed`` (at most
        :data:`HELD_SPEED` with something in the hand), its turn, or the time the slowest joint needs
        to reach ``q`` at the peak of the minimum-jerk profile, whichever takes longest. The joints
        bound a straight move too: a quarter turn of the hand can be most of a turn of a wrist joint
        (the UR5e's, damped to under 1 rad/s), which then lags the line and drags the tool off it."""
        hand = self.hand
        if hand.held is not None:
            speed = min(speed, HELD_SPEED)
        joints = 0.0 if q is None else MIN_JERK_PEAK * float(np.max(np.abs(np.asarray(q) - hand.q) / self.joint_speed))
        return max(
            MIN_SECONDS,
            float(np.linalg.norm(np.asarray(pos) - hand.pos)) / speed,
            rotation_angle(hand.rot, rot) / TURN_SPEED,
            joints,
        )

    def grip(self, gripper: float, seconds: float = 0.5) -> Move:
        """Open (1) or close (0) the gripper where the tool stands."""
        hand = self.hand
        hand.gripper = gripper
        return Move(hand.pos, hand.rot, gripper, seconds, hand.q)

    def hold(self, seconds: float) -> Move:
        """Stand still ``seconds`` (at least one control step)."""
        hand = self.hand
        return Move(hand.pos, hand.rot, hand.gripper, max(seconds, self.world.control_dt), hand.q)


SKILL_RUNTIMES: Plugins[Skill] = Plugins("skill", SkillFailure)


def skill(spec: type[StepSpec]) -> Callable[[Skill], Skill]:
    """Register the runtime of the skill step ``spec`` (registered in :mod:`pipette_cli.specs.expert`) by its name."""
    return SKILL_RUNTIMES.register(SKILLS.name_of(spec))
