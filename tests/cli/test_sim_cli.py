"""``pipette sim render`` and ``pipette sim step-rate``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.render


def test_render_writes_three_views_side_by_side(run_cli, tmp_path: Path) -> None:
    out = tmp_path / "views.png"
    result = run_cli("sim", "render", "PickUpTestTube", "--image-size", "48", "--profile", "fast", "--out", out)
    assert result.exit_code == 0, result.stderr
    image = np.asarray(Image.open(out))
    assert image.shape == (48, 3 * 48 + 2 * 4, 3)
    assert image[:, :48].std() > 5 and image[:, -48:].std() > 5
    for x in (0, 52, 104):  # top, main, wrist: each named in its top-left corner, light on black
        corner = image[:12, x : x + 24].reshape(-1, 3)
        assert (corner == 0).all(axis=1).sum() >= 10 and (corner >= 150).all(axis=1).sum() >= 3


def test_step_rate_reports_physics_and_both_render_profiles(run_cli) -> None:
    result = run_cli("sim", "step-rate", "PickUpTestTube", "--steps", "30", "--image-size", "32", "--json")
    assert result.exit_code == 0, result.stderr
    rates = json.loads(result.stdout)
    assert rates["task"] == "pipette/PickUpTestTube-v1"
    assert rates["physics_real_time_factor"] > 0 and rates["control_steps_per_s"] > 0
    assert rates["render_fast_3view_per_s"] > 0 and rates["render_full_3view_per_s"] > 0


def test_unknown_task_and_no_display(run_cli, monkeypatch) -> None:
    assert "unknown task" in run_cli("sim", "render", "NoSuchTask").stderr
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    result = run_cli("sim", "view", "PickUpTestTube")
    assert result.exit_code == 1 and "needs one" in result.stderr


def test_render_on_another_robot_and_an_unknown_one(run_cli, tmp_path: Path) -> None:
    out = tmp_path / "ur5e.png"
    result = run_cli(
        "sim",
        "render",
        "PickUpTestTube",
        "--robot",
        "ur5e_2f85",
        "--image-size",
        "32",
        "--profile",
        "fast",
        "--out",
        out,
    )
    assert result.exit_code == 0, result.stderr
    assert np.asarray(Image.open(out))[:, -32:].std() > 5  # the UR5e's wrist camera sees something
    moved = run_cli(
        "sim",
        "render",
        "PlaceTubeOnBalance",
        "--robot",
        "piper",
        "--image-size",
        "32",
        "--profile",
        "fast",
        "--out",
        tmp_path / "piper.png",
    )
    assert moved.exit_code == 0, moved.stderr
    assert "agilex_piper: base moved from (0.00, 0.00) to (" in moved.stderr
    bad = run_cli("sim", "render", "PickUpTestTube", "--robot", "kuka")
    assert bad.exit_code == 1
    lines = [line for line in bad.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "unknown robot 'kuka'" in lines[0] and "ur5e_robotiq" in lines[0], bad.stderr
