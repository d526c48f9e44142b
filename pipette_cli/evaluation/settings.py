"""What an evaluation is set to: how a policy's answers become robot commands
(:class:`DecodeConfig`, paper A.4 / A.6 per policy type) and what every episode of a run shares
(:class:`EvalSettings`). Light on purpose (no ZeroMQ, no SciPy): ``pipette eval`` binds its options
to these fields, and each field's description is the help of its option.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipette_cli.errors import PipetteError
from pipette_cli.serving.protocol import DEFAULT_TIMEOUT_MS
from pipette_cli.specs.base import described

POLICY_TYPES = ("act", "smolvla", "pi0")
ADHOC_EPISODES = 100
"""Episodes of an evaluation without a suite (paper, experimental setup: 100 per model and task)."""
ADHOC_SEED = 0
"""Seed of the first episode without a suite; episode ``i`` uses ``ADHOC_SEED + i``."""


@dataclass(frozen=True)
class DecodeConfig:
    """How a policy's answers become robot commands (paper A.4 / A.6 defaults per policy)."""

    policy_type: str = described("act", "act, smolvla or pi0")
    open_threshold: float = described(0.5, "gripper command u at or above which a closed gripper opens (paper A.6)")
    stay_open_threshold: float = described(0.5, "u above which an open gripper stays open (hysteresis below 0.5)")
    timeout_ms: int = described(DEFAULT_TIMEOUT_MS["act"], "ms a query may take before it fails (paper A.4)")
    max_consecutive_failures: int = described(6, "failed queries in a row before the safe hold (paper A.4)")
    float_images: bool = described(True, "images sent as float32 CHW in [0, 1] (ACT), else uint8 (SmolVLA, pi0)")

    @classmethod
    def for_policy(cls, policy_type: str) -> DecodeConfig:
        """The paper's settings for ``policy_type`` (pi0: thresholds 0.55 / 0.45, 300 s, 20 failures)."""
        if policy_type not in POLICY_TYPES:
            raise PipetteError(f"unknown policy type {policy_type!r}; expected one of {', '.join(POLICY_TYPES)}")
        if policy_type == "act":
            return cls("act")
        if policy_type == "smolvla":
            return cls("smolvla", float_images=False)
        return cls("pi0", 0.55, 0.45, DEFAULT_TIMEOUT_MS["pi0"], 20, float_images=False)

    @property
    def chunked(self) -> bool:
        return self.policy_type != "act"


@dataclass(frozen=True)
class EvalSettings:
    """What every episode of an evaluation shares."""

    config: DecodeConfig
    image_size: int | None = described(
        None, "Camera image side without a suite, must match the policy's (default: the task's cameras)"
    )
    render_profile: str = described("fast", "render profile: fast or full")
    dataset_version: str = described("raw", "raw or augmented: the label `eval report` groups by")
    suite: dict[str, Any] | None = None
    """``{"id", "version", "sha256"}`` of the suite, None for an ad-hoc run."""


def checkpoint_policy_type(path: Path) -> str:
    """The policy ``type`` LeRobot wrote into ``path/config.json`` (``act``, ``smolvla``, ``pi0``).

    Raises:
        PipetteError: ``path`` holds no readable ``config.json`` with a ``type``.
    """
    config = Path(path) / "config.json"
    if not config.is_file():
        raise PipetteError(f"{path}: not a LeRobot policy folder (no config.json); pass the pretrained_model folder")
    try:
        policy_type = json.loads(config.read_text(encoding="utf-8")).get("type")
    except (OSError, ValueError, AttributeError) as exc:
        raise PipetteError(f"{config}: not a readable LeRobot policy config: {exc}") from exc
    if not isinstance(policy_type, str):
        raise PipetteError(f"{config}: no policy 'type' field; pass --policy-type ({', '.join(POLICY_TYPES)})")
    return policy_type


def resolve_policy_type(given: str | None, checkpoint: Path | None) -> str:
    """The policy type to decode with: the checkpoint's ``config.json`` ``type``, which an explicit
    ``given`` must agree with; ``given`` (default: :class:`DecodeConfig`'s) when there is no
    checkpoint (a server).

    Raises:
        PipetteError: ``given`` contradicts the checkpoint, or the checkpoint's type is unknown.
    """
    if checkpoint is None:
        return given or DecodeConfig().policy_type
    found = checkpoint_policy_type(checkpoint)
    if given is not None and given != found:
        raise PipetteError(
            f"--policy-type {given} contradicts {Path(checkpoint) / 'config.json'}, which says type "
            f"{found!r}; drop --policy-type or pass the right checkpoint"
        )
    if found not in POLICY_TYPES:
        raise PipetteError(
            f"{Path(checkpoint) / 'config.json'}: policy type {found!r} cannot be evaluated; "
            f"expected one of {', '.join(POLICY_TYPES)}"
        )
    return found


def checkpoint_images(path: Path) -> dict[str, tuple[int, ...]]:
    """``observation.images.<camera>`` -> CHW shape, the images a LeRobot policy folder's
    ``config.json`` says the policy reads (its ``VISUAL`` input features); empty when it names none.

    Raises:
        PipetteError: ``path`` holds no readable ``config.json``.
    """
    config = Path(path) / "config.json"
    try:
        features = json.loads(config.read_text(encoding="utf-8")).get("input_features") or {}
    except (OSError, ValueError, AttributeError) as exc:
        raise PipetteError(f"{config}: not a readable LeRobot policy config: {exc}") from exc
    return {
        key: tuple(int(n) for n in feature["shape"])
        for key, feature in features.items()
        if isinstance(feature, dict) and feature.get("type") == "VISUAL" and feature.get("shape")
    }


def image_size_problem(images: dict[str, Any], rendered: tuple[int, int], policy: str, fix: str) -> str | None:
    """One line saying which camera image of the policy differs from the ``(height, width)`` an
    evaluation renders, None when all match (a policy scores nothing on images of another size).

    Args:
        images: Request key -> CHW shape, as a policy reads them (a server's ``info``, a checkpoint).
        rendered: Height and width of the rendered images.
        policy: How the policy is named in the line (``at tcp://...``, ``in ckpt/``).
        fix: The option that sets the rendered size, with its value (``--image-size``).
    """
    for key, shape in images.items():
        if tuple(shape[-2:]) != tuple(rendered):
            return (
                f"the policy {policy} reads {key.rsplit('.', 1)[-1]} images of {shape[-2]}x{shape[-1]}, "
                f"but this evaluation renders {rendered[0]}x{rendered[1]} ({fix})"
            )
    return None
