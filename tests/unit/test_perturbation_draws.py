"""Drawing perturbations: the new axes (light jitter, every camera, placement over the task's range,
surface colour), their determinism, and their use as a suite's per-episode conditions."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from pydantic import ValidationError

from pipette_cli.augment.perturb import placed_object, plan_variant
from pipette_cli.augment.simulate import Placement
from pipette_cli.augment.specs import VariantSpec, default_atoms, make_variants
from pipette_cli.errors import SpecError
from pipette_cli.evaluation.suites import episode_plan, load_suites, suite_sha256
from pipette_cli.registry import load_registry
from pipette_cli.specs.perturbations import (
    CameraPoseSpec,
    JointNoiseSpec,
    LightingSpec,
    ObjectPoseSpec,
    SpeedSpec,
    SurfaceColorSpec,
)
from pipette_cli.specs.suite import SuiteSpec

ACTIONS = np.zeros((40, 8))
TUBE = Placement("tube", start=(0.52, -0.03, 40.0), nominal=(0.5, 0.0, 0.0), span=(0.04, 0.04, 180.0))


def draw(*perturbations, seed: int = 7, actions=ACTIONS, placement=TUBE):
    variant = VariantSpec(name="v", perturbations=list(perturbations))
    return plan_variant(variant, actions, seed=0, demo_seed=seed, default_object="tube", placement=placement)


def test_light_jitter_draws_each_episode_its_own_scale_inside_the_range() -> None:
    scales = [draw(LightingSpec(scale=0.9, jitter=0.4), seed=s).light_scale for s in range(200)]
    assert min(scales) >= 0.5 and max(scales) <= 1.3 and max(scales) - min(scales) > 0.6
    assert draw(LightingSpec()).light_scale == 0.8  # the paper's fixed s_I when there is no jitter
    with pytest.raises(ValidationError, match="above 0"):
        LightingSpec(scale=0.5, jitter=0.5)


def test_camera_all_moves_every_camera_within_its_own_radius() -> None:
    plan = draw(CameraPoseSpec(camera="all", radius=0.05, wrist_radius=0.002))
    assert set(plan.camera_offsets) == {"top", "main", "wrist"}
    assert np.linalg.norm(plan.camera_offsets["wrist"]) <= 0.002
    assert all(np.linalg.norm(plan.camera_offsets[c]) <= 0.05 for c in ("top", "main"))
    assert plan.params["camera_pose"]["chosen"] == "all"
    one = draw(CameraPoseSpec(camera="top")).params["camera_pose"]
    assert one["chosen"] == "top" and one["radius_used"] == 0.2  # one camera: recorded as before


def test_task_range_places_the_object_anew_around_its_nominal_pose() -> None:
    spec = ObjectPoseSpec(task_range=1.5)
    ends = []
    for seed in range(300):
        offset = draw(spec, seed=seed).offset
        assert offset is not None and offset.name == "tube"
        ends.append((TUBE.start[0] + offset.dx, TUBE.start[1] + offset.dy, TUBE.start[2] + offset.dyaw_deg))
    x, y, yaw = np.array(ends).T
    assert np.all(np.abs(x - 0.5) <= 0.06 + 1e-9) and np.all(np.abs(y) <= 0.06 + 1e-9)
    assert np.abs(x - 0.5).max() > 0.05  # beyond the task's own +-4 cm
    assert np.all(np.abs(np.asarray([draw(spec, seed=s).offset.dyaw_deg for s in range(50)])) <= 180)  # type: ignore[union-attr]
    assert len(set(np.round(yaw, 6))) > 250
    assert placed_object(VariantSpec(name="o", perturbations=[spec]), "tube") == "tube"
    assert placed_object(VariantSpec(name="o", perturbations=[ObjectPoseSpec()]), "tube") is None
    with pytest.raises(ValueError, match="placement"):
        draw(spec, placement=None)


def test_corrective_noise_keeps_the_demonstrated_targets_and_runs_the_same_draw_as_plain_noise() -> None:
    actions = np.random.default_rng(1).uniform(-1, 1, size=(40, 8))
    plain = draw(SpeedSpec(), JointNoiseSpec(), actions=actions)
    corrective = draw(SpeedSpec(), JointNoiseSpec(corrective=True), actions=actions)
    clean = draw(SpeedSpec(), actions=actions)
    assert plain.noise is None and plain.executed() is plain.actions
    assert corrective.actions is not None and clean.actions is not None and corrective.noise is not None
    assert np.array_equal(corrective.actions, clean.actions)  # recorded: the (resampled) demonstration
    executed = corrective.executed()
    assert executed is not None and np.array_equal(executed, plain.actions)  # run: what plain noise runs
    arm = executed[:, :-1] - corrective.actions[:, :-1]
    assert 0 < np.abs(arm).max() <= JointNoiseSpec().bound and np.array_equal(executed[:, -1], clean.actions[:, -1])
    assert corrective.params["joint_noise"]["corrective"] is True
    assert corrective.magnitude.endswith(",corrective") and not plain.magnitude.endswith(",corrective")
    again = draw(SpeedSpec(), JointNoiseSpec(corrective=True), actions=actions).executed()
    assert again is not None and executed.tobytes() == again.tobytes()  # same seed, same noise


def test_windowed_noise_drifts_and_is_recorded() -> None:
    actions = np.zeros((300, 8))
    plan = draw(JointNoiseSpec(sigma=0.01, bound=0.03, window=15, corrective=True), actions=actions)
    assert plan.noise is not None and np.abs(plan.noise).max() <= 0.03
    lag1 = min(np.corrcoef(joint[:-1], joint[1:])[0, 1] for joint in plan.noise.T)
    assert lag1 > 0.8  # each joint drifts; the white noise of the paper does not
    assert plan.params["joint_noise"]["window"] == 15 and "window=15" in plan.magnitude


def test_surface_color_draws_a_colour_for_each_surface() -> None:
    plan = draw(SurfaceColorSpec(blend=0.3))
    assert set(plan.surface_tint) == {"bench", "floor"} and plan.visual and not plan.physics
    assert plan.surface_blend == 0.3 and all(np.all((t >= 0) & (t <= 1)) for t in plan.surface_tint.values())
    assert not np.allclose(plan.surface_tint["bench"], plan.surface_tint["floor"])
    assert plan.params["surface_color"]["tint"]["bench"] == plan.surface_tint["bench"].round(4).tolist()
    assert "table" in default_atoms() and make_variants(["table+light"], default_atoms())[0].physics is False


def test_draws_are_deterministic_and_need_no_actions_unless_they_perturb_them() -> None:
    specs = (LightingSpec(jitter=0.2), CameraPoseSpec(camera="all"), ObjectPoseSpec(task_range=1.0), SurfaceColorSpec())
    a, b = draw(*specs, actions=None), draw(*specs, actions=None)
    assert a.actions is None and json.dumps(a.params, default=list) == json.dumps(b.params, default=list)
    assert a.params != draw(*specs, seed=8, actions=None).params
    with pytest.raises(ValueError, match="actions"):
        draw(SpeedSpec(), actions=None)


def test_paper_variants_draw_as_before() -> None:
    """The new fields default to the old behaviour: same random stream, same values."""
    plan = draw(LightingSpec(), CameraPoseSpec(camera="random"), ObjectPoseSpec(xy=0.02), placement=None)
    rng = np.random.default_rng([0, 7, __import__("zlib").crc32(b"v")])
    dx, dy = rng.uniform(-0.02, 0.02, size=2)
    assert plan.offset is not None and (plan.offset.dx, plan.offset.dy) == (dx, dy)
    assert plan.light_scale == 0.8


def test_a_suite_refuses_perturbations_of_actions_and_keeps_old_hashes() -> None:
    base = {"id": "lab/S-v1", "name": "s", "tasks": [{"task": "pipette/PickUpTestTube-v1", "instructions": ["x"]}]}
    with pytest.raises(ValidationError, match="actions"):
        SuiteSpec.model_validate({**base, "perturbations": [{"type": "speed"}]})
    with pytest.raises(ValidationError, match="twice"):
        SuiteSpec.model_validate({**base, "perturbations": [{"type": "lighting"}, {"type": "lighting"}]})
    plain = SuiteSpec.model_validate(base)
    old = json.dumps(
        {k: v for k, v in plain.model_dump(mode="json").items() if k != "perturbations"},
        sort_keys=True,
        separators=(",", ":"),
    )
    assert suite_sha256(plain) == hashlib.sha256(old.encode()).hexdigest()
    shifted = SuiteSpec.model_validate({**base, "perturbations": [{"type": "surface_color"}]})
    assert suite_sha256(shifted) != suite_sha256(plain)
    assert [p.conditions for p in episode_plan(shifted)["pipette/PickUpTestTube-v1"]][0][0].type == "surface_color"


def test_the_augmentation_suites_pair_nominal_and_shifted_episodes() -> None:
    suites = load_suites(load_registry())
    nominal, shifted = (
        suites.get("pipette/AugmentationNominal-v1").spec,
        suites.get("pipette/AugmentationShifted-v1").spec,
    )
    assert not nominal.perturbations and {p.type for p in shifted.perturbations} == {
        "lighting",
        "camera_pose",
        "object_pose",
        "surface_color",
    }
    plans = episode_plan(nominal), episode_plan(shifted)
    assert list(plans[0]) == list(plans[1]) and len(plans[0]) >= 4
    for task, episodes in plans[0].items():
        assert [(e.seed, e.instruction) for e in episodes] == [(e.seed, e.instruction) for e in plans[1][task]]
        assert len(episodes) >= 50 and min(e.seed for e in episodes) >= 100_000  # never a demonstration seed


def test_unknown_atoms_still_name_the_new_ones() -> None:
    with pytest.raises(SpecError, match="table"):
        make_variants(["tabel"], default_atoms())


def test_a_starred_variant_repeats_with_its_own_draws() -> None:
    variants = make_variants(["original", "object+table*3"], default_atoms(object={"task_range": 1.0}))
    assert [v.name for v in variants] == ["original", "object+table@1", "object+table@2", "object+table@3"]
    tints = [
        plan_variant(v, ACTIONS, seed=0, demo_seed=1, default_object="tube", placement=TUBE).surface_tint["bench"]
        for v in variants[1:]
    ]
    assert not np.allclose(tints[0], tints[1]) and not np.allclose(tints[1], tints[2])
    for bad in ("object*0", "original*2", "light*x"):
        with pytest.raises(SpecError, match=r"\*N"):
            make_variants([bad], default_atoms())
