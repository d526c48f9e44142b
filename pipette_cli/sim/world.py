"""A task's compiled scene with its robot, mechanisms and evaluator: reset, act, step.

:class:`World` is the physics core shared by every workflow (gym env, scripted experts,
teleoperation, recording, augmentation, evaluation). It implements the
:class:`~pipette_cli.evaluators.base.WorldState` protocol the evaluators read. It renders
nothing; see :mod:`.render`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator
from functools import cached_property

import mujoco
import numpy as np

from pipette_cli.errors import SimError, suggest
from pipette_cli.evaluators.base import MechanismState, Verdict, make_evaluator
from pipette_cli.sim.actuation import Memory
from pipette_cli.sim.mechanisms import make_mechanism, memory_size
from pipette_cli.sim.meshes import MeshDetail
from pipette_cli.sim.robots import gripper_ctrl
from pipette_cli.sim.scene import ROBOT_PREFIX, compile_scene, euler_to_quat, make_scene_spec
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

PENETRATION_TOLERANCE = 0.004
"""Metres of initial interpenetration between scene objects refused at build time."""
CHECKED_SEEDS = range(20)
"""Seeds whose initial state a world checks when it is built (0.4 ms a reset)."""


class World:
    """One task's MuJoCo model and data, reset per episode from a seed.

    Args:
        task: The task spec.
        meshes: ``"decimated"`` swaps heavy visual-only meshes for simplified ones (the
            ``fast`` render profile, :mod:`.meshes`); the physics does not change.
        check: Refuse a scene that fails :meth:`check_initial_state` (``False``: build it anyway,
            to list every problem with :meth:`interpenetrations` and :meth:`out_of_reach`).
    """

    def __init__(self, task: TaskSpec, *, meshes: MeshDetail = "full", check: bool = True) -> None:
        self.task = task
        self.meshes = meshes
        spec, self.robot, self.objects = make_scene_spec(task)
        self.spec = spec
        self._memory: dict[str, tuple[int, int]] = {}
        for mech in task.scene.mechanisms:  # each mechanism's state lives in its slots of data.userdata
            self._memory[mech.name] = (spec.nuserdata, memory_size(mech))
            spec.nuserdata += self._memory[mech.name][1]
        self.model = compile_scene(spec, task, meshes=meshes)
        self.data = mujoco.MjData(self.model)
        self.control_dt = 1.0 / task.timing.control_hz
        self.substeps = task.timing.substeps
        self._refs: dict[str, tuple[str, int]] = {}
        m = self.model
        self.arm_joint_ids = np.array(
            [self._id(mujoco.mjtObj.mjOBJ_JOINT, ROBOT_PREFIX + j) for j in self.robot.arm_joints]
        )
        self.arm_qpos_adr = m.jnt_qposadr[self.arm_joint_ids]
        self.arm_dof_adr = m.jnt_dofadr[self.arm_joint_ids]
        self.arm_actuator_ids = np.array(
            [self._id(mujoco.mjtObj.mjOBJ_ACTUATOR, ROBOT_PREFIX + a) for a in self.robot.arm_actuators]
        )
        self.gripper_actuator_id = self._id(mujoco.mjtObj.mjOBJ_ACTUATOR, ROBOT_PREFIX + self.robot.gripper.actuator)
        gripper_joint = self._id(mujoco.mjtObj.mjOBJ_JOINT, ROBOT_PREFIX + self.robot.gripper.joint)
        self.gripper_qpos_adr = int(m.jnt_qposadr[gripper_joint])
        self.gripper_range = m.jnt_range[gripper_joint].copy()
        self.tcp_site_id = self._id(mujoco.mjtObj.mjOBJ_SITE, ROBOT_PREFIX + "tcp")
        self.arm_range = m.jnt_range[self.arm_joint_ids].copy()
        self._nominal_body_pos = m.body_pos.copy()
        self._nominal_body_quat = m.body_quat.copy()
        self._switch_off_object_actuators()
        self.mechanisms = {mech.name: make_mechanism(mech, self) for mech in task.scene.mechanisms}
        self.evaluator = make_evaluator(task.success)
        self.verdict = Verdict()
        self.step_count = 0
        self.seed: int | None = None
        if check:
            self.check_initial_state()

    # ------------------------------------------------------------------ lookups
    def _id(self, kind: mujoco.mjtObj, name: str) -> int:
        index = mujoco.mj_name2id(self.model, kind, name)
        if index < 0:
            raise SimError(f"{self.task.id}: the scene has no {kind.name.removeprefix('mjOBJ_').lower()} {name!r}")
        return index

    def _resolve(self, ref: str) -> tuple[str, int]:
        """``object`` -> its root body; ``object/part`` -> the site, body or joint of that name."""
        if ref in self._refs:
            return self._refs[ref]
        obj, _, part = ref.partition("/")
        found: tuple[str, int] | None
        if obj not in self.objects:
            raise SimError(f"{self.task.id}: {ref!r} names no scene object; {suggest(obj, self.objects)}")
        if not part:
            found = ("body", self._id(mujoco.mjtObj.mjOBJ_BODY, self.objects[obj].root_body))
        else:
            found = None
            for kind, obj_type in (
                ("site", mujoco.mjtObj.mjOBJ_SITE),
                ("body", mujoco.mjtObj.mjOBJ_BODY),
                ("joint", mujoco.mjtObj.mjOBJ_JOINT),
            ):
                index = mujoco.mj_name2id(self.model, obj_type, ref)
                if index >= 0:
                    found = (kind, index)
                    break
            if found is None:
                names = [self.model.site(i).name for i in range(self.model.nsite)]
                names += [self.model.body(i).name for i in range(self.model.nbody)]
                names += [self.model.joint(i).name for i in range(self.model.njnt)]
                raise SimError(
                    f"{self.task.id}: asset {self.objects[obj].asset!r} has no site, body or joint {part!r}; "
                    f"{suggest(ref, [n for n in names if n.startswith(obj + '/')])}"
                )
        self._refs[ref] = found
        return found

    def site_id(self, ref: str) -> int:
        kind, index = self._resolve(ref)
        if kind != "site":
            raise SimError(f"{self.task.id}: {ref!r} is a {kind}, expected a site")
        return index

    def joint_id(self, ref: str) -> int:
        kind, index = self._resolve(ref)
        if kind != "joint":
            raise SimError(f"{self.task.id}: {ref!r} is a {kind}, expected a joint")
        return index

    def body_id(self, ref: str) -> int:
        kind, index = self._resolve(ref)
        if kind == "site":
            return int(self.model.site_bodyid[index])
        if kind == "joint":
            return int(self.model.jnt_bodyid[index])
        return index

    def actuator_for_joint(self, ref: str) -> int:
        joint = self.joint_id(ref)
        for i in range(self.model.nu):
            if self.model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT and self.model.actuator_trnid[i, 0] == joint:
                return i
        raise SimError(f"{self.task.id}: joint {ref!r} has no actuator to drive it")

    @cached_property
    def object_actuators(self) -> list[int]:
        return [i for i in range(self.model.nu) if not self.model.actuator(i).name.startswith(ROBOT_PREFIX)]

    def _switch_off_object_actuators(self) -> None:
        for i in self.object_actuators:
            self.model.actuator_gainprm[i, :] = 0.0
            self.model.actuator_biasprm[i, :] = 0.0

    # ------------------------------------------------------------- WorldState
    @property
    def time(self) -> float:
        return float(self.data.time)

    def position(self, ref: str) -> np.ndarray:
        kind, index = self._resolve(ref)
        if kind == "site":
            return self.data.site_xpos[index].copy()
        if kind == "joint":
            return self.data.xanchor[index].copy()
        return self.data.xpos[index].copy()

    def rotation(self, ref: str) -> np.ndarray:
        kind, index = self._resolve(ref)
        if kind == "site":
            return self.data.site_xmat[index].reshape(3, 3).copy()
        return self.data.xmat[self.body_id(ref)].reshape(3, 3).copy()

    def joint(self, ref: str) -> float:
        index = self.joint_id(ref)
        value = float(self.data.qpos[self.model.jnt_qposadr[index]])
        return float(np.rad2deg(value)) if self.model.jnt_type[index] == mujoco.mjtJoint.mjJNT_HINGE else value

    def bbox_xy(self, ref: str) -> tuple[float, float]:
        body = self.body_id(ref)
        lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
        for g in np.flatnonzero(self.model.geom_bodyid == body):
            if self.model.geom_contype[g] == 0 and self.model.geom_conaffinity[g] == 0:
                continue  # visual only
            center = self.data.geom_xpos[g] + self.data.geom_xmat[g].reshape(3, 3) @ self.model.geom_aabb[g, :3]
            half = np.abs(self.data.geom_xmat[g].reshape(3, 3)) @ self.model.geom_aabb[g, 3:]
            lo = np.minimum(lo, (center - half)[:2])
            hi = np.maximum(hi, (center + half)[:2])
        if not np.all(np.isfinite(lo)):
            raise SimError(f"{self.task.id}: {ref!r} has no collision geometry to measure")
        size = hi - lo
        return float(size[0]), float(size[1])

    def _nearest_xy(self, name: str, point: np.ndarray) -> float:
        """Horizontal distance from ``point`` to the nearest part of object ``name``'s collision
        geometry (an instrument is in reach when its front is, not its centre)."""
        m, d = self.model, self.data
        bodies = [b for b, owner in enumerate(self._owners) if owner == name]
        best = np.inf
        for g in np.flatnonzero(np.isin(m.geom_bodyid, bodies)):
            if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                continue
            center = d.geom_xpos[g] + d.geom_xmat[g].reshape(3, 3) @ m.geom_aabb[g, :3]
            half = np.abs(d.geom_xmat[g].reshape(3, 3)) @ m.geom_aabb[g, 3:]
            nearest = np.clip(point, center[:2] - half[:2], center[:2] + half[:2])
            best = min(best, float(np.linalg.norm(nearest - point)))
        return best if np.isfinite(best) else float(np.linalg.norm(self.position(name)[:2] - point))

    @cached_property
    def _owners(self) -> list[str]:
        """Each body's owner: the scene object (or ``robot``) whose name prefixes it."""
        return [self.model.body(b).name.split("/", 1)[0] for b in range(self.model.nbody)]

    def _robot_contacts(self) -> Iterator[tuple[int, int]]:
        """``(contact index, other body)`` for each contact between the robot and a body not its own."""
        m, d, owners = self.model, self.data, self._owners
        robot = ROBOT_PREFIX.rstrip("/")
        for i, contact in enumerate(d.contact[: d.ncon]):
            b1, b2 = int(m.geom_bodyid[contact.geom1]), int(m.geom_bodyid[contact.geom2])
            for mine, other in ((b1, b2), (b2, b1)):
                if owners[mine] == robot and owners[other] != robot:
                    yield i, other

    def robot_contacts(self) -> set[int]:
        """The bodies, other than the robot's own, that the robot touches now."""
        return {other for _, other in self._robot_contacts()}

    def robot_force(self, bodies: Iterable[int]) -> float:
        """Newtons the robot presses on ``bodies`` now (normal forces of their contacts, summed)."""
        wanted, force, total = set(bodies), np.zeros(6), 0.0
        for i, other in self._robot_contacts():
            if other in wanted:
                mujoco.mj_contactForce(self.model, self.data, i, force)
                total += abs(float(force[0]))
        return total

    def robot_touches(self, ref: str) -> bool:
        if "/" not in ref and ref not in self.objects:
            raise SimError(f"{self.task.id}: {ref!r} names no scene object; {suggest(ref, self.objects)}")
        touched = self.robot_contacts()
        if "/" in ref:
            return self.body_id(ref) in touched
        return any(self._owners[b] == ref for b in touched)

    def mechanism(self, name: str) -> MechanismState:
        try:
            return self.mechanisms[name].state()
        except KeyError:
            raise SimError(f"{self.task.id}: no mechanism {name!r}; {suggest(name, self.mechanisms)}") from None

    # ------------------------------------------------------------ instruments
    def mechanism_memory(self, name: str, slots: tuple[str, ...] | list[str]) -> Memory:
        """The ``userdata`` slots reserved for mechanism ``name`` at build time, by slot name."""
        offset, size = self._memory[name]
        if len(slots) != size:
            raise SimError(
                f"{self.task.id}: mechanism {name!r} asks for {len(slots)} memory slots, {size} were reserved"
            )
        return Memory(self, offset, slots)

    @cached_property
    def instrument_names(self) -> list[str]:
        """``mechanism.value`` for every value the scene's mechanisms report, in a fixed order."""
        return [f"{name}.{key}" for name, mech in self.mechanisms.items() for key in mech.names()]

    def instrument_state(self) -> np.ndarray:
        """The values of :attr:`instrument_names` now (float64; 1/0 for flags)."""
        out: list[float] = []
        for mech in self.mechanisms.values():
            values = mech.state().values
            out += [values[key] for key in mech.names()]
        return np.asarray(out, dtype=np.float64)

    @property
    def stage(self) -> int:
        """The stage being worked on: a ``sequence`` criterion's stage index (the number of stages once
        it succeeded); for other criteria 0, or 1 once it succeeded."""
        stage = getattr(self.evaluator, "stage", None)
        if isinstance(stage, int):
            return stage
        return int(self.verdict.success)

    def instruction(self) -> str:
        """The language instruction for now: the current stage's own, where the task's ``sequence``
        criterion gives its stages instructions, else the task's."""
        own = getattr(self.evaluator, "stage_instruction", None)
        text = own() if callable(own) else None
        return text or self.task.instruction

    # ------------------------------------------------------------------ robot
    def tcp_position(self) -> np.ndarray:
        return self.data.site_xpos[self.tcp_site_id].copy()

    def tcp_rotation(self) -> np.ndarray:
        return self.data.site_xmat[self.tcp_site_id].reshape(3, 3).copy()

    def arm_qpos(self) -> np.ndarray:
        return self.data.qpos[self.arm_qpos_adr].copy()

    def state(self) -> np.ndarray:
        """Proprioceptive state s_t = [arm joints..., gripper joint] (paper A.3)."""
        return np.append(self.arm_qpos(), self.data.qpos[self.gripper_qpos_adr]).astype(np.float32)

    @property
    def action_dim(self) -> int:
        return self.robot.arm_dof + 1

    def apply_action(self, action: np.ndarray) -> None:
        """Set arm joint targets and the binary gripper command (u >= 0.5 opens)."""
        action = np.asarray(action, dtype=float)
        if action.shape != (self.action_dim,):
            raise SimError(f"{self.task.id}: action must have shape ({self.action_dim},), got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise SimError(f"{self.task.id}: action contains NaN or inf")
        targets = np.clip(action[:-1], self.arm_range[:, 0], self.arm_range[:, 1])
        self.data.ctrl[self.arm_actuator_ids] = targets
        self.data.ctrl[self.gripper_actuator_id] = gripper_ctrl(self.robot, float(action[-1]))

    # ------------------------------------------------------------------ episode
    def reset(self, seed: int) -> None:
        """Restore the nominal scene, apply the task's randomisation for ``seed``, settle."""
        m, d = self.model, self.data
        rng = np.random.default_rng(seed)
        self.seed = seed
        m.body_pos[:] = self._nominal_body_pos
        m.body_quat[:] = self._nominal_body_quat
        mujoco.mj_resetData(m, d)
        initial = np.asarray(self.task.embodiment.initial_joints)
        d.qpos[self.arm_qpos_adr] = initial
        d.ctrl[self.arm_actuator_ids] = initial
        opened = self.task.embodiment.gripper == "open"
        d.ctrl[self.gripper_actuator_id] = gripper_ctrl(self.robot, 1.0 if opened else 0.0)
        for obj in self.task.scene.objects:
            if obj.randomize is None:
                continue
            dx, dy = (rng.uniform(-r, r) if r > 0 else 0.0 for r in obj.randomize.xy)
            dyaw = rng.uniform(-obj.randomize.yaw_deg, obj.randomize.yaw_deg) if obj.randomize.yaw_deg else 0.0
            quat = np.zeros(4)
            mujoco.mju_mulQuat(quat, euler_to_quat((0.0, 0.0, dyaw)), euler_to_quat(obj.pose.euler_deg))
            pos = np.asarray(obj.pose.pos) + [dx, dy, 0.0]
            info = self.objects[obj.name]
            body = self._id(mujoco.mjtObj.mjOBJ_BODY, info.root_body)
            if info.free:
                adr = m.jnt_qposadr[m.body_jntadr[body]]
                d.qpos[adr : adr + 3] = pos
                d.qpos[adr + 3 : adr + 7] = quat
            else:
                m.body_pos[body] = pos
                m.body_quat[body] = quat
        for state in self.task.scene.joint_states:
            index = self.joint_id(state.joint)
            value = state.value + (rng.uniform(-state.randomize, state.randomize) if state.randomize else 0.0)
            hinge = m.jnt_type[index] == mujoco.mjtJoint.mjJNT_HINGE
            d.qpos[m.jnt_qposadr[index]] = np.deg2rad(value) if hinge else value
        mujoco.mj_forward(m, d)
        self.restart()

    def restart(self) -> None:
        """Start the episode from the state the world is in now: mechanisms, the step count and the
        evaluator begin again (the end of :meth:`reset`; again after a scene object is moved
        between the reset and the first step, so it is judged from where it now starts)."""
        for mech in self.mechanisms.values():
            mech.reset()
        self.step_count = 0
        self.evaluator.reset(self)
        self.verdict = Verdict()

    def step(self, action: np.ndarray) -> Verdict:
        """Apply ``action`` for one control period (``substeps`` physics steps), then evaluate."""
        self.apply_action(action)
        for _ in range(self.substeps):
            mujoco.mj_step(self.model, self.data)
        for mech in self.mechanisms.values():
            mech.update()
        if not np.all(np.isfinite(self.data.qpos)):
            raise SimError(f"{self.task.id}: simulation diverged (NaN in qpos) at t={self.data.time:.3f}s")
        self.step_count += 1
        self.verdict = self.evaluator.update(self)
        return self.verdict

    # ------------------------------------------------------------- build checks
    def check_initial_state(self) -> None:
        """Refuse scenes whose objects interpenetrate at reset or whose targets stand out of the
        robot's reach: the first of :meth:`initial_state_problems` over the task's targets."""
        for loc, message in self.initial_state_problems(self.task.targets):
            raise SimError(f"{self.task.id}: {'.'.join(map(str, loc))}: {message}")

    def initial_state_problems(self, names: Iterable[str]) -> list[tuple[tuple[str | int, ...], str]]:
        """:meth:`interpenetrations` and :meth:`out_of_reach` (of ``names``) at the reset of each
        seed of :data:`CHECKED_SEEDS`, each field path once (its first seed): a randomised pose can
        push together what the nominal layout keeps apart. The world is left reset to seed 0."""
        problems: dict[tuple[str | int, ...], str] = {}
        for seed in CHECKED_SEEDS:
            self.reset(seed=seed)
            for loc, message in self.interpenetrations() + self.out_of_reach(names):
                problems.setdefault(loc, message + (f" on seed {seed} (a randomised layout)" if seed else ""))
        self.reset(seed=0)
        return list(problems.items())

    def interpenetrations(self) -> list[tuple[tuple[str | int, ...], str]]:
        """``(field path, message)`` for each two owners (scene objects, the bench, the robot) whose
        bodies interpenetrate now by more than :data:`PENETRATION_TOLERANCE`; the object listed last
        in the task (the one added) is blamed."""
        m, d = self.model, self.data
        robot = ROBOT_PREFIX.rstrip("/")
        index = {obj.name: i for i, obj in enumerate(self.task.scene.objects)}
        depths: dict[tuple[str, ...], float] = {}
        for contact in d.contact[: d.ncon]:
            if contact.dist >= -PENETRATION_TOLERANCE:
                continue
            bodies = m.geom_bodyid[contact.geom1], m.geom_bodyid[contact.geom2]
            owners = tuple(sorted({self._owners[b] for b in bodies}))
            if owners != (robot,):  # the robot's links touch each other by design
                depths[owners] = max(depths.get(owners, 0.0), -float(contact.dist))
        problems: list[tuple[tuple[str | int, ...], str]] = []
        for owners, depth in sorted(depths.items()):
            named = [index[o] for o in owners if o in index]
            loc: tuple[str | int, ...] = ("embodiment", "base") if robot in owners else ("scene",)
            if named:
                loc = ("scene", "objects", max(named), "pose")
            message = f"{' and '.join(owners)} interpenetrate by {depth * 1000:.1f} mm at reset; move them apart"
            problems.append((loc, message))
        return problems

    def out_of_reach(self, names: Iterable[str]) -> list[tuple[tuple[str | int, ...], str]]:
        """``(field path, message)`` for each object of ``names`` whose collision geometry is all beyond
        the robot's reach from its base axis, where it stands now."""
        base = np.asarray(self.task.embodiment.base.pos)
        reach = self.robot.reach
        problems: list[tuple[tuple[str | int, ...], str]] = []
        for i, obj in enumerate(self.task.scene.objects):
            if obj.name not in names:
                continue
            distance = self._nearest_xy(obj.name, base[:2])
            if distance > reach:
                message = (
                    f"{obj.name!r} is {distance:.2f} m from the {self.robot.name} base, beyond its {reach} m reach"
                )
                problems.append((("scene", "objects", i, "pose"), message))
        return problems
