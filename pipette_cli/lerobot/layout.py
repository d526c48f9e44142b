"""Where ``lerobot-train`` leaves a policy, and which policy folder a path a user gives names.

A training run writes ``<run>/checkpoints/<step>/pretrained_model`` every ``--save_freq`` steps and
links ``<run>/checkpoints/last`` to the newest. ``serve --policy`` and ``eval --policy`` load a
``pretrained_model`` folder; :func:`policy_folder` also takes the run folder (its last checkpoint)
or one step's folder, which is what a researcher has at hand after ``pipette train``. Light on
purpose (no lerobot import): the CLI resolves the path before anything slow loads.
"""

from __future__ import annotations

from pathlib import Path

from pipette_cli.errors import PipetteError

PRETRAINED = "pretrained_model"
LAST_CHECKPOINT = Path("checkpoints/last") / PRETRAINED
"""A run's newest policy, relative to the run folder (lerobot's CHECKPOINTS_DIR/LAST_CHECKPOINT_LINK)."""
SHOWN = 5
"""Runs named at most when a folder holds several."""


def policy_folder(path: Path) -> Path:
    """The LeRobot policy folder ``path`` names: ``path`` itself when it holds ``config.json``, else
    its ``pretrained_model`` (a step's checkpoint), else its run's last checkpoint.

    Raises:
        PipetteError: ``path`` is missing, holds several training runs (named, newest first), or none.
        One run below ``path`` (``outputs/train/act`` after one training) is that run.
    """
    path = Path(path)
    if not path.exists():
        raise PipetteError(f"{path}: no such policy folder")
    for candidate in (path, path / PRETRAINED, path / LAST_CHECKPOINT):
        if (candidate / "config.json").is_file():
            return candidate
    runs = [p.parents[3] for depth in ("*", "*/*") for p in path.glob(f"{depth}/{LAST_CHECKPOINT}/config.json")]
    if len(runs) == 1:
        return runs[0] / LAST_CHECKPOINT
    if runs:
        runs.sort(key=lambda run: (-(run / LAST_CHECKPOINT / "config.json").stat().st_mtime, str(run)))
        named = ", ".join(str(run) for run in runs[:SHOWN]) + (
            f" and {len(runs) - SHOWN} more" if len(runs) > SHOWN else ""
        )
        raise PipetteError(f"{path} holds {len(runs)} training runs; pass one of them: {named}")
    if (path / "checkpoints").is_dir():
        raise PipetteError(
            f"{path}: a training run with no finished checkpoint ({LAST_CHECKPOINT}/config.json is missing); "
            "continue the training or pass a checkpoints/<step> folder"
        )
    raise PipetteError(
        f"{path}: not a LeRobot policy folder (no config.json here, in {PRETRAINED}/ or in {LAST_CHECKPOINT}/); "
        "pass a training run folder or a pretrained_model folder"
    )
