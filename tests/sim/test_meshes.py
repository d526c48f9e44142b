"""Decimated visual meshes (the ``fast`` profile): same physics bit for bit, same silhouette, cached."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from pipette_cli.augment.simulate import Rollout, replay_check
from pipette_cli.demos.recorder import sim_state
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.registry import load_registry
from pipette_cli.sim import meshes
from pipette_cli.sim.render import CameraRig
from pipette_cli.sim.robots import home_joints
from pipette_cli.sim.scene import CAMERA_NAMES, ROBOT_PREFIX
from pipette_cli.sim.world import World

pytestmark = pytest.mark.render
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "augment"))
from raw_demo import TASK, raw_demo  # noqa: E402

SILHOUETTE_IOU = 0.97
"""Smallest intersection-over-union of the robot's segmentation mask, decimated vs full meshes,
in any of the three views of any tested arm pose (measured: >= 0.98 at keep = 0.08)."""


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch) -> Path:
    folder = tmp_path_factory.getbasetemp() / "mesh_cache"
    monkeypatch.setenv(meshes.CACHE_ENV, str(folder))
    return folder


def _tasks():
    registry = load_registry([])
    tube = registry.get("PickUpTestTube")
    embodiment = tube.embodiment.model_copy(
        update={"robot": "ur5e_robotiq", "initial_joints": home_joints("ur5e_robotiq").tolist()}
    )
    return {
        "franka_panda": tube,
        "agilex_piper": registry.get("PlaceFlaskOnShaker"),
        "ur5e_robotiq": tube.model_copy(update={"embodiment": embodiment}),
    }


TASKS = _tasks()


def _robot_geoms(model: mujoco.MjModel) -> np.ndarray:
    return np.array([model.body(int(b)).name.startswith(ROBOT_PREFIX) for b in model.geom_bodyid])


def _robot_faces(model: mujoco.MjModel) -> int:
    """Triangles of the robot's visual (non-colliding) mesh geoms."""
    visual = (model.geom_contype == 0) & (model.geom_conaffinity == 0) & (model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
    return int(sum(model.mesh_facenum[model.geom_dataid[g]] for g in np.flatnonzero(_robot_geoms(model) & visual)))


@pytest.mark.parametrize("robot", list(TASKS), ids=list(TASKS))
def test_decimated_meshes_leave_the_physics_bit_identical(robot: str) -> None:
    task = TASKS[robot]
    full, fast = World(task), World(task, meshes="decimated")
    assert _robot_faces(fast.model) * 3 < _robot_faces(full.model), "the robot's visual meshes were not simplified"
    for name in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "geom_contype", "geom_conaffinity"):
        np.testing.assert_array_equal(getattr(fast.model, name), getattr(full.model, name), err_msg=name)
    colliding = (full.model.geom_contype != 0) | (full.model.geom_conaffinity != 0)
    for name in ("geom_size", "geom_pos", "geom_quat", "geom_type", "geom_dataid"):
        np.testing.assert_array_equal(
            getattr(fast.model, name)[colliding], getattr(full.model, name)[colliding], err_msg=name
        )
    rng = np.random.default_rng(0)
    full.reset(5)
    fast.reset(5)
    start = full.arm_qpos()
    for k in range(90):  # sweep the arm, close the gripper halfway through
        action = np.append(start + 0.3 * np.sin(0.1 * k + rng.uniform(0, 1, len(start))), float(k < 45))
        verdicts = full.step(action), fast.step(action)
        assert sim_state(full.model, full.data).tobytes() == sim_state(fast.model, fast.data).tobytes(), f"step {k}"
        assert verdicts[0] == verdicts[1]


def test_a_demo_recorded_with_decimated_meshes_replays_bit_for_bit_with_full_ones(tmp_path_factory) -> None:
    """collect renders with the fast profile (decimated); its grasp replays exactly without it."""
    record = read_episode(scan(raw_demo(tmp_path_factory)).episodes[0])
    assert replay_check(World(load_registry([]).get(TASK)), record.summary.seed, Rollout.from_record(record)) is None


def _robot_masks(world: World, poses: list[np.ndarray], size: int) -> list[np.ndarray]:
    rig = CameraRig(world.model, size, size, "fast")
    rig.renderer.enable_segmentation_rendering()
    robot = _robot_geoms(world.model)
    masks = []
    try:
        for q in poses:
            world.reset(0)
            world.data.qpos[world.arm_qpos_adr] = q
            mujoco.mj_forward(world.model, world.data)
            for camera in CAMERA_NAMES:
                seg = rig.render(world.data, camera)
                ids, kinds = seg[..., 0], seg[..., 1]
                masks.append((kinds == mujoco.mjtObj.mjOBJ_GEOM) & (ids >= 0) & robot[np.clip(ids, 0, None)])
    finally:
        rig.close()
    return masks


@pytest.mark.parametrize("robot", ["franka_panda", "agilex_piper"])
def test_decimation_changes_the_robot_silhouette_by_less_than_the_tolerance(robot: str) -> None:
    task = TASKS[robot]
    full, fast = World(task), World(task, meshes="decimated")
    full.reset(0)
    home = full.arm_qpos()
    rng = np.random.default_rng(1)
    poses = [home] + [np.clip(home + rng.uniform(-0.4, 0.4, len(home)), *full.arm_range.T) for _ in range(3)]
    reference, decimated = _robot_masks(full, poses, 160), _robot_masks(fast, poses, 160)
    seen = [i for i, m in enumerate(reference) if m.sum() > 50]
    assert len(seen) >= len(poses) * 2, "the robot should be in view in most captures"
    ious = [(reference[i] & decimated[i]).sum() / (reference[i] | decimated[i]).sum() for i in seen]
    assert min(ious) >= SILHOUETTE_IOU, f"robot silhouette IoU {min(ious):.4f} < {SILHOUETTE_IOU}"


def test_simplified_meshes_are_cached_by_content(private_cache: Path, monkeypatch) -> None:
    task = TASKS["franka_panda"]
    for leftover in private_cache.glob("*.npz"):
        leftover.unlink()
    first = World(task, meshes="decimated")
    full = World(task)
    chosen = [full.model.mesh(name).id for name in meshes.visual_geoms(full.spec, full.model)]
    assert 0 < len(list(private_cache.glob("*.npz"))) <= len(chosen)
    import fast_simplification

    def refuse(*args, **kwargs):
        raise AssertionError("a cached mesh was simplified again")

    monkeypatch.setattr(fast_simplification, "simplify", refuse)
    again = World(task, meshes="decimated")
    np.testing.assert_array_equal(again.model.mesh_vert, first.model.mesh_vert)
    vertices, faces = meshes.mesh_arrays(full.model, chosen[0])
    with pytest.raises(AssertionError, match="simplified again"):
        meshes.simplify(vertices * 1.01, faces)  # other content, other key


def test_cache_folder_follows_the_environment(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setenv(meshes.CACHE_ENV, str(tmp_path / "here"))
    assert meshes.cache_dir() == tmp_path / "here"
    monkeypatch.delenv(meshes.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert meshes.cache_dir() == tmp_path / "xdg" / "pipette" / "meshes"
