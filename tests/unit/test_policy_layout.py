"""Which LeRobot policy folder a path names: the folder, a step's checkpoint, or a run's last one."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from pipette_cli.errors import PipetteError
from pipette_cli.lerobot.layout import LAST_CHECKPOINT, policy_folder


def run(folder: Path, *steps: int) -> Path:
    """A training run as lerobot-train leaves it: a folder per saved step, ``last`` linked to the newest."""
    for step in steps:
        model = folder / "checkpoints" / f"{step:06d}" / "pretrained_model"
        model.mkdir(parents=True)
        (model / "config.json").write_text(json.dumps({"type": "act"}))
    if steps:
        os.symlink(f"{max(steps):06d}", folder / "checkpoints" / "last")
    return folder


def test_a_policy_folder_a_step_and_a_run_each_name_their_policy(tmp_path: Path) -> None:
    folder = run(tmp_path / "act_raw", 500, 1000)
    model = folder / "checkpoints" / "000500" / "pretrained_model"
    assert policy_folder(model) == model
    assert policy_folder(model.parent) == model  # a step's checkpoint folder
    assert policy_folder(folder) == folder / LAST_CHECKPOINT  # the run: its last checkpoint, the newest step
    assert policy_folder(folder).resolve() == (folder / "checkpoints" / "001000" / "pretrained_model").resolve()
    assert policy_folder(tmp_path) == folder / LAST_CHECKPOINT  # the one run below a folder


def test_a_folder_of_several_runs_names_them_newest_first(tmp_path: Path) -> None:
    older, newer = run(tmp_path / "act" / "a_raw", 100), run(tmp_path / "act" / "b_augmented", 100)
    os.utime(older / LAST_CHECKPOINT / "config.json", (1, 1))
    with pytest.raises(PipetteError, match="holds 2 training runs; pass one of them") as caught:
        policy_folder(tmp_path)
    said = str(caught.value)
    assert said.index(str(newer)) < said.index(str(older))


def test_what_is_not_a_policy_says_what_is_missing(tmp_path: Path) -> None:
    with pytest.raises(PipetteError, match="no such policy folder"):
        policy_folder(tmp_path / "nowhere")
    with pytest.raises(PipetteError, match=r"not a LeRobot policy folder \(no config.json here"):
        policy_folder(tmp_path)
    (tmp_path / "unfinished" / "checkpoints").mkdir(parents=True)  # training stopped before its first save
    with pytest.raises(PipetteError, match="a training run with no finished checkpoint"):
        policy_folder(tmp_path / "unfinished")
