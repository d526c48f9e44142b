"""Render kept rollouts from their recorded states, with perturbed lights and cameras.

Frames equal those rendered during simulation, bit for bit. After ``mj_step`` MuJoCo's
kinematics (``xpos``, ``cam_xpos``, ...) belong to the state *before* the last substep's
integration, and :class:`~pipette_cli.sim.env.PipetteEnv` renders that data. So the frame of
control step ``t > 0`` is reproduced by restoring ``sim_state[t - 1]`` and re-running action
``t - 1`` (``substeps`` calls of ``mj_step``, bit-exact); step 0 is the restored start after
``mj_forward``. Only fresh steps (10 Hz) are rendered; stale ones reuse the frame.

Lighting, camera pose and surface colour do not touch the physics: lights are scaled in
``model.light_*`` (and the headlight), cameras moved in ``model.cam_pos``, the bench's and the
floor's materials mixed with other colours in ``model.mat_rgba``; all are restored afterwards. Evaluation suites
apply their per-episode conditions through the same :func:`visual_perturbation`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import mujoco
import numpy as np

from pipette_cli.augment.perturb import VariantPlan
from pipette_cli.augment.simulate import Rollout, restore
from pipette_cli.demos.recorder import SIM_STATE
from pipette_cli.sim.render import CameraRig
from pipette_cli.sim.scene import BENCH, FLOOR_MATERIAL
from pipette_cli.sim.world import World

_LIGHT_FIELDS = ("light_ambient", "light_diffuse", "light_specular", "light_intensity")
_HEADLIGHT_FIELDS = ("ambient", "diffuse", "specular")
_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)


def surface_parts(model: mujoco.MjModel) -> dict[str, tuple[list[int], list[int]]]:
    """The materials and geoms of each recolourable surface: the bench's own and the floor's. A
    geom shows its material's colour unless it sets its own (MuJoCo: an rgba other than the
    default takes precedence), so the materials and the geoms that set a colour are mixed."""
    mats = [model.mat(i).name for i in range(model.nmat)]
    floor = [i for i, name in enumerate(mats) if name == FLOOR_MATERIAL]
    bench = [i for i, name in enumerate(mats) if name.startswith(BENCH + "/")]
    own = ~np.all(np.isclose(model.geom_rgba, _DEFAULT_RGBA), axis=1)
    names = [model.geom(i).name for i in range(model.ngeom)]
    return {
        "bench": (bench, [i for i, name in enumerate(names) if own[i] and name.startswith(BENCH + "/")]),
        "floor": (floor, [i for i in range(model.ngeom) if own[i] and model.geom_matid[i] in floor]),
    }


@contextmanager
def visual_perturbation(model: mujoco.MjModel, plan: VariantPlan, camera_ids: dict[str, int]) -> Iterator[None]:
    """Scale every light by ``plan.light_scale``, move cameras by ``plan.camera_offsets`` and mix
    ``plan.surface_tint`` into the surfaces' colours for the block."""
    saved = {name: getattr(model, name).copy() for name in _LIGHT_FIELDS}
    saved_head = {name: np.array(getattr(model.vis.headlight, name)) for name in _HEADLIGHT_FIELDS}
    saved_cam = model.cam_pos.copy()
    saved_mat, saved_geom = model.mat_rgba.copy(), model.geom_rgba.copy()
    try:
        if plan.surface_tint:
            parts = surface_parts(model)
            w = plan.surface_blend
            for surface, tint in plan.surface_tint.items():
                mats, geoms = parts[surface]
                model.mat_rgba[mats, :3] = (1.0 - w) * saved_mat[mats, :3] + w * tint
                model.geom_rgba[geoms, :3] = (1.0 - w) * saved_geom[geoms, :3] + w * tint
        if plan.light_scale != 1.0:
            for name in _LIGHT_FIELDS:
                getattr(model, name)[:] = saved[name] * plan.light_scale
            if plan.headlight:
                for name in _HEADLIGHT_FIELDS:
                    setattr(model.vis.headlight, name, saved_head[name] * plan.light_scale)
        for camera, delta in plan.camera_offsets.items():
            model.cam_pos[camera_ids[camera]] = saved_cam[camera_ids[camera]] + delta
        yield
    finally:
        for name in _LIGHT_FIELDS:
            getattr(model, name)[:] = saved[name]
        for name in _HEADLIGHT_FIELDS:
            setattr(model.vis.headlight, name, saved_head[name])
        model.cam_pos[:] = saved_cam
        model.mat_rgba[:] = saved_mat
        model.geom_rgba[:] = saved_geom


def fresh_steps(num_steps: int, vision_every: int) -> np.ndarray:
    """Rows whose frame is new: control step ``k = t + 1`` with ``(k - 1) mod d_v == 0``."""
    return np.arange(num_steps) % vision_every == 0


def view_key(plan: VariantPlan, camera: str) -> tuple[object, ...]:
    """What one camera's frames of a given physics depend on: the lights, that camera's pose and
    the surfaces' colours."""
    delta = plan.camera_offsets.get(camera)
    tints = (
        plan.surface_blend,
        *((n, tuple(np.asarray(t, dtype=float).tolist())) for n, t in sorted(plan.surface_tint.items())),
    )
    return (
        plan.light_scale,
        plan.headlight,
        None if delta is None else tuple(np.asarray(delta, dtype=float).tolist()),
        tints,
    )


def render_rollout(
    world: World,
    rig: CameraRig,
    seed: int,
    rollout: Rollout,
    plan: VariantPlan,
    *,
    vision_every: int,
    on_capture: Callable[[int, dict[str, np.ndarray]], None] | None = None,
    known: dict[str, list[np.ndarray]] | None = None,
) -> list[dict[str, np.ndarray]]:
    """One dict of camera frames per row; stale rows share the previous row's arrays.

    Args:
        on_capture: Called as ``on_capture(t, views)`` after each fresh row.
        known: Per camera, this rollout's fresh frames already rendered under the same lights and
            camera pose (another variant of the same physics); those cameras are not rendered again.
    """
    m, d = world.model, world.data
    known = known or {}
    cameras = [c for c in rig.ids if c not in known]
    fresh = fresh_steps(rollout.num_steps, vision_every)
    frames: list[dict[str, np.ndarray]] = []
    with visual_perturbation(m, plan, rig.ids):
        if cameras:
            restore(world, seed, rollout.states[0], plan.offset)
        for t in range(rollout.num_steps):
            if not fresh[t]:
                frames.append(frames[-1])
                continue
            if cameras and t > 0:
                mujoco.mj_setState(m, d, rollout.states[t - 1], SIM_STATE)
                world.apply_action(rollout.applied[t - 1])
                for _ in range(world.substeps):
                    mujoco.mj_step(m, d)
            elif cameras:
                mujoco.mj_forward(m, d)  # camera poses follow the moved cameras
            capture = int(np.count_nonzero(fresh[:t]))
            views = {c: known[c][capture] if c in known else rig.render(d, c) for c in rig.ids}
            frames.append(views)
            if on_capture is not None:
                on_capture(t, views)
    return frames
