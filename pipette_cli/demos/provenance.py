"""Where a recorded episode came from: code version, simulator, and hashes of its inputs.

Stored on every episode of an HDF5 file (:mod:`.recorder`) so that a dataset can be traced to
the code, the MuJoCo build, the task spec and the exact asset files that produced it.
"""

from __future__ import annotations

import hashlib
import json
import logging
import subprocess
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

import pipette_cli
from pipette_cli.assets.library import load_asset_library
from pipette_cli.demos.store import DatasetStatus, open_h5
from pipette_cli.kernels import blas_kernel
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


def files_sha256(root: Path) -> str:
    """SHA-256 over every file under ``root`` but bytecode caches (each path, size and bytes, in path order)."""
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts):
        data = path.read_bytes()
        digest.update(f"{path.relative_to(root).as_posix()}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()


@cache
def code_sha256() -> str:
    """:func:`files_sha256` of the package: the code that runs, edits included, whether it came from git
    or from a wheel (a commit hash changes when the same patch is applied again; this does not)."""
    return files_sha256(Path(pipette_cli.__file__).resolve().parent)


def provenance_code() -> dict[str, str]:
    """The attributes that name the code running now (:func:`code_version` reads them back)."""
    commit, _dirty = git_state()
    return {
        "package_version": pipette_cli.__version__,
        "code_sha256": code_sha256(),
        "git_commit": commit,
        "mujoco_version": mujoco.__version__,
    }


def provenance(task: TaskSpec, model: mujoco.MjModel | None = None) -> dict[str, str | bool]:
    """The provenance attributes of an episode recorded for ``task``.

    Returns:
        ``package_version``, ``code_sha256`` (:func:`code_sha256`), ``git_commit``, ``git_dirty``, ``mujoco_version``,
        ``blas_kernel`` (OpenBLAS's, :func:`pipette_cli.kernels.blas_kernel`),
        ``task_spec_sha256``, ``assets_sha256`` (JSON object: asset id -> SHA-256) and, when
        ``model`` is given, ``model_sha256``.
    """
    out: dict[str, str | bool] = {
        **provenance_code(),
        "git_dirty": git_state()[1],
        "blas_kernel": blas_kernel(),
        "task_spec_sha256": task_spec_sha256(task),
        "assets_sha256": json.dumps(asset_hashes(task), sort_keys=True),
    }
    if model is not None:
        out["model_sha256"] = model_sha256(model)
    return out


def code_version(attrs: Mapping[str, Any]) -> tuple[str, str, str]:
    """The code that made an episode, from its attributes: pipette's version, its source (the hash of
    its files; an episode recorded before that was kept, by its git commit) and MuJoCo's version."""
    source = attrs.get("code_sha256")
    made = f"source {str(source)[:12]}" if source else f"commit {str(attrs.get('git_commit', '?'))[:12]}"
    return str(attrs.get("package_version", "?")), made, str(attrs.get("mujoco_version", "?"))


def describe_code(version: tuple[str, str, str]) -> str:
    package, made, engine = version
    return f"pipette {package} ({made}) with MuJoCo {engine}"


def code_change(attrs: Mapping[str, Any]) -> str | None:
    """``recorded by X, replayed by Y`` when an episode's code is not the code running now, else None:
    why a replay may differ from its recording though the file is sound."""
    theirs, here = code_version(attrs), code_version(provenance_code())
    return None if theirs == here else f"recorded by {describe_code(theirs)}, replayed by {describe_code(here)}"


def replay_reason(why: str, attrs: Mapping[str, Any]) -> str:
    """Why a replay failed, with :func:`code_change` added where other code recorded the episode."""
    changed = code_change(attrs)
    return why if changed is None else f"{why} ({changed})"


def recorded_code(status: DatasetStatus) -> set[tuple[str, str, str]]:
    """The code versions (:func:`code_version`) that made the episodes of ``status``'s file and parts."""
    groups: dict[Path, list[str]] = {}
    for ref in status.episodes:
        groups.setdefault(ref.file, []).append(ref.group)
    found: set[tuple[str, str, str]] = set()
    for path, names in groups.items():  # the packed file once, each part once
        with open_h5(path) as f:
            found.update(code_version(f[name].attrs) for name in names)
    return found


def mixing_problem(status: DatasetStatus, task: TaskSpec) -> str | None:
    """Why new episodes made by this code must not join ``status``'s file, or None.

    A file whose episodes were made by other code (another pipette version or source, another
    MuJoCo) would hold two versions' physics, experts and retargeting, which no reader can tell
    apart by looking at the data; episodes are compared by :func:`code_version`.
    """
    here = code_version(provenance_code())
    others = sorted(recorded_code(status) - {here})
    if not others:
        return None
    return (
        f"{status.path} holds episodes made by {describe_code(others[0])}; this is {describe_code(here)}: "
        f"adding {task.id} episodes here would mix two versions' physics and experts in one file. "
        "Finish it with the version that began it, or write to another file"
    )
