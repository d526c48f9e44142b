"""The HDF5 episode recorder of paper A.3: one group per episode, one row per control step.

An :class:`EpisodeWriter` streams one episode into its own file (``*.tmp`` until committed):
the three RGB views as uint8 ``(T, H, W, 3)`` datasets (gzip level 4, one chunk per frame),
the proprioceptive state, the action, the full MuJoCo integration state *before* the action
(restorable with ``mj_setState``), simulated and wall-clock time, the fresh flag and frame
age, the language instruction of each step (a protocol's stage instruction), the stages completed
and the instruments' values (``instrument_state``, one column per ``World.instrument_names``);
then the episode's verdict and provenance as attributes.
The layout is documented in ``docs/data_format.md``; :mod:`.store` packs episode files into
one dataset file atomically.

Images: a stale control step (``fresh`` false) repeats the last frame; its compressed chunk
is written again byte for byte (``write_direct_chunk``) instead of being compressed anew.
"""

from __future__ import annotations

import json
import os
import time
import uuid
import zlib
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import h5py
import mujoco
import numpy as np

from pipette_cli.errors import DatasetError
from pipette_cli.evaluators.base import Verdict
from pipette_cli.sim.env import Observation, PipetteEnv

FORMAT = "pipette.episodes"
FORMAT_VERSION = 1
GZIP_LEVEL = 4
SIM_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
SIM_STATE_NAME = "mjSTATE_INTEGRATION"
EPISODES = "episodes"
TRUNCATED = "max_steps"
"""Failure reason of an episode cut at the step cap before the evaluator decided."""
STOPPED = "stopped"
"""Failure reason of an episode an operator saved before the evaluator decided."""


def episode_name(index: int) -> str:
    return f"episode_{index:06d}"


def compress_frame(frame: np.ndarray) -> bytes:
    """One image as the gzip chunk its dataset stores (``write_direct_chunk``)."""
    return zlib.compress(np.ascontiguousarray(frame, dtype=np.uint8).tobytes(), GZIP_LEVEL)


def sim_state(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The MuJoCo integration state: time, qpos, qvel, act, warm start, ctrl, applied forces, mocap, ...

    Everything ``mj_step`` reads; ``mj_setState(model, data, state, SIM_STATE)`` restores it.
    """
    out = np.empty(mujoco.mj_stateSize(model, SIM_STATE))
    mujoco.mj_getState(model, data, out, SIM_STATE)
    return out


OPTIONAL_ATTRS = ("instrument_names", "state_names", "action_names")
"""File attributes that older files lack (read as empty)."""


@dataclass(frozen=True)
class DatasetInfo:
    """File-level attributes every episode of a dataset file shares."""

    task_id: str
    embodiment: str
    instruction: str
    image_height: int
    image_width: int
    cameras: tuple[str, ...]
    physics_hz: int
    control_hz: int
    vision_hz: int
    state_dim: int
    action_dim: int
    sim_state_size: int
    instrument_names: tuple[str, ...] = ()
    """Columns of each episode's ``instrument_state`` (``mechanism.value``); none without instruments."""
    state_names: tuple[str, ...] = ()
    """Per-robot names of the state entries (``robot_spec(embodiment).state_names()``); empty in
    files written before robots were switchable."""
    action_names: tuple[str, ...] = ()

    @classmethod
    def from_env(cls, env: PipetteEnv) -> DatasetInfo:
        task = env.task
        rig = env.rig
        height, width = (rig.height, rig.width) if rig is not None else (0, 0)
        return cls(
            task_id=task.id,
            embodiment=task.embodiment.robot,
            instruction=task.instruction,
            image_height=height,
            image_width=width,
            cameras=tuple(rig.ids) if rig is not None else (),
            physics_hz=task.timing.physics_hz,
            control_hz=task.timing.control_hz,
            vision_hz=task.timing.vision_hz,
            state_dim=env.world.action_dim,
            action_dim=env.world.action_dim,
            sim_state_size=mujoco.mj_stateSize(env.world.model, SIM_STATE),
            instrument_names=tuple(env.world.instrument_names),
            state_names=tuple(env.world.robot.state_names()),
            action_names=tuple(env.world.robot.action_names()),
        )

    def write(self, attrs: h5py.AttributeManager) -> None:
        attrs["format"] = FORMAT
        attrs["format_version"] = FORMAT_VERSION
        attrs["sim_state_spec"] = SIM_STATE_NAME
        for key, value in asdict(self).items():
            attrs[key] = np.array(value, dtype=h5py.string_dtype()) if isinstance(value, tuple) else value

    @classmethod
    def read(cls, attrs: h5py.AttributeManager, source: str) -> DatasetInfo:
        """Parse file attributes; raises :class:`DatasetError` naming ``source`` if they are not ours."""
        if attrs.get("format") != FORMAT:
            raise DatasetError(f"{source} is not a Pipette episode file (no format={FORMAT!r} attribute)")
        version = int(attrs.get("format_version", -1))
        if version != FORMAT_VERSION:
            raise DatasetError(f"{source} has format version {version}; this Pipette reads version {FORMAT_VERSION}")
        try:
            values: dict[str, Any] = {}
            for name, kind in cls.__annotations__.items():
                if name not in attrs and name in OPTIONAL_ATTRS:  # files written before these existed
                    continue
                raw = attrs[name]
                if name in ("cameras", *OPTIONAL_ATTRS):
                    values[name] = tuple(_text(c) for c in raw)
                elif kind == "int":
                    values[name] = int(raw)
                else:
                    values[name] = str(raw)
            return cls(**values)
        except KeyError as exc:
            raise DatasetError(f"{source}: file attribute {exc.args[0]!r} is missing") from None

    def mismatch(self, other: DatasetInfo) -> str | None:
        """Why episodes described by ``other`` cannot join a file described by ``self`` (None if they can)."""
        if other.task_id != self.task_id:
            return f"it holds episodes of task {self.task_id}, not {other.task_id}"
        if (other.image_height, other.image_width) != (self.image_height, self.image_width):
            return (
                f"its images are {self.image_height}x{self.image_width}, not {other.image_height}x{other.image_width} "
                f"(pass --image-size {self.image_height})"
            )
        if other.embodiment != self.embodiment:
            return (
                f"it holds episodes recorded on the {self.embodiment}, not the {other.embodiment}; "
                "record each robot into its own file"
            )
        for name in (
            "cameras",
            "state_dim",
            "action_dim",
            "sim_state_size",
            "control_hz",
            "physics_hz",
            "instrument_names",
        ):
            if getattr(self, name) != getattr(other, name):
                return f"its {name} is {getattr(self, name)}, not {getattr(other, name)} (the task changed)"
        return None


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


@dataclass(frozen=True)
class EpisodeSummary:
    """What a finished episode reports (and what ``data inspect`` lists)."""

    index: int
    seed: int
    source: str
    num_steps: int
    success: bool
    reason: str
    metrics: dict[str, float]
    uid: str
    variant: str = ""
    """The augmentation variant a replay was made under (its ``augment_variant``); "" for a recording."""


def fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def fsync_file(path: Path) -> None:
    with open(path, "rb+") as f:
        os.fsync(f.fileno())


class EpisodeWriter:
    """Streams one episode into ``path`` + ``.tmp``; :meth:`close` finalises it, :meth:`commit` publishes it.

    Args:
        path: Final path of the one-episode file (``.../episode_000012.h5``).
        info: The dataset's file-level attributes.
        index: Episode index in the dataset.
        seed: The seed the world was reset with (``World.reset(seed)`` restores the model).
        source: ``scripted``, ``teleop``, ...
        attrs: Extra episode attributes (provenance, expert name).
    """

    def __init__(
        self, path: Path, info: DatasetInfo, *, index: int, seed: int, source: str, attrs: dict[str, Any] | None = None
    ) -> None:
        self.path = Path(path)
        self.tmp = self.path.with_name(self.path.name + ".tmp")
        self.info = info
        self.index, self.seed, self.source = index, seed, source
        self.uid = uuid.uuid4().hex
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = h5py.File(self.tmp, "w")
        info.write(self._file.attrs)
        self.group = self._file.create_group(EPISODES).create_group(episode_name(index))
        self._attrs = dict(attrs or {})
        self._rows: dict[str, list[Any]] = {
            k: []
            for k in (
                "state",
                "action",
                "sim_state",
                "sim_time",
                "wall_time",
                "step",
                "fresh",
                "frame_age",
                "instruction",
                "stage",
                "instrument",
                "executed",
            )
        }
        self._images: dict[str, h5py.Dataset] = {}
        self._last_chunk: dict[str, tuple[np.ndarray, bytes]] = {}
        self._started = time.time()
        self.num_steps = 0
        self.closed = False

    def __enter__(self) -> EpisodeWriter:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is not None or not self.closed:
            self.abort()

    # ----------------------------------------------------------------- per step
    def _image_dataset(self, camera: str, frame: np.ndarray) -> h5py.Dataset:
        if camera not in self._images:
            h, w, c = frame.shape
            self._images[camera] = self.group.require_group("images").create_dataset(
                camera,
                shape=(0, h, w, c),
                maxshape=(None, h, w, c),
                dtype=np.uint8,
                chunks=(1, h, w, c),
                compression="gzip",
                compression_opts=GZIP_LEVEL,
            )
        return self._images[camera]

    def add(
        self,
        obs: Observation,
        action: np.ndarray,
        state: np.ndarray,
        chunks: Mapping[str, bytes] | None = None,
        executed: np.ndarray | None = None,
    ) -> None:
        """Record control step ``obs.step``: the observation, the action about to be applied, and the
        simulator state before it (:func:`sim_state`). ``chunks`` may hold ``obs.images`` already
        compressed with :func:`compress_frame` (e.g. by another thread while the next frame renders).
        ``executed``: the action the simulation applied when the recorded one is another (a corrective
        label); given for every step of an episode or for none, written as ``executed_action``."""
        k = self.num_steps
        if k > 0 and (executed is not None) != bool(self._rows["executed"]):
            raise DatasetError(f"step {obs.step}: an executed action is given for every step of an episode or none")
        for camera, frame in obs.images.items():
            dataset = self._image_dataset(camera, frame)
            last = self._last_chunk.get(camera)
            if chunks is not None and camera in chunks:
                last = (frame, chunks[camera])
                self._last_chunk[camera] = last
            elif last is None or obs.fresh or last[0] is not frame:  # a stale step reuses the same array
                last = (obs.images[camera], compress_frame(frame))
                self._last_chunk[camera] = last
            dataset.resize(k + 1, axis=0)
            dataset.id.write_direct_chunk((k, 0, 0, 0), last[1])
        rows = self._rows
        rows["state"].append(np.asarray(obs.state, dtype=np.float32))
        rows["action"].append(np.asarray(action, dtype=np.float64).copy())
        if executed is not None:
            rows["executed"].append(np.asarray(executed, dtype=np.float64).copy())
        rows["sim_state"].append(np.asarray(state, dtype=np.float64).copy())
        rows["sim_time"].append(obs.sim_time)
        rows["wall_time"].append(obs.wall_time)
        rows["step"].append(obs.step)
        rows["fresh"].append(obs.fresh)
        rows["frame_age"].append(obs.frame_age)
        rows["instruction"].append(obs.instruction)
        rows["stage"].append(obs.stage)
        if len(obs.instrument) != len(self.info.instrument_names):
            raise DatasetError(
                f"step {obs.step} has {len(obs.instrument)} instrument values; the dataset records "
                f"{len(self.info.instrument_names)} ({', '.join(self.info.instrument_names) or 'none'})"
            )
        rows["instrument"].append(np.asarray(obs.instrument, dtype=np.float64).copy())
        self.num_steps += 1

    # ------------------------------------------------------------------- finish
    def close(
        self, verdict: Verdict, final_state: np.ndarray, final_sim_state: np.ndarray, *, undecided: str = TRUNCATED
    ) -> EpisodeSummary:
        """Write the per-step arrays, the final state and the verdict; fsync the ``.tmp`` file.

        Args:
            verdict: The evaluator's last verdict.
            final_state: Proprioceptive state after the last action.
            final_sim_state: Simulator state after the last action.
            undecided: Failure reason recorded when the evaluator had not decided yet
                (``max_steps``: cut at the step cap; ``stopped``: ended by the operator).
        """
        if self.num_steps == 0:
            raise DatasetError("an episode needs at least one control step")
        g, rows = self.group, self._rows
        g.create_dataset("state", data=np.stack(rows["state"]))
        g.create_dataset("action", data=np.stack(rows["action"]))
        if rows["executed"]:
            g.create_dataset("executed_action", data=np.stack(rows["executed"]))
        g.create_dataset("sim_state", data=np.stack(rows["sim_state"]), compression="gzip", compression_opts=GZIP_LEVEL)
        g.create_dataset("sim_time", data=np.asarray(rows["sim_time"], dtype=np.float64)).attrs["unit"] = "s"
        g.create_dataset("wall_time", data=np.asarray(rows["wall_time"], dtype=np.float64)).attrs["unit"] = "s"
        g.create_dataset("step", data=np.asarray(rows["step"], dtype=np.int32))
        g.create_dataset("fresh", data=np.asarray(rows["fresh"], dtype=bool))
        g.create_dataset("frame_age", data=np.asarray(rows["frame_age"], dtype=np.int32))
        g.create_dataset(
            "instruction",
            data=rows["instruction"],
            dtype=h5py.string_dtype(),
            compression="gzip",
            compression_opts=GZIP_LEVEL,
        )
        g.create_dataset("stage", data=np.asarray(rows["stage"], dtype=np.int32))
        if self.info.instrument_names:
            g.create_dataset("instrument_state", data=np.stack(rows["instrument"]))
            g["instrument_state"].attrs["names"] = np.array(self.info.instrument_names, dtype=h5py.string_dtype())
        g.create_dataset("final_state", data=np.asarray(final_state, dtype=np.float32))
        g.create_dataset("final_sim_state", data=np.asarray(final_sim_state, dtype=np.float64))
        truncated = not verdict.done
        reason = (verdict.reason or "") if verdict.done else undecided
        summary = EpisodeSummary(
            index=self.index,
            seed=self.seed,
            source=self.source,
            num_steps=self.num_steps,
            success=bool(verdict.success),
            reason=reason,
            metrics={k: float(v) for k, v in verdict.metrics.items()},
            uid=self.uid,
        )
        attrs = g.attrs
        attrs.update(
            {
                "index": self.index,
                "seed": self.seed,
                "source": self.source,
                "uid": self.uid,
                "task_id": self.info.task_id,
                "embodiment": self.info.embodiment,
                "instruction": self.info.instruction,
                "num_steps": self.num_steps,
                "success": summary.success,
                "failed": bool(verdict.failed),
                "truncated": truncated,
                "reason": reason,
                "metrics": json.dumps(summary.metrics, sort_keys=True),
                "recorded_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(self._started)),
                "wall_duration_s": time.time() - self._started,
            }
        )
        for key, value in self._attrs.items():
            attrs[key] = value
        self._file.close()
        fsync_file(self.tmp)
        self.closed = True
        self.summary = summary
        return summary

    def commit(self) -> Path:
        """Atomically publish the closed ``.tmp`` file as ``path``."""
        if not self.closed:
            raise DatasetError("close the episode before committing it")
        commit_tmp(self.tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the episode: close and delete the ``.tmp`` file."""
        try:
            if self._file.id.valid:
                self._file.close()
        finally:
            self.tmp.unlink(missing_ok=True)
            self.closed = True


def commit_tmp(tmp: Path, path: Path) -> None:
    """``os.replace`` a fsynced temporary file onto ``path`` and fsync the folder."""
    os.replace(tmp, path)
    fsync_dir(path.parent)


def write_json_atomic(path: Path, data: Any, *, indent: int = 1, sort_keys: bool = True) -> None:
    """Write ``data`` as JSON to ``path`` so that a crash leaves the old file or the new one,
    never a torn one: ``path.tmp``, fsync, rename (:func:`commit_tmp`)."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        json.dump(data, f, indent=indent, sort_keys=sort_keys)
        f.write("\n")
        f.flush()
        os.fsync(f.fileno())
    commit_tmp(tmp, path)


def read_summary(group: h5py.Group) -> EpisodeSummary:
    """The summary stored in an episode group's attributes."""
    a = group.attrs
    return EpisodeSummary(
        index=int(a["index"]),
        seed=int(a["seed"]),
        source=str(a["source"]),
        num_steps=int(a["num_steps"]),
        success=bool(a["success"]),
        reason=str(a["reason"]),
        metrics=json.loads(str(a["metrics"])),
        uid=str(a["uid"]),
        variant=str(a.get("augment_variant", "")),
    )
