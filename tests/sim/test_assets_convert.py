"""USD -> MjSpec through MuJoCo's importer, and what our loader adds on top."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from pipette_cli.assets.library import load_asset_library
from pipette_cli.assets.loader import attach_asset, load_asset_spec
from pipette_cli.errors import AssetError


@pytest.mark.parametrize("asset_id", load_asset_library().ids())
def test_every_asset_compiles(asset_id: str) -> None:
    model = load_asset_spec(asset_id).compile()
    entry = load_asset_library().get(asset_id)
    assert model.body_subtreemass[0] == pytest.approx(entry.semantics()["mass"], rel=1e-4)
    assert all("/" not in model.body(i).name for i in range(model.nbody))


def test_centrifuge_lid_joint_and_servo() -> None:
    model = load_asset_spec("centrifuge_benchtop").compile()
    joint = model.joint("lid_hinge")
    assert np.degrees(joint.range) == pytest.approx([-100, 0], abs=1e-3)
    assert joint.axis == pytest.approx([0, -1, 0])
    act = model.actuator("lid_drive")
    assert act.gainprm[0] == pytest.approx(200) and act.biasprm[1:3] == pytest.approx([-200, -20])
    assert act.forcerange == pytest.approx([-1000, 1000])


def test_centrifuge_lid_opens_upward_with_negative_angle() -> None:
    model = load_asset_spec("centrifuge_benchtop").compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    closed = data.site("lid_handle").xpos.copy()
    data.ctrl[0] = math.radians(-40)
    for _ in range(1000):
        mujoco.mj_step(model, data)
    assert math.degrees(data.joint("lid_hinge").qpos[0]) == pytest.approx(-40, abs=2)
    assert data.site("lid_handle").xpos[2] > closed[2] + 0.2


def test_incubator_door_opens_toward_the_robot() -> None:
    model = load_asset_spec("incubator_benchtop").compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    closed = data.site("door_handle").xpos.copy()
    data.joint("door_hinge").qpos[0] = math.radians(90)
    mujoco.mj_forward(model, data)
    assert data.site("door_handle").xpos[0] < closed[0] - 0.3


def test_free_object_has_named_free_joint_or_none() -> None:
    spec = load_asset_spec("test_tube_16x150")
    assert [j.name for j in spec.joints] == ["free"]
    assert load_asset_spec("test_tube_16x150", free_joint=False).compile().njnt == 0


def test_glass_is_transparent() -> None:
    model = load_asset_spec("beaker_250ml").compile()
    assert model.material("glass").rgba[3] < 0.5


def test_two_assets_attach_with_prefixes() -> None:
    scene = mujoco.MjSpec()
    attach_asset(scene, "lab_bench", name="bench")
    attach_asset(scene, "centrifuge_benchtop", name="centrifuge", pos=(0.5, 0, 0.55))
    attach_asset(scene, "test_tube_16x150", name="tube_a", pos=(0.3, 0.2, 0.55))
    attach_asset(scene, "test_tube_16x150", name="tube_b", pos=(0.3, 0.25, 0.55))
    model = scene.compile()
    assert model.joint("centrifuge/lid_hinge").type == mujoco.mjtJoint.mjJNT_HINGE
    assert model.joint("tube_a/free").type == mujoco.mjtJoint.mjJNT_FREE
    assert model.site("centrifuge/button").id >= 0 and model.actuator("centrifuge/lid_drive").id >= 0
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.body("centrifuge/base").xpos == pytest.approx([0.5, 0, 0.55])


def test_unknown_asset_suggests_a_name() -> None:
    with pytest.raises(AssetError, match="did you mean 'beaker_250ml'"):
        load_asset_spec("beaker_250")


def test_sites_survive_a_usd_stage_opened_before_mujoco_is_imported() -> None:
    """pxr reads its schema registry once: MuJoCo's schemas must be registered before the first
    stage, or MuJoCo's USD import drops every site (a fresh process, pxr first)."""
    import ast
    import subprocess
    import sys

    code = (
        "from pipette_cli.assets.library import load_asset_library\n"
        "load_asset_library().get('centrifuge_benchtop').semantics()  # pxr opens a stage first\n"
        "from pipette_cli.assets.loader import load_asset_spec\n"
        "m = load_asset_spec('thermal_cycler').compile()\n"
        "print(sorted(m.site(i).name for i in range(m.nsite)))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    sites = set(ast.literal_eval(result.stdout.strip()))
    assert {"block_center", "lid_handle", "lid_button", "start_button", "well_a1", "well_h12"} <= sites
    assert len(sites) == 4 + 96  # the block's 96 wells
