"""Camera views side by side, each labelled with its camera's name in its top-left corner.

The one way Pipette shows several views at once: the PNG of ``pipette sim render``, the gym env's
``rgb_array`` frame, the demo's augmentation GIF, the evaluation GIFs and ``pipette data video``; and the one way it writes
them as an animation (:func:`save_animation`).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np

from pipette_cli.sim.scene import CAMERA_NAMES

LABEL_TEXT = (255, 255, 255)
LABEL_BACKGROUND = (0, 0, 0)


def label_view(image: np.ndarray, name: str) -> np.ndarray:
    """A copy of the RGB ``image`` with ``name`` written in its top-left corner, white on black, in a
    font about 1/12 of the image's height (at least 8 px)."""
    from PIL import Image, ImageDraw, ImageFont  # deferred: PIL (~15 ms of `pipette --help`)

    picture = Image.fromarray(np.ascontiguousarray(image[..., :3], dtype=np.uint8))
    size = max(8, picture.height // 12)
    font = ImageFont.load_default(size=size)
    draw = ImageDraw.Draw(picture)
    pad = max(1, size // 6)
    _, _, right, bottom = draw.textbbox((pad, pad), name, font=font)
    draw.rectangle([0, 0, right + pad - 1, bottom + pad - 1], fill=LABEL_BACKGROUND)
    draw.text((pad, pad), name, font=font, fill=LABEL_TEXT)
    return np.asarray(picture)


def views_sheet(
    views: Mapping[str, np.ndarray], *, names: Sequence[str] = CAMERA_NAMES, gap: int = 4, scale: int = 1
) -> np.ndarray:
    """The views ``names`` (those present, in that order) side by side, each labelled with its name.

    Args:
        views: RGB ``(H, W, 3)`` uint8 images by camera name, all of one size.
        names: Which views, in order (default top, main, wrist).
        gap: White pixels between two views.
        scale: Each view is first enlarged this many times (nearest neighbour), so that small
            images get readable labels.

    Raises:
        ValueError: none of ``names`` is in ``views``.
    """
    shown = [name for name in names if name in views]
    if not shown:
        raise ValueError(f"no view among {list(names)} (have {sorted(views)})")
    tiles = []
    for name in shown:
        image = np.asarray(views[name])
        if scale > 1:
            image = image.repeat(scale, axis=0).repeat(scale, axis=1)
        tiles.append(label_view(image, name))
    if gap:
        spacer = np.full((tiles[0].shape[0], gap, 3), 255, np.uint8)
        tiles = [part for tile in tiles for part in (tile, spacer)][:-1]
    return np.concatenate(tiles, axis=1)


class AnimationFormat(enum.StrEnum):
    """The formats :func:`save_animation` writes, named by a file's suffix."""

    gif = "gif"
    mp4 = "mp4"


ANIMATION_SUFFIXES = tuple(f".{f.value}" for f in AnimationFormat)


def save_animation(frames: Sequence[np.ndarray], path: Path, *, fps: float = 10.0) -> Path:
    """Write RGB ``(H, W, 3)`` uint8 frames as an animation, its format from ``path``'s suffix:
    ``.gif`` (looping; PIL) or ``.mp4`` (H.264 through PyAV, which bundles its own FFmpeg; the
    frame's odd rows and columns are padded white, as the encoder needs even sizes).

    Raises:
        ValueError: no frames, or a suffix other than those of :data:`ANIMATION_SUFFIXES`.
    """
    suffix = path.suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise ValueError(
            f"{path}: cannot write a {suffix or 'suffixless'} animation (use {' or '.join(ANIMATION_SUFFIXES)})"
        )
    if not frames:
        raise ValueError(f"{path}: no frames to write")
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        from PIL import Image  # deferred: PIL (as above)

        images = [Image.fromarray(np.ascontiguousarray(frame)) for frame in frames]
        images[0].save(path, save_all=True, append_images=images[1:], duration=round(1000 / fps), loop=0)
        return path
    import av  # deferred: PyAV (comes with LeRobot)

    height, width = frames[0].shape[:2]
    even = (height + height % 2, width + width % 2)
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
        stream.height, stream.width = even
        stream.pix_fmt = "yuv420p"
        for frame in frames:
            padded = np.full((*even, 3), 255, np.uint8)
            padded[:height, :width] = frame[..., :3]
            container.mux(stream.encode(av.VideoFrame.from_ndarray(padded, format="rgb24")))
        container.mux(stream.encode())
    return path
