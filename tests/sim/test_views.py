"""Multi-view sheets name their views: ``sim.views`` and the sheets made with it (issue 36: the
three views of ``pipette sim render`` and the GIFs had no labels)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pipette_cli.demo import RecordingSource, contact_sheet
from pipette_cli.demos.collect import collect
from pipette_cli.registry import load_registry
from pipette_cli.sim.gym_env import PipetteGymEnv
from pipette_cli.sim.views import LABEL_BACKGROUND, LABEL_TEXT, label_view, views_sheet

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402

GREY = 120


def has_label(view: np.ndarray) -> bool:
    """True when the top-left corner of ``view`` holds a label: light text (antialiased) on a black box."""
    corner = view[: max(12, view.shape[0] // 6), : view.shape[1] // 2, :3].reshape(-1, 3)
    black = (corner == LABEL_BACKGROUND).all(axis=1).sum()
    light = (corner >= 0.6 * np.asarray(LABEL_TEXT)).all(axis=1).sum()
    return bool(black >= 10 and light >= 3)


def test_each_view_is_labelled_with_its_name_and_left_as_is_elsewhere() -> None:
    views = {name: np.full((48, 48, 3), GREY, np.uint8) for name in ("wrist", "main", "top")}
    sheet = views_sheet(views)
    assert sheet.shape == (48, 3 * 48 + 2 * 4, 3)
    tiles = [sheet[:, i * 52 : i * 52 + 48] for i in range(3)]
    for tile, name in zip(tiles, ("top", "main", "wrist"), strict=True):  # in camera order
        assert has_label(tile) and np.array_equal(tile, label_view(views[name], name))
        assert (tile[24:] == GREY).all()  # the label stays in its corner
    assert not np.array_equal(tiles[0], tiles[2])  # "top" and "wrist" are told apart
    assert (sheet[:, 48:52] == 255).all()  # the white gap
    assert not has_label(views["top"])


def test_scaled_views_get_labels_of_their_own_size() -> None:
    views = {"top": np.full((16, 16, 3), GREY, np.uint8), "main": np.zeros((16, 16, 3), np.uint8)}
    sheet = views_sheet(views, scale=4, gap=0)
    assert sheet.shape == (64, 128, 3) and has_label(sheet[:, :64])
    with pytest.raises(ValueError, match="no view"):
        views_sheet({"side": views["top"]})


def test_evaluation_gifs_label_the_views_the_policy_saw(tmp_path: Path) -> None:
    class Still:
        def act(self, observation, *, task, reset, chunk):
            return np.zeros(8)

    source = RecordingSource(Still())
    image = np.full((3, 24, 24), 0.5, np.float32)  # what a LeRobot policy is given: CHW in [0, 1]
    observation = {f"observation.images.{c}": image for c in ("top", "main", "wrist")}
    for step in range(3):
        source.act(observation, task="t", reset=step == 0, chunk=False)
    [path] = source.write_gifs(tmp_path, scale=2)
    frame = np.asarray(Image.open(path).convert("RGB"))
    assert frame.shape == (48, 3 * 48 + 2 * 4, 3)
    assert all(has_label(frame[:, i * 52 : i * 52 + 48]) for i in range(3))


@pytest.mark.render
def test_the_demo_gif_labels_its_views(tmp_path: Path) -> None:
    raw = tmp_path / "raw.h5"
    task = load_registry([FIXTURES / "registry"]).get("testlab/HoldTube-v1")
    collect(task, raw, episodes=1, seed=0, image_size=16, expert_factory=demo_experts.Wiggle)
    contact_sheet(raw, tmp_path / "sheet.png", tmp_path / "views.gif", tile=64)
    frame = np.asarray(Image.open(tmp_path / "views.gif").convert("RGB"))
    assert frame.shape == (64, 3 * 64 + 2 * 4, 3)
    assert all(has_label(frame[:, i * 68 : i * 68 + 64]) for i in range(3))


@pytest.mark.render
def test_the_gym_env_frame_labels_its_views() -> None:
    env = PipetteGymEnv("pipette/PickUpTestTube-v1", image_size=48, render_mode="rgb_array")
    try:
        env.reset(seed=0)
        frame = env.render()
    finally:
        env.close()
    assert frame is not None and frame.shape == (48, 3 * 48, 3)  # no gap: the frame keeps its shape
    assert all(has_label(frame[:, i * 48 : (i + 1) * 48]) for i in range(3))
