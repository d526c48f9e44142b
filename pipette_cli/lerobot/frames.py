"""Which control steps of a recorded episode become dataset frames.

Recordings hold one row per control step (30 Hz) and a fresh camera frame every
``control_hz / vision_hz`` steps; other rows repeat the last frame (``fresh`` false). A
policy dataset runs at ``fps`` (10 Hz): the ``fresh`` filter keeps the steps that rendered a
new frame (then every n-th of those when the cameras ran faster than ``fps``), the ``stride``
filter keeps every ``control_hz / fps``-th step from the first one. Row ``t`` pairs the
observation taken before action ``t`` (images, state) with that action, so keeping whole rows
keeps observations, states and actions aligned.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from pipette_cli.errors import DatasetError


class FrameFilter(str, Enum):
    """How control steps are thinned to the dataset rate."""

    fresh = "fresh"
    stride = "stride"


def _ratio(high: int, low: int, what: str) -> int:
    if low <= 0 or high % low:
        raise DatasetError(f"--fps {low} does not divide the {what} of {high} Hz; choose a divisor of {high}")
    return high // low


def select_frames(fresh: np.ndarray, *, control_hz: int, vision_hz: int, fps: int, mode: FrameFilter) -> np.ndarray:
    """Indices of the control steps kept at ``fps``.

    Args:
        fresh: Per-step flag, true where a new camera frame was rendered.
        control_hz: Recording rate of the rows.
        vision_hz: Camera rate of the recording.
        fps: Target dataset rate.
        mode: ``fresh`` (keep fresh steps) or ``stride`` (every k-th step).

    Raises:
        DatasetError: ``fps`` is not reachable from the recording's rates.
    """
    fresh = np.asarray(fresh, dtype=bool)
    if mode is FrameFilter.fresh:
        if fps > vision_hz:
            raise DatasetError(
                f"--fps {fps} is above the recording's camera rate of {vision_hz} Hz; use --fps {vision_hz} or lower"
            )
        return np.flatnonzero(fresh)[:: _ratio(vision_hz, fps, "camera rate")]
    if fps > control_hz:
        raise DatasetError(f"--fps {fps} is above the recording's control rate of {control_hz} Hz")
    return np.arange(0, len(fresh), _ratio(control_hz, fps, "control rate"))
