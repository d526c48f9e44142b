"""Physics-first augmentation on a real PickUpTestTube demo: filtering, frames, re-verification, resume."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from pipette_cli.augment.run import augment, ledger_path
from pipette_cli.augment.specs import AugmentSpec, VariantSpec
from pipette_cli.augment.verify import verify_file
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.errors import DatasetError
from pipette_cli.registry import load_registry
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.specs.perturbations import CameraPoseSpec, JointNoiseSpec, LightingSpec, SpeedSpec

pytestmark = pytest.mark.render
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "augment"))
from raw_demo import TASK, raw_demo  # noqa: E402

SPEC = AugmentSpec(
    variants=[
        VariantSpec(name="original"),
        VariantSpec(
            name="light+cam", perturbations=[LightingSpec(scale=0.5), CameraPoseSpec(camera="top", radius=0.2)]
        ),
        VariantSpec(name="speed", perturbations=[SpeedSpec()]),
        VariantSpec(name="destroy", perturbations=[JointNoiseSpec(sigma=0.5, bound=0.5)]),  # deliberately destructive
    ]
)


@pytest.fixture(scope="module")
def task():
    return load_registry([]).get(TASK)


@pytest.fixture(scope="module")
def run(task, tmp_path_factory):
    raw = raw_demo(tmp_path_factory)
    folder = tmp_path_factory.mktemp("aug")
    out, rejected = folder / "aug.h5", folder / "rejected.h5"
    result = augment(task, raw, out, SPEC, rejected=rejected, workers=1)
    return raw, out, rejected, result


def test_destructive_variant_is_filtered_and_counted(run) -> None:
    _, out, rejected, result = run
    rows = {r["variant"]: r for r in result.report["variants"]}
    assert {k: v["kept"] for k, v in rows.items()} == {"original": 1, "light+cam": 1, "speed": 1, "destroy": 0}
    assert sum(rows["destroy"]["failures"].values()) == 1
    kept = [read_episode(ref).attrs["augment_variant"] for ref in scan(out).episodes]
    assert kept == ["original", "light+cam", "speed"]
    failed = read_episode(scan(rejected).episodes[0])
    assert failed.attrs["augment_variant"] == "destroy" and not failed.summary.success
    assert failed.summary.reason == next(iter(rows["destroy"]["failures"]))


def test_every_kept_episode_reverifies(run, task) -> None:
    _, out, rejected, _ = run
    checks = verify_file(task, out)
    assert len(checks) == 3 and all(c.ok for c in checks), checks
    assert not any(c.ok for c in verify_file(task, rejected))


def test_frames_from_recorded_states_equal_frames_rendered_during_simulation(run, task) -> None:
    raw, out, _, _ = run
    original = read_episode(scan(raw).episodes[0], images=True)  # rendered by `collect` while simulating
    episodes = [read_episode(ref, images=True) for ref in scan(out).episodes]
    same = episodes[0]
    for cam in ("top", "main", "wrist"):
        assert same.images[cam].tobytes() == original.images[cam].tobytes(), cam
    assert same.arrays["sim_state"].tobytes() == original.arrays["sim_state"].tobytes()
    # light/camera only: same physics, other pixels
    visual = episodes[1]
    assert visual.arrays["sim_state"].tobytes() == original.arrays["sim_state"].tobytes()
    assert not np.array_equal(visual.images["top"], original.images["top"])
    assert visual.images["wrist"].mean() < original.images["wrist"].mean()  # darker at s_I = 0.5
    # a re-simulated variant rendered by PipetteEnv while stepping equals our render from its states
    speed = episodes[2]
    env = PipetteEnv(task, image_size=16)
    try:
        obs = env.reset(speed.summary.seed)
        frames = [obs.images]
        for action in speed.arrays["action"][:-1]:
            obs, _ = env.step(action)
            frames.append(obs.images)
    finally:
        env.close()
    for cam in ("top", "main", "wrist"):
        assert np.stack([f[cam] for f in frames]).tobytes() == speed.images[cam].tobytes(), cam


def test_provenance_and_speed_resampling_in_attributes(run) -> None:
    raw, out, _, _ = run
    src = read_episode(scan(raw).episodes[0])
    speed = read_episode(scan(out).episodes[2])
    params = json.loads(speed.attrs["augment_params"])
    assert params["speed"]["factor"] == 1.2 and params["speed"]["source_steps"] == src.summary.num_steps
    assert speed.summary.num_steps < src.summary.num_steps  # 1.2x faster
    assert speed.attrs["augment_source_uid"] == src.summary.uid and speed.attrs["source"] == "augmented"
    assert speed.summary.seed == src.summary.seed and speed.attrs["git_commit"]


def test_rerun_skips_finished_demos_and_other_parameters_are_refused(run, task) -> None:
    raw, out, rejected, _ = run
    before = out.read_bytes()
    again = augment(task, raw, out, SPEC, rejected=rejected, workers=1)
    assert again.new_demos == 0 and again.skipped_demos == 1
    assert out.read_bytes() == before
    assert json.loads(ledger_path(out).read_text())["demos"]
    # execution-only fields (batch screening gives the same verdicts) do not block a resume
    flipped = augment(task, raw, out, SPEC.model_copy(update={"batch": not SPEC.batch}), rejected=rejected, workers=1)
    assert flipped.new_demos == 0 and out.read_bytes() == before
    with pytest.raises(DatasetError, match="other parameters"):
        augment(task, raw, out, SPEC.model_copy(update={"seed": 9}), workers=1)


def test_an_output_begun_by_other_code_is_not_finished_by_this_code(run, task, tmp_path: Path) -> None:
    raw, out, rejected, _ = run
    older, older_rejected = tmp_path / "older.h5", tmp_path / "older_rejected.h5"
    for src, dst in ((out, older), (rejected, older_rejected), (ledger_path(out), ledger_path(older))):
        shutil.copy(src, dst)
    with h5py.File(older, "r+") as f:
        for episode in f["episodes"].values():
            episode.attrs["code_sha256"] = "fedcba9876543210" * 4
    finished = augment(task, raw, older, SPEC, rejected=older_rejected, workers=1)
    assert finished.new_demos == 0  # finished: read, not added to
    ledger = json.loads(ledger_path(older).read_text())
    ledger["demos"].clear()  # as if its one demo were still to do
    ledger_path(older).write_text(json.dumps(ledger))
    before = older.read_bytes()
    with pytest.raises(DatasetError, match=r"older\.h5 holds episodes made by pipette \S+ \(source fedcba987654\)"):
        augment(task, raw, older, SPEC, rejected=older_rejected, workers=1)
    assert older.read_bytes() == before


def test_a_demo_that_does_not_replay_says_which_code_recorded_it(run, task, tmp_path: Path) -> None:
    raw = tmp_path / "raw.h5"
    shutil.copy(run[0], raw)
    with h5py.File(raw, "r+") as f:
        episode = next(iter(f["episodes"].values()))
        episode.attrs["code_sha256"] = "fedcba9876543210" * 4  # recorded by other code ...
        actions = episode["action"]
        row = actions[5]
        row[0] = np.nextafter(row[0], np.inf)  # ... whose physics differ in the last bit
        actions[5] = row
    spec = AugmentSpec(variants=[VariantSpec(name="original")])
    result = augment(task, raw, tmp_path / "aug.h5", spec, workers=1)
    (demo,) = json.loads(ledger_path(tmp_path / "aug.h5").read_text())["demos"].values()
    assert result.report["kept"] == 0 and demo["status"] == "replay_failed"
    assert demo["detail"].startswith("replay differs from the recording at step ")
    assert "(recorded by pipette " in demo["detail"] and "(source fedcba987654)" in demo["detail"]


def test_target_yield_shrinks_magnitudes_until_enough_variants_pass(task, tmp_path_factory) -> None:
    from pipette_cli.augment.calibrate import calibrate

    raw = raw_demo(tmp_path_factory)
    spec = AugmentSpec(variants=[VariantSpec(name="noise", perturbations=[JointNoiseSpec(sigma=0.5, bound=0.5)])])
    found = calibrate(task, raw, spec, target=1.0, demos=1, shrink=0.3)
    assert found.rounds[0]["factor"] == 1.0 and found.rounds[0]["yield"] == 0.0  # full magnitude destroys the demo
    assert found.factor < 1.0 and found.rounds[-1]["yield"] == 1.0
    noise = found.spec.variants[0].perturbations[0]
    assert noise.sigma == pytest.approx(0.5 * found.factor) and noise.bound == pytest.approx(0.5 * found.factor)


def test_target_yield_out_of_range_is_refused(task, tmp_path_factory) -> None:
    from pipette_cli.augment.calibrate import calibrate
    from pipette_cli.errors import PipetteError

    with pytest.raises(PipetteError, match=r"--target-yield must be in \(0, 1\]"):
        calibrate(task, raw_demo(tmp_path_factory), SPEC, target=1.5)


def test_batch_rollout_screening_agrees_with_step_by_step(task, tmp_path_factory) -> None:
    """mujoco.rollout screens physics variants at once; verdicts and the kept episodes are the same
    as simulating each variant step by step."""
    from pipette_cli.augment.batch import screen
    from pipette_cli.augment.simulate import simulate
    from pipette_cli.sim.world import World

    raw = raw_demo(tmp_path_factory)
    record = read_episode(scan(raw).episodes[0])
    actions, start, seed = record.arrays["action"], record.arrays["sim_state"][0], record.summary.seed
    rng = np.random.default_rng(0)
    wild = actions.copy()
    wild[:, :-1] += rng.normal(0, 0.4, wild[:, :-1].shape)
    variants = [actions, wild, actions[::2]]
    world = World(task)
    batch = screen(world, seed, start, variants, settle_steps=30)
    serial = [simulate(world, seed, start, a, settle_steps=30).verdict for a in variants]
    assert [(v.success, v.failed) for v in batch] == [(v.success, v.failed) for v in serial]
    assert batch[0].success and not batch[1].success

    spec_on = AugmentSpec(
        variants=[
            VariantSpec(name="speed", perturbations=[SpeedSpec()]),
            VariantSpec(name="destroy", perturbations=[JointNoiseSpec(sigma=0.5, bound=0.5)]),
        ]
    )
    spec_off = spec_on.model_copy(update={"batch": False})
    folder = tmp_path_factory.mktemp("batch")
    on = augment(task, raw, folder / "on.h5", spec_on, workers=1)
    off = augment(task, raw, folder / "off.h5", spec_off, workers=1)
    kept_on = [read_episode(ref).arrays["sim_state"] for ref in scan(folder / "on.h5").episodes]
    kept_off = [read_episode(ref).arrays["sim_state"] for ref in scan(folder / "off.h5").episodes]
    assert len(kept_on) == len(kept_off) == 1
    np.testing.assert_array_equal(kept_on[0], kept_off[0])
    assert [r["kept"] for r in on.report["variants"]] == [r["kept"] for r in off.report["variants"]] == [1, 0]


def test_views_shared_by_variants_of_the_same_physics_are_rendered_once(task, tmp_path_factory) -> None:
    """light+cam moves one camera: its other two views are those of `light` (same physics, same
    lights) and are reused, not rendered again; the episode is identical to rendering it alone."""
    from pipette_cli.sim.render import CameraRig

    raw = raw_demo(tmp_path_factory)
    folder = tmp_path_factory.mktemp("reuse")
    light = VariantSpec(name="light", perturbations=[LightingSpec(scale=0.6)])
    moved = VariantSpec(
        name="light+cam", perturbations=[LightingSpec(scale=0.6), CameraPoseSpec(camera="top", radius=0.2)]
    )
    rendered: list[str] = []
    real_render = CameraRig.render

    def counting(self, data, camera):
        rendered.append(camera)
        return real_render(self, data, camera)

    CameraRig.render = counting  # type: ignore[method-assign]
    try:
        augment(task, raw, folder / "both.h5", AugmentSpec(variants=[light, moved]), workers=1)
        both = list(rendered)
        rendered.clear()
        augment(task, raw, folder / "alone.h5", AugmentSpec(variants=[moved]), workers=1)
    finally:
        CameraRig.render = real_render  # type: ignore[method-assign]
    captures = both.count("wrist")
    assert both.count("top") == 2 * captures  # light and light+cam each render their own top view
    assert rendered.count("top") == rendered.count("main") == captures  # alone: all three views once
    shared = read_episode(scan(folder / "both.h5").episodes[1], images=True)
    alone = read_episode(scan(folder / "alone.h5").episodes[0], images=True)
    assert shared.attrs["augment_variant"] == alone.attrs["augment_variant"] == "light+cam"
    for cam in ("top", "main", "wrist"):
        assert shared.images[cam].tobytes() == alone.images[cam].tobytes(), cam


def test_placement_over_the_task_range_and_surface_colour_are_verified_deterministic_and_recorded(
    task, tmp_path_factory
) -> None:
    from pipette_cli.augment.specs import default_atoms, make_variants

    raw = raw_demo(tmp_path_factory)
    atoms = default_atoms(object={"task_range": 1.5})
    spec = AugmentSpec(variants=make_variants(["original", "object*3", "table"], atoms))
    outs = []
    for name in ("a", "b"):  # the same spec twice: the same episodes, bit for bit
        folder = tmp_path_factory.mktemp(name)
        result = augment(task, raw, folder / "aug.h5", spec, rejected=folder / "rejected.h5", workers=1)
        outs.append((folder / "aug.h5", folder / "rejected.h5", result))
    (out, rejected, result), (out_b, _, _) = outs
    rows = {r["variant"]: r for r in result.report["variants"]}
    assert set(rows) == {"original", "object@1", "object@2", "object@3", "table"}  # a yield line each
    kept = [read_episode(ref, images=True) for ref in scan(out).episodes]
    again = [read_episode(ref, images=True) for ref in scan(out_b).episodes]
    assert [e.attrs["augment_variant"] for e in kept] == [e.attrs["augment_variant"] for e in again]
    for a, b in zip(kept, again, strict=True):
        assert a.arrays["action"].tobytes() == b.arrays["action"].tobytes()
        assert a.images["top"].tobytes() == b.images["top"].tobytes()
    assert all(c.ok for c in verify_file(task, out)) and not any(c.ok for c in verify_file(task, rejected))
    from pipette_cli.augment.simulate import placement, restore
    from pipette_cli.sim.world import World

    source = read_episode(scan(raw).episodes[0])
    world = World(task)
    restore(world, source.summary.seed, source.arrays["sim_state"][0])
    start = placement(world, "tube")
    moved = 0
    for episode in kept + [read_episode(ref) for ref in scan(rejected).episodes]:
        params = json.loads(episode.attrs["augment_params"])
        if "object_pose" in params:  # placed anew within 1.5 times the task's range around the nominal pose
            offset = json.loads(episode.attrs["augment_object_offset"])
            assert params["object_pose"]["task_range"] == 1.5 and offset["dx"] == params["object_pose"]["dx"]
            for axis, delta in ((0, offset["dx"]), (1, offset["dy"])):
                assert abs(start.start[axis] + delta - start.nominal[axis]) <= 1.5 * start.span[axis] + 1e-9
            moved += 1
    assert moved == 3
    table = next(e for e in kept if e.attrs["augment_variant"] == "table")
    original = next(e for e in kept if e.attrs["augment_variant"] == "original")
    assert table.arrays["sim_state"].tobytes() == original.arrays["sim_state"].tobytes()  # rendering only
    assert not np.array_equal(table.images["main"], original.images["main"])
    assert json.loads(table.attrs["augment_params"])["surface_color"]["tint"]["floor"]


def test_distractors_stand_clear_of_the_demo_and_are_verified_deterministic_and_recorded(
    task, tmp_path_factory
) -> None:
    import math

    import mujoco

    from pipette_cli.augment.clutter import DISTRACTOR_RADIUS, clutter_of, transfer_state
    from pipette_cli.augment.specs import default_atoms, make_variants
    from pipette_cli.demos.replay import replay_episode
    from pipette_cli.sim.distractors import distractors_from_attrs, with_distractors
    from pipette_cli.sim.world import World
    from pipette_cli.specs.suite import SuiteSpec

    raw = raw_demo(tmp_path_factory)
    spec = AugmentSpec(variants=make_variants(["original", "clutter*2"], default_atoms(clutter={"count": 3})))
    outs = []
    for name in ("a", "b"):  # the same spec twice: the same distractors and episodes, bit for bit
        folder = tmp_path_factory.mktemp(f"clutter_{name}")
        result = augment(task, raw, folder / "aug.h5", spec, rejected=folder / "rejected.h5", workers=1)
        outs.append((folder / "aug.h5", result))
    (out, result), (out_b, _) = outs
    assert {r["variant"] for r in result.report["variants"]} == {"original", "clutter@1", "clutter@2"}
    kept = [read_episode(ref, images=True) for ref in scan(out).episodes]
    again = [read_episode(ref, images=True) for ref in scan(out_b).episodes]
    assert [e.attrs.get("augment_distractors") for e in kept] == [e.attrs.get("augment_distractors") for e in again]
    cluttered = [e for e in kept if distractors_from_attrs(e.attrs)]
    assert cluttered, "no cluttered episode was kept"
    source = read_episode(scan(raw).episodes[0])
    world = World(task)
    room = clutter_of(world, source.arrays["sim_state"])
    original = next(e for e in kept if e.attrs["augment_variant"] == "original")
    for episode in cluttered:
        placed = distractors_from_attrs(episode.attrs)
        assert len(placed) == 3 and json.loads(episode.attrs["augment_params"])["distractors"]["count"] == 3
        for d in placed:  # clear of the hand's path and of the task's objects
            gaps = [math.hypot(d.x - x, d.y - y) - r for x, y, r in [*room.keep_out, *room.objects]]
            assert min(gaps) >= 0.06 + DISTRACTOR_RADIUS - 1e-6
        assert episode.arrays["sim_state"].shape[1] > source.arrays["sim_state"].shape[1]  # a larger scene
        assert not np.array_equal(episode.images["top"][0], original.images["top"][0])  # and they are seen
    index = next(i for i, ref in enumerate(scan(out).episodes) if distractors_from_attrs(read_episode(ref).attrs))
    report = replay_episode(out, index, task)  # data replay rebuilds the scene the episode ran in
    assert report.states_equal and report.outcome_equal
    assert all(c.ok for c in verify_file(task, out))
    scene = World(with_distractors(task, distractors_from_attrs(cluttered[0].attrs)))
    transfer_state(world, source.arrays["sim_state"][0], scene, source.summary.seed)  # leaves world at that state
    mujoco.mj_forward(world.model, world.data)
    assert np.array_equal(scene.position("tube"), world.position("tube"))  # the robot and the tube where recorded
    assert np.array_equal(scene.arm_qpos(), world.arm_qpos())
    suite = {"id": "test/Clutter-v1", "name": "x", "tasks": [{"task": task.id, "instructions": ["Pick up the tube."]}]}
    assert SuiteSpec.model_validate(
        {**suite, "perturbations": [{"type": "distractors"}]}
    )  # the expert's path stands in
    with pytest.raises(ValueError, match="drawn around a demonstration"):
        SuiteSpec.model_validate({**suite, "perturbations": [{"type": "speed"}]})


def test_corrective_noise_records_the_demonstrated_targets_runs_the_noisy_ones_and_reverifies(
    run, task, tmp_path_factory
) -> None:
    from pipette_cli.augment.specs import default_atoms, make_variants
    from pipette_cli.demos.replay import replay_episode

    raw = run[0]
    atoms = default_atoms(noise={"corrective": True}, object={"task_range": 1.0})
    spec = AugmentSpec(variants=make_variants(["noise*2", "speed+noise", "object+noise"], atoms), seed=4)
    outs = []
    for name in ("a", "b"):  # the same spec twice: the same labels and the same executed noise
        folder = tmp_path_factory.mktemp(f"dart_{name}")
        augment(task, raw, folder / "aug.h5", spec, rejected=folder / "rejected.h5", workers=1)
        outs.append((folder / "aug.h5", folder / "rejected.h5"))
    (out, rejected), (out_b, rejected_b) = outs
    episodes = [read_episode(ref) for f in (out, rejected) for ref in scan(f).episodes]
    again = [read_episode(ref) for f in (out_b, rejected_b) for ref in scan(f).episodes]
    assert len(episodes) == 4 and sum(e.summary.success for e in episodes) >= 2
    source = read_episode(scan(raw).episodes[0]).arrays["action"]
    bound = JointNoiseSpec().bound
    for episode, twin in zip(episodes, again, strict=True):
        label, executed = episode.arrays["action"], episode.arrays["executed_action"]
        assert label.tobytes() == twin.arrays["action"].tobytes()
        assert executed.tobytes() == twin.arrays["executed_action"].tobytes()
        assert episode.attrs["augment_actions"] == "corrective"
        assert json.loads(episode.attrs["augment_params"])["joint_noise"]["corrective"] is True
        arm = executed[:, :-1] - label[:, :-1]
        assert 0 < np.abs(arm).max() <= bound + 1e-12 and np.array_equal(executed[:, -1], label[:, -1])
        if episode.attrs["augment_variant"].startswith("noise@"):  # no speed, no object: the demo's own targets
            held = source[np.minimum(np.arange(len(label)), len(source) - 1)]
            assert np.array_equal(label, held)
    # the states are what the executed actions make: the kept ones re-verify, the rejected ones replay as failures
    assert all(c.ok for c in verify_file(task, out)) and not any(c.ok for c in verify_file(task, rejected))
    first = replay_episode(out, 0, task)  # `pipette replay`: the executed actions, bit for bit
    assert first.ok and first.states_compared == len(episodes[0].arrays["action"])
    plain = [read_episode(ref) for ref in scan(run[1]).episodes]
    assert all("executed_action" not in e.arrays and e.attrs["augment_actions"] == "executed" for e in plain)


def the_experiment():
    """benchmarks/augmentation_experiment.py as a module."""
    import importlib.util

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "augmentation_experiment.py"
    spec = importlib.util.spec_from_file_location("augmentation_experiment_sim", path)
    assert spec is not None and spec.loader is not None
    experiment = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = experiment  # its dataclasses look their module up
    spec.loader.exec_module(experiment)
    return experiment


def test_the_corrective_noise_excursion_is_measured_off_the_recorded_path(run, task, tmp_path) -> None:
    experiment = the_experiment()
    ex = experiment.Experiment(tmp_path, 1, 16, "fast", 1, (500,), 1, None, 1)
    ex.folder(task).mkdir(parents=True)
    shutil.copy(run[0], ex.folder(task, "raw.h5"))
    found = experiment.noise_excursion(ex, task)
    assert found == experiment.noise_excursion(ex, task)  # same seed, same noise
    assert found["demos"] == 1 and found["sigma"] == JointNoiseSpec().sigma
    assert 0 < found["mean_joint_deviation_rad"] < found["largest_joint_deviation_rad"] < 0.1
    assert 0 < found["mean_tcp_deviation_mm"] < found["largest_tcp_deviation_mm"] < 50
    drift = experiment.noise_excursion(ex, task, "aug_all_drift")  # amendment 12: the hand further off the path
    assert drift["window"] == 15 and drift["mean_tcp_deviation_mm"] > 2 * found["mean_tcp_deviation_mm"]


def test_aug_alls_replays_inside_amendment_14s_data_are_identical_array_for_array(
    run, task, tmp_path, monkeypatch
) -> None:
    experiment = the_experiment()
    for setting in ("aug_all", "aug_all_plus_drift"):  # the experiment's variants, two draws of each kind
        monkeypatch.setitem(experiment.VARIANTS, setting, experiment.VARIANTS[setting].replace("*5", "*2"))
    ex = experiment.Experiment(tmp_path, 1, 16, "fast", 1, (500,), 1, None, 1)
    ex.folder(task).mkdir(parents=True)
    shutil.copy(run[0], ex.folder(task, "raw.h5"))
    experiment.data(ex, task, ["aug_all", "aug_all_plus_drift"])
    reports = json.loads(ex.folder(task, "yield.json").read_text())
    kinds = experiment.yield_by_kind(reports["aug_all_plus_drift"])
    assert set(kinds) == {"original", "object+light+cam+table", "light+cam+table+noise"}  # a yield line per kind
    assert kinds["light+cam+table+noise"][1] == 2
    found = experiment.contained(ex, task, "aug_all_plus_drift")
    assert found["same_yield"] and found["episodes"] == len(scan(ex.folder(task, "aug_all.h5")).episodes) >= 2
    assert found["identical"] == found["episodes"]
    drifted = [read_episode(r) for r in scan(ex.folder(task, "aug_all_plus_drift.h5")).episodes]
    drifted = [e for e in drifted if str(e.attrs["augment_variant"]).startswith("light+cam+table+noise")]
    for episode in drifted:  # the demonstrated targets recorded, the drifting ones run
        params = json.loads(episode.attrs["augment_params"])
        assert params["joint_noise"]["window"] == 15 and "object_pose" not in params
        assert "executed_action" in episode.arrays
    refs = scan(ex.folder(task, "aug_all_plus_drift.h5")).episodes
    original = next(r for r in refs if read_episode(r).attrs["augment_variant"] == "original")
    with h5py.File(ex.folder(task, "aug_all_plus_drift.h5"), "r+") as f:  # one changed action is seen
        f[original.group]["action"][0, 0] += 1.0
    assert experiment.contained(ex, task, "aug_all_plus_drift")["identical"] == found["identical"] - 1
