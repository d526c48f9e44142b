"""Where a recorded episode came from: code version, simulator, and hashes of its inputs.

Stored on every episode of an HDF5 file (:mod:`.recorder`) so that a dataset can be traced to
the code, the MuJoCo build, the task spec and the exact asset files that produced it.
"""

from __future__ import annotations

import hashlib
import json
import logging
import subprocess
from functools import cache
from pathlib import Path

import mujoco
import numpy as np

import pipette_cli
from pipette_cli.assets.library import load_asset_library
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def task_spec_sha256(task: TaskSpec) -> str:
    """SHA-256 of the task spec's canonical JSON (sorted keys, no whitespace)."""
    canonical = json.dumps(task.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
    return sha256_bytes(canonical.encode())


def asset_hashes(task: TaskSpec) -> dict[str, str]:
    """SHA-256 of every USD asset file the task's scene uses (bench and objects), by asset id."""
    library = load_asset_library()
    ids = sorted({task.scene.bench, *(o.asset for o in task.scene.objects)})
    return {asset_id: sha256_file(library.get(asset_id).path) for asset_id in ids}


def model_sha256(model: mujoco.MjModel) -> str:
    """SHA-256 of the compiled model (MJB bytes): robot meshes and all, as the episode saw it."""
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return sha256_bytes(buffer.tobytes())


@cache
def git_state() -> tuple[str, bool]:
    """``(commit, dirty)`` of the source tree the package runs from; ``("unknown", False)`` outside git."""
    root = Path(pipette_cli.__file__).resolve().parent
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        status = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown", False
    return commit or "unknown", bool(status.strip())


def provenance(task: TaskSpec, model: mujoco.MjModel | None = None) -> dict[str, str | bool]:
    """The provenance attributes of an episode recorded for ``task``.

    Returns:
        ``package_version``, ``git_commit``, ``git_dirty``, ``mujoco_version``,
        ``task_spec_sha256``, ``assets_sha256`` (JSON object: asset id -> SHA-256) and, when
        ``model`` is given, ``model_sha256``.
    """
    commit, dirty = git_state()
    out: dict[str, str | bool] = {
        "package_version": pipette_cli.__version__,
        "git_commit": commit,
        "git_dirty": dirty,
        "mujoco_version": mujoco.__version__,
        "task_spec_sha256": task_spec_sha256(task),
        "assets_sha256": json.dumps(asset_hashes(task), sort_keys=True),
    }
    if model is not None:
        out["model_sha256"] = model_sha256(model)
    return out
