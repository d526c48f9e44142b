"""What a step makes: the path a later step's ``{"from_step": N}`` stands for.

Most commands name their output in an option (``collect --out``, ``augment --output``, see
``products`` in the vocabulary); for the others the path is computed with the library's own
layout functions: ``convert`` writes ``datasets/<task>/<version>`` unless ``--root`` is given,
``train`` leaves its policy in ``<output_root>/<policy>/<task>_<version>/checkpoints/last/pretrained_model``.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pipette_cli.agent.catalog import CommandInfo
from pipette_cli.agent.plan import StepRef
from pipette_cli.agent.vocabulary import WorkflowVocabularySpec
from pipette_cli.lerobot.convert import DatasetVersion, default_root, slug
from pipette_cli.lerobot.layout import LAST_CHECKPOINT
from pipette_cli.lerobot.train import DEFAULT_OUTPUT_ROOT, Policy, run_dir


def _arg(info: CommandInfo, args: dict[str, Any], name: str) -> Any:
    value = args.get(name)
    return info.params[name].default if value is None and name in info.params else value


def _convert(info: CommandInfo, args: dict[str, Any], task: str | None) -> Path | None:
    version = _arg(info, args, "dataset_version")
    if task is None or version not in {v.value for v in DatasetVersion}:
        return None
    return default_root(task, DatasetVersion(version))


def _train(info: CommandInfo, args: dict[str, Any], task: str | None) -> Path | None:
    tasks, policy = args.get("tasks"), args.get("policy")
    version = _arg(info, args, "dataset_version")
    if not isinstance(tasks, str) or "," in tasks or tasks == "all" or policy not in {p.value for p in Policy}:
        return None
    if version not in {v.value for v in DatasetVersion}:
        return None
    root = Path(_arg(info, args, "output_root") or DEFAULT_OUTPUT_ROOT)
    return run_dir(tasks, Policy(policy), DatasetVersion(version), root) / LAST_CHECKPOINT


def train_run_of(path: str, task_ids: list[str]) -> dict[str, str] | None:
    """The ``train`` arguments a run folder in its layout stands for (``outputs/train/act/
    pipette_PickUpTestTube-v1_raw[/checkpoints/...]``: ``--output-root outputs/train --policy act --tasks
    pipette/PickUpTestTube-v1 --dataset-version raw``), or None for any other path."""
    policies = "|".join(p.value for p in Policy)
    versions = "|".join(v.value for v in DatasetVersion)
    m = re.fullmatch(rf"(?:(.*)/)?({policies})/([\w.-]+)_({versions})(?:/checkpoints(?:/.*)?)?/?", path)
    task = next((t for t in task_ids if m and slug(t) == m.group(3)), None)
    if m is None or task is None:
        return None
    return {"output_root": m.group(1) or ".", "policy": m.group(2), "tasks": task, "dataset_version": m.group(4)}


def version_in_path(path: str) -> str | None:
    """The dataset version a policy folder in ``train``'s layout names (``.../<task>_augmented/
    checkpoints/...``: ``augmented``), else None."""
    versions = "|".join(v.value for v in DatasetVersion)
    m = re.search(rf"_({versions})(?=/|$)", path)
    return m.group(1) if m else None


RULES: dict[str, Callable[[CommandInfo, dict[str, Any], str | None], Path | None]] = {
    "convert": _convert,
    "train": _train,
}


def product_of(
    info: CommandInfo, args: dict[str, Any], task: str | None, vocab: WorkflowVocabularySpec
) -> tuple[str | None, str | None]:
    """(path, kind) of what the step makes, or (None, None)."""
    spec = vocab.products.get(info.name)
    if spec is None:
        return None, None
    value = _arg(info, args, spec.param) if spec.param in info.params else None
    if value is None or isinstance(value, StepRef):
        rule = RULES.get(info.name)
        value = rule(info, args, task) if rule else None
    return (str(value), spec.kind) if value not in (None, "") else (None, None)
