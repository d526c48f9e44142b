"""Summary of a converted LeRobot dataset: episodes, frames, per-feature ranges, success provenance.

Reads LeRobot's own metadata (``LeRobotDatasetMetadata``: ``meta/info.json``, ``meta/stats.json``,
the episodes table) and Pipette's ``meta/pipette.json``. The folder must hold a dataset: the
metadata loader would otherwise try to download it, so a missing ``meta/info.json`` is an error
raised before it is called.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from pipette_cli.errors import DatasetError, plural
from pipette_cli.lerobot.convert import PROVENANCE_FILE, PROVENANCE_FORMAT


def load_provenance(root: Path) -> dict[str, Any] | None:
    """``meta/pipette.json`` of a dataset converted by Pipette (``None`` for other datasets)."""
    path = Path(root) / PROVENANCE_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path} is unreadable: {exc}") from None
    if not isinstance(data, dict) or data.get("format") != PROVENANCE_FORMAT:
        raise DatasetError(f"{path} is not a Pipette provenance file (format != {PROVENANCE_FORMAT!r})")
    return data


def _rounded(values: Any) -> Any:
    array = np.asarray(values, dtype=np.float64)
    return np.round(array, 6).tolist()


def _unperturbed(perturbation: dict[str, Any]) -> bool:
    """True for an augmented episode whose variant perturbs nothing (``--variants original``: the demo
    re-rendered, e.g. at another image size): its recorded perturbation parameters are empty."""
    params = perturbation.get("augment_params")
    if not isinstance(params, str):
        return False
    try:
        return json.loads(params) == {}
    except ValueError:
        return False


def dataset_stats(root: Path) -> dict[str, Any]:
    """Episodes, frames, feature ranges and (for Pipette datasets) success provenance of ``root``.

    Raises:
        DatasetError: ``root`` is not a LeRobot dataset folder or its metadata is damaged.
    """
    root = Path(root)
    if not (root / "meta" / "info.json").is_file():
        raise DatasetError(f"{root} is not a LeRobot dataset (no meta/info.json); convert one with `pipette convert`")
    provenance = load_provenance(root)
    repo_id = str(provenance["repo_id"]) if provenance else f"local/{root.name}"
    from lerobot.datasets.dataset_metadata import LeRobotDatasetMetadata  # deferred: lerobot, torch (~4 s)

    try:
        meta = LeRobotDatasetMetadata(repo_id, root=root)
        lengths = [int(n) for n in meta.episodes["length"]]
    except (OSError, ValueError, KeyError) as exc:
        raise DatasetError(f"{root}: LeRobot cannot read the metadata ({exc})") from None
    features: dict[str, Any] = {}
    for name, spec in meta.features.items():
        if name in ("timestamp", "frame_index", "episode_index", "index", "task_index"):
            continue
        entry: dict[str, Any] = {"dtype": spec["dtype"], "shape": list(spec["shape"])}
        names = spec.get("names")
        if spec["dtype"] not in ("image", "video") and isinstance(names, list) and [len(names)] == entry["shape"]:
            entry["names"] = [str(n) for n in names]  # what each dimension of a vector is ("joint1", "gripper")
        stats = (meta.stats or {}).get(name)
        if stats is not None:
            lo, hi = np.asarray(stats["min"]), np.asarray(stats["max"])
            if spec["dtype"] in ("image", "video"):  # per channel, scaled to [0, 1]
                lo, hi = lo.reshape(-1), hi.reshape(-1)
            entry.update(min=_rounded(lo), max=_rounded(hi), mean=_rounded(np.asarray(stats["mean"]).reshape(lo.shape)))
        features[name] = entry
    report: dict[str, Any] = {
        "root": str(root),
        "repo_id": repo_id,
        "codebase_version": meta.info.get("codebase_version"),
        "fps": meta.fps,
        "robot_type": meta.robot_type,
        "episodes": meta.total_episodes,
        "frames": meta.total_frames,
        "episode_length": {"min": min(lengths, default=0), "max": max(lengths, default=0)},
        "video": bool(meta.video_keys),
        "tasks": [str(t) for t in meta.tasks.index],
        "features": features,
    }
    if provenance:
        episodes = provenance.get("episodes", [])
        if len(episodes) != meta.total_episodes:
            raise DatasetError(
                f"{root}: {PROVENANCE_FILE} describes {plural(len(episodes), 'episode')} but the dataset has {meta.total_episodes}"
            )
        successes = sum(bool(e.get("success")) for e in episodes)
        report["provenance"] = {
            "dataset_version": provenance.get("dataset_version"),
            "frame_filter": provenance.get("frame_filter"),
            "successful": successes,
            "failed": len(episodes) - successes,
            "failure_reasons": dict(Counter(str(e.get("reason")) for e in episodes if not e.get("success"))),
            "skipped_failed": len(provenance.get("skipped", [])),
            "sources": dict(Counter(str(e.get("source", "?")) for e in episodes)),
            "perturbed": sum("perturbation" in e and not _unperturbed(e["perturbation"]) for e in episodes),
            "originals": sum("perturbation" in e and _unperturbed(e["perturbation"]) for e in episodes),
            "files": provenance.get("sources", []),
            "task_ids": provenance.get("task_ids", []),
        }
    return report
