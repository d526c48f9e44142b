"""Compliance and settling: every asset passes validation; scenes built from assets behave."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from pipette_cli.assets.library import load_asset_library
from pipette_cli.assets.loader import attach_asset
from pipette_cli.assets.validate import validate_asset

FIXTURES = Path(__file__).parent.parent / "fixtures" / "assets"


@pytest.mark.parametrize("asset_id", load_asset_library().ids())
def test_asset_is_valid(asset_id: str) -> None:
    entry = load_asset_library().get(asset_id)
    report = validate_asset(entry.path, entry.category)
    assert report.ok, report.problems


def test_free_objects_settle_without_jitter() -> None:
    entry = load_asset_library().get("conical_tube_50ml_skirted")
    report = validate_asset(entry.path, entry.category)
    assert report.metrics["rest_speed"] < 1e-3 and report.metrics["tilt_deg"] < 1
    assert report.metrics["penetration"] < 1e-3


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("broken_syntax.usda", "cannot parse USD (line 68"),
        ("missing_reference.usda", "does_not_exist.usda"),
        ("exploding_dish.usda", "physics:"),
    ],
)
def test_bad_assets_are_reported_not_fixed(name: str, expected: str) -> None:
    path = FIXTURES / name
    before = path.read_bytes()
    report = validate_asset(path)
    assert not report.ok
    assert any(expected in p for p in report.problems), report.problems
    assert path.read_bytes() == before


def _settle(scene: mujoco.MjSpec, seconds: float = 1.5) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = scene.compile()
    data = mujoco.MjData(model)
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return model, data


def test_tube_stands_in_a_rack_slot() -> None:
    scene = mujoco.MjSpec()
    attach_asset(scene, "test_tube_rack_16mm", name="rack")
    slot = load_asset_library().get("test_tube_rack_16mm")
    model = scene.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pos = data.site("rack/slot_3").xpos.copy()
    attach_asset(scene, "test_tube_16x150", name="tube", pos=(pos[0], pos[1], pos[2] + 0.002))
    model, data = _settle(scene)
    assert slot.asset_id
    assert data.body("tube/body").xpos[:2] == pytest.approx(pos[:2], abs=0.004)
    assert data.body("tube/body").xmat[8] > 0.99  # still upright


def test_dish_rests_on_incubator_shelf() -> None:
    scene = mujoco.MjSpec()
    attach_asset(scene, "incubator_benchtop", name="inc")
    model = scene.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    shelf = data.site("inc/shelf_1_center").xpos.copy()
    attach_asset(scene, "petri_dish_90mm", name="dish", pos=(shelf[0], shelf[1], shelf[2] + 0.002))
    model, data = _settle(scene)
    assert data.body("dish/body").xpos[2] == pytest.approx(shelf[2], abs=0.002)


def test_water_bath_lid_sits_on_its_seat() -> None:
    scene = mujoco.MjSpec()
    attach_asset(scene, "water_bath", name="bath")
    model = scene.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    seat = data.site("bath/lid_seat").xpos.copy()
    attach_asset(scene, "water_bath_lid", name="lid", pos=(seat[0], seat[1], seat[2] + 0.003))
    model, data = _settle(scene)
    assert data.body("lid/body").xpos[2] == pytest.approx(seat[2], abs=0.002)


def test_flask_rests_on_shaker_platform() -> None:
    scene = mujoco.MjSpec()
    attach_asset(scene, "orbital_shaker", name="shaker")
    model = scene.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    top = data.site("shaker/platform_center").xpos.copy()
    attach_asset(scene, "erlenmeyer_flask_250ml", name="flask", pos=(top[0], top[1], top[2] + 0.003))
    model, data = _settle(scene)
    assert data.body("flask/body").xpos[2] == pytest.approx(top[2], abs=0.002)


def test_pipette_hangs_upright_in_stand_slot() -> None:
    scene = mujoco.MjSpec()
    attach_asset(scene, "pipette_stand_linear", name="stand")
    model = scene.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    slot = data.site("stand/slot_1").xpos.copy()
    hang = load_asset_library().get("pipette_single_channel").semantics()["hang_height"]
    attach_asset(scene, "pipette_single_channel", name="pip", pos=(slot[0], slot[1], slot[2] - hang + 0.004))
    model, data = _settle(scene, 3.0)
    assert data.body("pip/body").xpos == pytest.approx([slot[0], slot[1], slot[2] - hang], abs=0.003)
    assert data.body("pip/body").xmat[8] > 0.99
