"""Recorded HDF5 episodes -> a LeRobot dataset, written with LeRobot's own ``LeRobotDataset`` API.

Each kept control step becomes one frame: ``observation.images.{top,main,wrist}`` (uint8 HWC),
``observation.state`` (float32), ``action`` (float32 copy of the float64 joint targets and
gripper command), their entries named after the robot's joints, the step's instruction as the
``task`` string (a protocol's stage instruction, so policies can be trained on sub-tasks),
``stage`` (stages completed) and, for scenes with instruments, ``instrument_state`` (one named
column per ``World.instrument_names``). The last two carry no ``observation.`` prefix on purpose:
LeRobot would otherwise feed them to policies as state. :mod:`.frames` decides
which steps are kept (fresh camera frames at 10 Hz by default). Successful episodes only,
unless ``include_failed``.

Everything is checked before anything is written (readable inputs, one task unless
``allow_mixed``, one robot unless ``allow_mixed_robots``, one image size, raw vs augmented episodes, a free target). The dataset
is then built in a hidden folder beside the target and renamed onto it on success; on any
error or Ctrl-C that folder is deleted, so no partial dataset is left behind. Provenance
(source files, seeds, success, perturbations) goes to ``meta/pipette.json`` in the dataset.
Nothing touches the network.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shutil
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

import pipette_cli
from pipette_cli.demos.recorder import DatasetInfo
from pipette_cli.demos.store import EpisodeRef, open_h5, read_episode, scan
from pipette_cli.errors import DatasetError, plural
from pipette_cli.lerobot.frames import FrameFilter, select_frames
from pipette_cli.specs.base import described
from pipette_cli.specs.robot import load_robot_specs

log = logging.getLogger(__name__)

PROVENANCE_FILE = "meta/pipette.json"
PROVENANCE_FORMAT = "pipette.lerobot"
CAMERAS = ("top", "main", "wrist")
AV1_MIN_SIDE = 32
"""SVT-AV1 (LeRobot's default codec) crashes the process on smaller frames."""
REPO_ID = re.compile(r"^[A-Za-z0-9][\w.-]*/[A-Za-z0-9][\w.-]*$")


class DatasetVersion(str, Enum):
    """Raw demonstrations and simulation-augmented replays are separate datasets (paper 3.6)."""

    raw = "raw"
    augmented = "augmented"


def image_key(camera: str) -> str:
    return f"observation.images.{camera}"


PERTURBATION_PREFIXES = ("augment_", "perturbation")
"""Episode attributes describing an augmentation (``pipette augment`` writes ``augment_*``)."""


def is_augmented(attrs: dict[str, Any]) -> bool:
    """An episode written by the augmentation command: ``source == "augmented"`` or perturbation attributes."""
    return attrs.get("source") == "augmented" or any(str(k).startswith(PERTURBATION_PREFIXES) for k in attrs)


def slug(task_id: str) -> str:
    """``testlab/HoldTube-v1`` -> ``testlab_HoldTube-v1`` (a folder or repo-name part)."""
    return re.sub(r"[^\w.-]+", "_", task_id).strip("_")


def default_root(task_id: str, version: DatasetVersion, base: Path = Path("datasets")) -> Path:
    """Default dataset folder ``datasets/<task>/<version>``."""
    return base / slug(task_id) / version.value


@dataclass(frozen=True)
class ConvertOptions:
    """What :func:`convert` writes and how (each field's description is also the help of its
    ``pipette convert`` option).

    Attributes:
        repo_id: LeRobot repo id (``local/NAME``); stored only, nothing is pushed.
        root: The dataset folder (``LeRobotDataset(repo_id, root=root)`` loads it).
    """

    repo_id: str
    root: Path
    fps: int = described(10, "Dataset frame rate in Hz (paper 3.6: 10 Hz, the rate of fresh camera frames)")
    frame_filter: FrameFilter = described(
        FrameFilter.fresh,
        "fresh: steps with a new camera frame (paper 3.6: stale frames removed); stride: every k-th step",
    )
    video: bool = described(True, "Cameras as MP4 video (lossy, small) or PNG images (exact)")
    dataset_version: DatasetVersion = described(
        DatasetVersion.raw, "raw or augmented; the two go to separate datasets, the other kind of episode is refused"
    )
    include_failed: bool = described(False, "Keep failed episodes too (default: successful ones only)")
    allow_mixed: bool = described(False, "Allow several tasks in one dataset")
    allow_mixed_robots: bool = described(
        False,
        "Allow episodes of several robots (same state/action size) in one dataset; its state/action entries "
        "are then named by position (joint_i), not by the robots' joints",
    )
    overwrite: bool = described(False, "Replace an existing dataset at root (--root)")
    vcodec: str = described("libsvtav1", "Video codec: libsvtav1 (LeRobot's default) or h264 (faster)")
    image_writer_threads: int = described(4, "Threads writing PNG frames while converting")


@dataclass(frozen=True)
class PlannedEpisode:
    """One source episode and the control steps it contributes."""

    file: Path
    ref: EpisodeRef
    info: DatasetInfo
    attrs: dict[str, Any]
    steps: np.ndarray
    stale: int
    """Kept steps whose images are repeated frames (``frame_age > 0``; only with ``stride``)."""


@dataclass
class ConversionPlan:
    """What will be converted, decided before anything is written."""

    episodes: list[PlannedEpisode]
    skipped: list[dict[str, Any]]
    info: DatasetInfo
    task_ids: list[str]
    embodiments: list[str]

    @property
    def num_frames(self) -> int:
        return sum(len(e.steps) for e in self.episodes)


@dataclass
class ConvertResult:
    """A finished conversion."""

    root: Path
    repo_id: str
    episodes: int
    frames: int
    skipped: int
    seconds: float
    provenance: dict[str, Any] = field(repr=False)

    @property
    def frames_per_s(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else float("inf")


def _check_target(options: ConvertOptions) -> None:
    root = options.root
    if root.exists():
        if not options.overwrite:
            raise DatasetError(f"{root} already exists; pass --overwrite to replace it or choose another --root")
        if not root.is_dir() or (any(root.iterdir()) and not (root / "meta" / "info.json").is_file()):
            raise DatasetError(
                f"{root} exists and is not a LeRobot dataset; --overwrite only replaces a dataset folder"
            )


def _mixed(kind: str, values: list[str]) -> str:
    return f"the inputs hold {len(values)} {kind}s ({', '.join(values)}); convert them separately or pass --allow-mixed"


def plan_conversion(inputs: Sequence[Path], options: ConvertOptions) -> ConversionPlan:
    """Read and check every input and choose the frames; writes nothing.

    Raises:
        DatasetError: an input is unreadable, the inputs cannot share one dataset, no
            episode qualifies, or the target folder is taken.
    """
    if not inputs:
        raise DatasetError("no input files given")
    if not REPO_ID.match(options.repo_id):
        raise DatasetError(f"--repo-id {options.repo_id!r} is not of the form OWNER/NAME (for example local/tube_raw)")
    first: DatasetInfo | None = None
    episodes: list[PlannedEpisode] = []
    skipped: list[dict[str, Any]] = []
    tasks: dict[str, None] = {}
    embodiments: dict[str, None] = {}
    uids: dict[str, Path] = {}
    for path in map(Path, inputs):
        status = scan(path)
        if status.info is None:
            raise DatasetError(f"{path}: no such file")
        info = status.info
        if first is None:
            first = info
        elif (info.image_height, info.image_width) != (first.image_height, first.image_width):
            raise DatasetError(
                f"{path} has {info.image_height}x{info.image_width} images but {inputs[0]} has "
                f"{first.image_height}x{first.image_width}; one dataset needs one image size (re-record with --image-size)"
            )
        elif info.cameras != first.cameras:
            raise DatasetError(f"{path} has cameras {list(info.cameras)} but {inputs[0]} has {list(first.cameras)}")
        elif (info.state_dim, info.action_dim) != (first.state_dim, first.action_dim):
            raise DatasetError(
                f"{path} has state/action size {info.state_dim}/{info.action_dim} but {inputs[0]} has "
                f"{first.state_dim}/{first.action_dim}; these cannot share one dataset"
            )
        if missing := [c for c in CAMERAS if c not in info.cameras]:
            raise DatasetError(f"{path} has no {', '.join(missing)} camera (cameras: {list(info.cameras)})")
        tasks[info.task_id] = None
        embodiments[info.embodiment] = None
        for ref in status.episodes:
            if ref.summary.uid in uids:
                raise DatasetError(
                    f"episode {ref.index} of {path} is already in {uids[ref.summary.uid]} (an input given twice?)"
                )
            uids[ref.summary.uid] = path
            record = read_episode(ref)
            augmented = is_augmented(record.attrs)
            if augmented != (options.dataset_version is DatasetVersion.augmented):
                kind = "augmented" if augmented else "raw"
                raise DatasetError(
                    f"episode {ref.index} of {path} is {kind} but this is {'a' if augmented else 'an'} "
                    f"{options.dataset_version.value} dataset; "
                    f"raw and augmented episodes go to separate datasets (--dataset-version {kind})"
                )
            if not ref.summary.success and not options.include_failed:
                skipped.append(
                    {"file": str(path), "index": ref.index, "seed": ref.summary.seed, "reason": ref.summary.reason}
                )
                continue
            steps = select_frames(
                record.arrays["fresh"],
                control_hz=info.control_hz,
                vision_hz=info.vision_hz,
                fps=options.fps,
                mode=options.frame_filter,
            )
            stale = int(np.count_nonzero(record.arrays["frame_age"][steps] > 0))
            episodes.append(PlannedEpisode(path, ref, info, record.attrs, steps, stale))
    assert first is not None
    _check_target(options)  # after the inputs: what they hold says more about what was meant than a taken folder
    if options.video and options.vcodec == "libsvtav1" and min(first.image_height, first.image_width) < AV1_MIN_SIDE:
        raise DatasetError(
            f"{first.image_height}x{first.image_width} images are too small for the libsvtav1 codec "
            f"(at least {AV1_MIN_SIDE} px); pass --images or --vcodec h264"
        )
    if len(tasks) > 1 and not options.allow_mixed:
        raise DatasetError(_mixed("task", list(tasks)))
    if len(embodiments) > 1 and not options.allow_mixed_robots:
        raise DatasetError(
            f"the inputs were recorded on {len(embodiments)} robots ({', '.join(embodiments)}); their "
            "joints differ: convert each robot's episodes separately or pass --allow-mixed-robots"
        )
    if not episodes:
        total = len(skipped)
        raise DatasetError(
            f"no episode to convert: {'the' if total == 1 else 'all'} {plural(total, 'episode')} failed; pass --include-failed to keep failed episodes"
            if total
            else "no episode to convert: the inputs hold no episodes"
        )
    return ConversionPlan(episodes, skipped, first, list(tasks), list(embodiments))


def vector_names(info: DatasetInfo, *, mixed_robots: bool = False) -> tuple[list[str], list[str]]:
    """Names of the state and action entries: the robot's own (its joints), or, for episodes of
    several robots in one dataset, ``joint_i``/``joint_i_target`` by position."""
    if not mixed_robots:
        if info.state_names and info.action_names:
            return list(info.state_names), list(info.action_names)

        robot = load_robot_specs().get(info.embodiment)
        if robot is not None and robot.arm_dof + 1 == info.state_dim:
            return robot.state_names(), robot.action_names()
    arm = info.state_dim - 1
    return [f"joint_{i}" for i in range(1, arm + 1)] + ["gripper"], [f"joint_{i}_target" for i in range(1, arm + 1)] + [
        "gripper_open"
    ]


def make_features(info: DatasetInfo, *, video: bool, mixed_robots: bool = False) -> dict[str, dict[str, Any]]:
    """The LeRobot features dict: three uint8 HWC cameras, state and action (float32), named after
    the robot's joints."""
    state_names, action_names = vector_names(info, mixed_robots=mixed_robots)
    shape = (info.image_height, info.image_width, 3)
    features: dict[str, dict[str, Any]] = {
        image_key(cam): {
            "dtype": "video" if video else "image",
            "shape": shape,
            "names": ["height", "width", "channels"],
        }
        for cam in CAMERAS
    }
    features["observation.state"] = {"dtype": "float32", "shape": (info.state_dim,), "names": state_names}
    features["action"] = {"dtype": "float32", "shape": (info.action_dim,), "names": action_names}
    features["stage"] = {"dtype": "int64", "shape": (1,), "names": ["stages_completed"]}
    if info.instrument_names:
        names = list(info.instrument_names)
        features["instrument_state"] = {"dtype": "float32", "shape": (len(names),), "names": names}
    return features


def _episode_provenance(index: int, planned: PlannedEpisode) -> dict[str, Any]:
    attrs, summary = planned.attrs, planned.ref.summary
    keep = (
        "seed",
        "source",
        "expert",
        "uid",
        "task_id",
        "embodiment",
        "instruction",
        "num_steps",
        "success",
        "failed",
        "truncated",
        "reason",
        "recorded_at",
        "git_commit",
        "task_spec_sha256",
        "model_sha256",
    )
    entry: dict[str, Any] = {
        "episode_index": index,
        "file": str(planned.file.resolve()),
        "source_index": planned.ref.index,
    }
    entry.update({k: attrs[k] for k in keep if k in attrs})
    entry.update(
        {
            "success": summary.success,
            "reason": summary.reason,
            "metrics": summary.metrics,
            "frames": len(planned.steps),
            "steps": planned.steps.tolist(),
            "stale_frames": planned.stale,
        }
    )
    perturbation = {k: attrs[k] for k in attrs if str(k).startswith(PERTURBATION_PREFIXES)}
    if perturbation:
        entry["perturbation"] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in perturbation.items()}
    return entry


def _provenance(plan: ConversionPlan, options: ConvertOptions) -> dict[str, Any]:
    return {
        "format": PROVENANCE_FORMAT,
        "format_version": 1,
        "repo_id": options.repo_id,
        "dataset_version": options.dataset_version.value,
        "fps": options.fps,
        "frame_filter": options.frame_filter.value,
        "video": options.video,
        "include_failed": options.include_failed,
        "task_ids": plan.task_ids,
        "embodiments": plan.embodiments,
        "package_version": pipette_cli.__version__,
        "created_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "sources": sorted({str(e.file.resolve()) for e in plan.episodes} | {s["file"] for s in plan.skipped}),
        "episodes": [_episode_provenance(i, e) for i, e in enumerate(plan.episodes)],
        "skipped": plan.skipped,
    }


def _read_images(planned: PlannedEpisode) -> dict[str, np.ndarray]:
    """The kept steps' frames of each camera (only those rows are decompressed)."""
    with open_h5(planned.file) as f:
        images = f[planned.ref.group]["images"]
        return {cam: images[cam][planned.steps] for cam in CAMERAS}


def _quiet_encoders() -> None:
    """Only errors from the video encoders: LeRobot hands FFmpeg back its default logger after each
    video (``av.logging.restore_default_callback``), which then prints every encoder's info lines
    (x264's statistics, "Starting second pass"), and SVT-AV1 logs its own (``SVT_LOG``; about 60
    lines per episode in all). A level the user set in the environment is kept."""
    import av.logging  # deferred: PyAV, with LeRobot's video encoder (~0.1 s; `pipette --help` imports this module)

    os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1: 1 = errors (read when an encoder starts)
    av.logging.set_libav_level(av.logging.ERROR)


def _write(
    plan: ConversionPlan, options: ConvertOptions, tmp: Path, on_episode: Callable[[int, int], None] | None
) -> None:
    # deferred: lerobot, torch, datasets (~4 s; `pipette --help` imports this module)
    import datasets
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    datasets.disable_progress_bars()  # one "Map" bar per episode otherwise; pipette reports progress itself
    if options.video:
        _quiet_encoders()
    dataset = LeRobotDataset.create(
        repo_id=options.repo_id,
        fps=options.fps,
        root=tmp,
        robot_type=",".join(plan.embodiments),
        features=make_features(plan.info, video=options.video, mixed_robots=len(plan.embodiments) > 1),
        use_videos=options.video,
        image_writer_threads=options.image_writer_threads,
        video_backend="pyav",  # decoding is not used here
        rgb_encoder=RGBEncoderConfig(vcodec=options.vcodec) if options.video else None,
    )
    try:
        for n, planned in enumerate(plan.episodes):
            arrays = read_episode(planned.ref).arrays
            images = _read_images(planned)
            states = arrays["state"][planned.steps].astype(np.float32)
            actions = arrays["action"][planned.steps].astype(np.float32)
            tasks = _step_instructions(arrays, planned)
            stages = arrays["stage"][planned.steps] if "stage" in arrays else np.zeros(len(planned.steps), np.int64)
            instruments = (
                arrays["instrument_state"][planned.steps].astype(np.float32) if plan.info.instrument_names else None
            )
            for row in range(len(planned.steps)):
                frame: dict[str, Any] = {image_key(cam): images[cam][row] for cam in CAMERAS}
                frame["observation.state"] = states[row]
                frame["action"] = actions[row]
                frame["task"] = tasks[row]
                frame["stage"] = np.array([stages[row]], dtype=np.int64)
                if instruments is not None:
                    frame["instrument_state"] = instruments[row]
                dataset.add_frame(frame)
            dataset.save_episode()
            if on_episode is not None:
                on_episode(n + 1, len(plan.episodes))
    finally:
        dataset.finalize()
    (tmp / PROVENANCE_FILE).write_text(json.dumps(_provenance(plan, options), indent=2, default=str) + "\n")


def _step_instructions(arrays: dict[str, np.ndarray], planned: PlannedEpisode) -> list[str]:
    """Each kept step's instruction (its stage's on a protocol), else the episode's."""
    if "instruction" in arrays:
        return [t.decode() if isinstance(t, bytes) else str(t) for t in arrays["instruction"][planned.steps]]
    return [str(planned.attrs.get("instruction", planned.info.instruction))] * len(planned.steps)


def convert(
    inputs: Sequence[Path],
    options: ConvertOptions,
    *,
    on_plan: Callable[[ConversionPlan], None] | None = None,
    on_episode: Callable[[int, int], None] | None = None,
) -> ConvertResult:
    """Convert ``inputs`` into one LeRobot dataset at ``options.root``, atomically.

    Args:
        inputs: HDF5 files written by ``pipette collect`` (or the augmentation command).
        options: Target and filters.
        on_plan: Called once the inputs are checked, before writing.
        on_episode: Called with ``(episodes written, episodes to write)``.

    Raises:
        DatasetError: bad inputs or target (nothing written), or LeRobot failed to write
            (the partial dataset is removed).
    """
    started = time.perf_counter()
    plan = plan_conversion(inputs, options)
    if on_plan is not None:
        on_plan(plan)
    root = options.root
    root.parent.mkdir(parents=True, exist_ok=True)
    tmp = root.with_name(f".{root.name}.converting-{uuid.uuid4().hex[:8]}")
    old = root.with_name(f".{root.name}.replaced-{uuid.uuid4().hex[:8]}")
    try:
        try:
            _write(plan, options, tmp, on_episode)
        except (ValueError, RuntimeError, OSError) as exc:
            raise DatasetError(f"LeRobot could not write the dataset: {exc}") from exc
        if root.exists():  # --overwrite, checked in plan_conversion
            os.replace(root, old)
        os.replace(tmp, root)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        shutil.rmtree(old, ignore_errors=True)
    provenance = json.loads((root / PROVENANCE_FILE).read_text())
    return ConvertResult(
        root=root,
        repo_id=options.repo_id,
        episodes=len(plan.episodes),
        frames=plan.num_frames,
        skipped=len(plan.skipped),
        seconds=time.perf_counter() - started,
        provenance=provenance,
    )
