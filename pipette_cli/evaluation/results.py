"""Evaluation results on disk: one folder per (task, policy) run, rebuilt from its episode logs.

A run folder holds

* ``run.json``: what the run is (task and task-spec hash, suite id/version/hash, the planned
  episodes' seeds and instructions, image size, render profile, policy, decoding, dataset
  version). A rerun into the same folder must plan the same run, except that one plan may
  extend the other (``--episodes 100`` after ``--episodes 50`` plays 50 more); the manifest
  keeps the longer plan.
* ``episode_XXXX.json``: one per finished episode (:class:`~pipette_cli.evaluation.evaluate.EpisodeLog`),
  written atomically (temporary file, fsync, rename), so a killed run leaves whole logs only.
* ``summary.json``: derived from the logs (success with its Wilson interval, failures by reason,
  stage progress, environments) and rewritten after every run, partial ones included. Anything
  that reads results can rebuild it from the logs (:func:`summarize`), so a lost or stale summary
  loses nothing.
"""

from __future__ import annotations

import json
import os
import platform
from collections import Counter
from dataclasses import asdict
from importlib import metadata
from pathlib import Path
from typing import Any

import mujoco

import pipette_cli
from pipette_cli.demos.provenance import code_sha256, git_state, sha256_file, task_spec_sha256
from pipette_cli.demos.recorder import write_json_atomic
from pipette_cli.errors import DatasetError
from pipette_cli.evaluation.evaluate import EpisodeLog
from pipette_cli.evaluation.settings import DecodeConfig
from pipette_cli.evaluation.significance import wilson_interval
from pipette_cli.evaluation.suites import EpisodePlan
from pipette_cli.kernels import PORTABLE, blas_kernel
from pipette_cli.specs.task import TaskSpec

RUN_FORMAT = "pipette.eval/1"
MANIFEST_FILE = "run.json"
SUMMARY_FILE = "summary.json"
VOLATILE = {("policy", "endpoints"), ("policy", "path")}
"""Manifest fields a resumed run may change: where the same policy is served or stored."""


def episode_file(folder: Path, index: int) -> Path:
    return Path(folder) / f"episode_{index:04d}.json"


def environment_record(gl: dict[str, str] | None = None) -> dict[str, Any]:
    """Where episodes run: package, git commit and source hash, MuJoCo, torch and lerobot versions,
    Python, the CPU kernels numpy and torch were told to use (:mod:`pipette_cli.kernels`), and the GL
    backend and renderer (``gl`` from :func:`~pipette_cli.sim.render.gl_info`)."""
    commit, dirty = git_state()

    def version(dist: str) -> str:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "absent"

    return {
        "pipette": pipette_cli.__version__,
        "git_commit": commit,
        "git_dirty": dirty,
        "mujoco": mujoco.__version__,
        "torch": version("torch"),
        "lerobot": version("lerobot"),
        "python": platform.python_version(),
        "code_sha256": code_sha256(),
        "blas_kernel": blas_kernel(),
        "cpu_kernels": {key: os.environ.get(key, "auto") for key in PORTABLE},
        **(gl or {}),
    }


def checkpoint_record(path: Path) -> dict[str, Any]:
    """A policy folder, identified by the hash of its weights (the path may move)."""
    weights = Path(path) / "model.safetensors"
    return {
        "kind": "checkpoint",
        "path": str(Path(path).resolve()),
        "sha256": sha256_file(weights) if weights.is_file() else None,
    }


def make_manifest(
    task: TaskSpec,
    episodes: list[EpisodePlan],
    *,
    suite: dict[str, Any] | None,
    image_size: int | None,
    render_profile: str,
    policy: dict[str, Any],
    config: DecodeConfig,
    dataset_version: str,
) -> dict[str, Any]:
    """The ``run.json`` of one task's run (with a shifted suite's ``conditions``)."""
    manifest: dict[str, Any] = {
        "format": RUN_FORMAT,
        "task": task.id,
        "task_spec_sha256": task_spec_sha256(task),
        "suite": suite,
        "image_size": image_size,
        "render_profile": render_profile,
        "policy": policy,
        "decode": asdict(config),
        "dataset_version": dataset_version,
        "episodes": [[e.seed, e.instruction] for e in episodes],
    }
    conditions = episodes[0].conditions if episodes else ()
    if conditions:  # only then: runs of nominal suites resume as before
        manifest["conditions"] = [c.model_dump(mode="json") for c in conditions]
    return manifest


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path}: unreadable ({exc}); delete it to run that part again") from None


def _differences(old: Any, new: Any, loc: tuple[str, ...] = ()) -> list[str]:
    if loc in VOLATILE:
        return []
    if isinstance(old, dict) and isinstance(new, dict):
        return [d for key in sorted(set(old) | set(new)) for d in _differences(old.get(key), new.get(key), (*loc, key))]
    if old != new:
        shown = "other seeds or instructions" if loc == ("episodes",) else f"{_short(old)} -> {_short(new)}"
        return [f"{'.'.join(loc)}: {shown}"]
    return []


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def prepare_folder(folder: Path, manifest: dict[str, Any]) -> dict[int, dict[str, Any]]:
    """Create or reopen a run folder; returns the finished episodes' logs by index.

    Raises:
        DatasetError: the folder holds another run (the first difference is named), or a log that
            does not belong to the plan.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for leftover in folder.glob("*.tmp"):  # a write cut short; its episode was not finished
        leftover.unlink()
    path = folder / MANIFEST_FILE
    if path.is_file():
        old = _read_json(path)
        before, now = old.get("episodes") or [], manifest["episodes"]
        longer = max(before, now, key=len)
        if longer[: len(before)] == before and longer[: len(now)] == now:  # one plan extends the other
            old, manifest = {**old, "episodes": longer}, {**manifest, "episodes": longer}
        changed = _differences(old, manifest)
        if changed:
            raise DatasetError(
                f"{folder} holds an evaluation with other settings ({changed[0]}); "
                "rerun with the same options to resume, or choose another --out"
            )
    elif any(folder.glob("episode_*.json")):
        raise DatasetError(f"{folder} holds episode logs without {MANIFEST_FILE} (an older run); choose another --out")
    write_json_atomic(path, manifest)
    done: dict[int, dict[str, Any]] = {}
    planned = manifest["episodes"]
    for log_path in sorted(folder.glob("episode_*.json")):
        log = _read_json(log_path)
        index = log.get("episode")
        if (
            not isinstance(index, int)
            or not 0 <= index < len(planned)
            or [log.get("seed"), log.get("instruction")] != planned[index]
        ):
            raise DatasetError(
                f"{log_path} is not episode {log_path.stem[8:]} of this run's plan; remove it or choose another --out"
            )
        done[index] = log
    return done


def write_episode(folder: Path, log: EpisodeLog) -> None:
    """Write one finished episode's log atomically."""
    write_json_atomic(episode_file(folder, log.episode), asdict(log), indent=2, sort_keys=False)


def read_logs(folder: Path) -> list[dict[str, Any]]:
    """Every episode log in ``folder``, by index."""
    logs = [_read_json(p) for p in sorted(Path(folder).glob("episode_*.json"))]
    return sorted(logs, key=lambda log: log.get("episode", 0))


def summarize(folder: Path, *, stopped: dict[str, Any] | None = None) -> dict[str, Any]:
    """The summary of a run folder, from its episode logs (and ``run.json`` for the plan).

    Raises:
        DatasetError: no episode logs, or unreadable files.
    """
    folder = Path(folder)
    logs = read_logs(folder)
    if not logs:
        raise DatasetError(f"{folder}: no episode logs")
    manifest = _read_json(folder / MANIFEST_FILE) if (folder / MANIFEST_FILE).is_file() else {}
    n = len(logs)
    successes = sum(bool(log["success"]) for log in logs)
    low, high = wilson_interval(successes, n)
    progress = [log["progress"] for log in logs if log.get("progress") is not None]
    stages = Counter(str(int(log["metrics"]["stage"])) for log in logs if log.get("progress") is not None)
    environments: list[dict[str, Any]] = []
    for log in logs:
        if log.get("environment") and log["environment"] not in environments:
            environments.append(log["environment"])
    planned = len(manifest.get("episodes", [])) or n
    return {
        "task": logs[0]["task"],
        "policy_type": logs[0]["policy_type"],
        "dataset_version": manifest.get("dataset_version", "raw"),
        "suite": manifest.get("suite"),
        "episodes": n,
        "planned": planned,
        "complete": n >= planned,
        "successes": successes,
        "success_rate": successes / n,
        "success_ci95": [round(low, 4), round(high, 4)],
        "failures": dict(Counter(log["failure_reason"] or "unknown" for log in logs if not log["success"])),
        "mean_progress": sum(progress) / len(progress) if progress else None,
        "final_stage_counts": dict(sorted(stages.items())) if progress else None,
        "safe_holds": sum(bool(log["safe_hold"]) for log in logs),
        "failed_queries": sum(int(log["failed_queries"]) for log in logs),
        "mean_runtime_s": sum(float(log["runtime_s"]) for log in logs) / n,
        "image_size": manifest.get("image_size"),
        "render_profile": manifest.get("render_profile"),
        "policy": manifest.get("policy"),
        "environments": environments,
        "stopped": stopped,
    }


def write_summary(folder: Path, *, stopped: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """Rebuild ``summary.json`` from the logs (None when no episode has finished yet)."""
    if not any(Path(folder).glob("episode_*.json")):
        return None
    summary = summarize(folder, stopped=stopped)
    write_json_atomic(Path(folder) / SUMMARY_FILE, summary, indent=2, sort_keys=False)
    return summary
