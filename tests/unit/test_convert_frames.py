"""Frame selection and the LeRobot features of `pipette convert` (no recordings needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipette_cli.demos.recorder import DatasetInfo
from pipette_cli.errors import DatasetError
from pipette_cli.lerobot.convert import ConvertOptions, is_augmented, make_features, plan_conversion
from pipette_cli.lerobot.frames import FrameFilter, select_frames
from pipette_cli.lerobot.stats import dataset_stats

FRESH_EVERY_3 = np.arange(30) % 3 == 0  # 30 Hz control, a new frame every 3rd step (paper A.3)


def test_fresh_filter_keeps_the_fresh_steps() -> None:
    steps = select_frames(FRESH_EVERY_3, control_hz=30, vision_hz=10, fps=10, mode=FrameFilter.fresh)
    assert steps.tolist() == list(range(0, 30, 3))


def test_fresh_filter_downsamples_faster_cameras_to_fps() -> None:
    every_step = np.ones(30, dtype=bool)  # cameras at the 30 Hz control rate
    steps = select_frames(every_step, control_hz=30, vision_hz=30, fps=10, mode=FrameFilter.fresh)
    assert steps.tolist() == list(range(0, 30, 3))
    assert select_frames(FRESH_EVERY_3, control_hz=30, vision_hz=10, fps=5, mode=FrameFilter.fresh).tolist() == list(
        range(0, 30, 6)
    )


def test_fresh_filter_ignores_irregular_fresh_flags_when_picking() -> None:
    fresh = np.zeros(10, dtype=bool)
    fresh[[0, 4, 7]] = True
    assert select_frames(fresh, control_hz=30, vision_hz=10, fps=10, mode=FrameFilter.fresh).tolist() == [0, 4, 7]


def test_stride_filter_keeps_every_kth_step() -> None:
    assert select_frames(FRESH_EVERY_3, control_hz=30, vision_hz=10, fps=15, mode=FrameFilter.stride).tolist() == list(
        range(0, 30, 2)
    )
    assert select_frames(FRESH_EVERY_3[:7], control_hz=30, vision_hz=10, fps=10, mode=FrameFilter.stride).tolist() == [
        0,
        3,
        6,
    ]


@pytest.mark.parametrize(
    ("mode", "fps", "message"),
    [
        (FrameFilter.fresh, 30, "above the recording's camera rate"),
        (FrameFilter.fresh, 3, "does not divide"),
        (FrameFilter.stride, 7, "does not divide"),
        (FrameFilter.stride, 60, "above the recording's control rate"),
    ],
)
def test_unreachable_rates_are_errors(mode: FrameFilter, fps: int, message: str) -> None:
    with pytest.raises(DatasetError, match=message):
        select_frames(FRESH_EVERY_3, control_hz=30, vision_hz=10, fps=fps, mode=mode)


def test_features_are_uint8_hwc_cameras_state_and_action() -> None:
    info = DatasetInfo("lab/T-v1", "piper", "do it", 48, 64, ("top", "main", "wrist"), 600, 30, 10, 7, 7, 100)
    features = make_features(info, video=False)
    assert set(features) == {
        "observation.images.top",
        "observation.images.main",
        "observation.images.wrist",
        "observation.state",
        "action",
        "stage",
    }
    assert (
        features["observation.images.wrist"]["shape"] == (48, 64, 3)
        and features["observation.images.top"]["dtype"] == "image"
    )
    assert features["observation.state"]["shape"] == (7,) and features["observation.state"]["names"][-1] == "gripper"
    assert len(features["action"]["names"]) == 7
    assert make_features(info, video=True)["observation.images.main"]["dtype"] == "video"


def test_instrument_values_are_named_columns() -> None:
    info = DatasetInfo(
        "lab/T-v1",
        "piper",
        "do it",
        48,
        64,
        ("top", "main", "wrist"),
        600,
        30,
        10,
        7,
        7,
        100,
        ("centrifuge.closed", "centrifuge.run_time_s"),
    )
    features = make_features(info, video=False)
    assert features["instrument_state"] == {
        "dtype": "float32",
        "shape": (2,),
        "names": ["centrifuge.closed", "centrifuge.run_time_s"],
    }
    assert "observation.instrument_state" not in features  # LeRobot would feed observation.* keys to policies


def test_augmented_episodes_are_recognised() -> None:
    assert not is_augmented({"source": "scripted", "seed": 1})
    assert is_augmented({"source": "scripted", "perturbation": "{}"})
    assert is_augmented({"source": "augmented"})
    assert is_augmented({"source": "scripted", "augment_variant": "lighting"})


def test_bad_repo_id_is_refused_before_reading_and_a_taken_target_after(tmp_path: Path) -> None:
    missing = tmp_path / "none.h5"
    with pytest.raises(DatasetError, match="OWNER/NAME"):
        plan_conversion([missing], ConvertOptions(repo_id="noslash", root=tmp_path / "ds"))
    (tmp_path / "taken").mkdir()
    with pytest.raises(DatasetError, match="no such file"):  # what the inputs are says more than the folder
        plan_conversion([missing], ConvertOptions(repo_id="local/x", root=tmp_path / "taken"))
    (tmp_path / "taken" / "precious.txt").write_text("keep me")
    with pytest.raises(DatasetError, match="no such file"):
        plan_conversion([missing], ConvertOptions(repo_id="local/x", root=tmp_path / "taken", overwrite=True))
    assert (tmp_path / "taken" / "precious.txt").read_text() == "keep me"


def test_stats_of_a_folder_without_a_dataset_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="not a LeRobot dataset"):
        dataset_stats(tmp_path)
