"""A recorded episode as an animation: its camera views side by side, at a chosen frame rate
(``pipette data video``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pipette_cli.demos.store import DatasetStatus, read_episode
from pipette_cli.errors import DatasetError
from pipette_cli.sim.views import save_animation, views_sheet

READABLE_WIDTH = 128
"""Views narrower than this are enlarged (nearest neighbour) by a whole factor, so that their labels
and the objects in them can be read."""


def episode_frames(
    status: DatasetStatus, index: int, *, cameras: Sequence[str] = (), fps: float = 10.0, scale: int = 0
) -> list[np.ndarray]:
    """Episode ``index``'s views side by side, one frame every ``1/fps`` s of simulated time (the
    recording holds one per control step).

    Args:
        status: The file, as :func:`pipette_cli.demos.store.scan` read it.
        cameras: Which views, in order (default: every recorded one).
        fps: Frames per second of simulated time; at most the control rate.
        scale: Enlarge each view this many times (0: enough for :data:`READABLE_WIDTH`).

    Raises:
        DatasetError: no such episode, no images in it, an unknown camera, or a rate above the control rate.
    """
    info = status.info
    if info is None:
        raise DatasetError(f"{status.path}: no such file")
    ref = status.episode(index)
    shown = tuple(cameras) or info.cameras
    unknown = [c for c in shown if c not in info.cameras]
    if unknown:
        raise DatasetError(f"{status.path}: no camera {', '.join(unknown)} (recorded: {', '.join(info.cameras)})")
    if not 0 < fps <= info.control_hz:
        raise DatasetError(f"--fps {fps:g}: between 0 and the recording's control rate ({info.control_hz} Hz)")
    images = read_episode(ref, images=shown).images
    if not images:
        raise DatasetError(f"{status.path}: episode {index} holds no images (recorded without cameras)")
    count = len(images[shown[0]])
    step = info.control_hz / fps
    picks = sorted({min(count - 1, round(k * step)) for k in range(max(1, int(count / step)))} | {count - 1})
    enlarge = scale or max(1, READABLE_WIDTH // max(1, info.image_width))
    return [views_sheet({c: images[c][i] for c in shown}, names=shown, scale=enlarge) for i in picks]


def write_episode_video(
    status: DatasetStatus, index: int, out: Path, *, cameras: Sequence[str] = (), fps: float = 10.0, scale: int = 0
) -> Path:
    """Episode ``index`` as ``out`` (``.gif`` or ``.mp4``), played in real time (see :func:`episode_frames`)."""
    frames = episode_frames(status, index, cameras=cameras, fps=fps, scale=scale)
    try:
        return save_animation(frames, out, fps=fps)
    except ValueError as error:
        raise DatasetError(str(error)) from None
