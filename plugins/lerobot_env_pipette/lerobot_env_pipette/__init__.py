"""LeRobot env plugin for Pipette tasks.

LeRobot imports installed distributions whose name starts with ``lerobot_env_`` (see
``lerobot.utils.import_utils.register_third_party_plugins``); importing this one registers
the ``pipette`` env type, so

    lerobot-eval --policy.path=OUT/pretrained_model --env.type=pipette \\
        --env.task=pipette/PickUpTestTube-v1 --eval.n_episodes=10 --eval.batch_size=1

evaluates a LeRobot policy in a Pipette task. Images are ``observation.images.top|main|wrist``,
the state ``observation.state``, the action joint targets plus the gripper command.

Images are rendered at the size the policy reads (its ``config.json``, for a local
``--policy.path``), else at the task's camera size (400 px). ``--env.image_size=N`` sets it; one
that contradicts the policy stops the run with one line naming both sizes, as ``pipette eval``
does: a policy scores nothing on images of another size, without a word.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_IMAGES, OBS_STATE

CAMERAS = ("top", "main", "wrist")
log = logging.getLogger(__name__)


@EnvConfig.register_subclass("pipette")
@dataclass
class PipetteEnvConfig(EnvConfig):
    """A Pipette task as a LeRobot environment (policy queried at the vision rate, 10 Hz)."""

    task: str | None = "pipette/PickUpTestTube-v1"
    fps: int = 10
    image_size: int | None = None
    """Square image side rendered; default: the policy's (``--policy.path``), else the task's cameras."""
    render_profile: str = "fast"
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from pipette_cli.registry import load_registry

        spec = load_registry().get(self.task)
        self.task = spec.id
        self.image_size = fit_image_size(self.image_size, policy_path(), (spec.cameras.height, spec.cameras.width))
        from pipette_cli.specs.robot import robot_spec

        dim = robot_spec(spec.embodiment.robot).arm_dof + 1  # arm joints + the gripper
        self.features = {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(dim,))}
        self.features["agent_pos"] = PolicyFeature(type=FeatureType.STATE, shape=(dim,))
        self.features_map = {ACTION: ACTION, "agent_pos": OBS_STATE}
        for cam in CAMERAS:
            key = f"pixels/{cam}"
            self.features[key] = PolicyFeature(type=FeatureType.VISUAL, shape=(self.image_size, self.image_size, 3))
            self.features_map[key] = f"{OBS_IMAGES}.{cam}"

    @property
    def package_name(self) -> str:
        return "pipette_cli.envs"  # imported by LeRobot when the gym id is not yet registered

    @property
    def gym_id(self) -> str:
        return str(self.task)

    @property
    def gym_kwargs(self) -> dict:
        return {"image_size": self.image_size, "render_profile": self.render_profile, "render_mode": "rgb_array"}


def policy_path() -> Path | None:
    """The local folder ``--policy.path`` names on this command line (``lerobot-eval``), if any."""
    from lerobot.configs import parser

    given = parser.get_path_arg("policy")
    return Path(given) if given and (Path(given) / "config.json").is_file() else None


def fit_image_size(given: int | None, policy: Path | None, cameras: tuple[int, int]) -> int:
    """The image side to render: ``given`` (``--env.image_size``), else the size the ``policy``
    folder's images have, else the task's cameras; a size other than the policy's stops the run.

    Raises:
        SystemExit: with one line naming both sizes and the flag (``lerobot-eval`` prints it).
    """
    from pipette_cli.evaluation.settings import checkpoint_images, image_size_problem

    images = checkpoint_images(policy) if policy is not None else {}
    if given is None:
        if _side(images) != "N":
            size = int(_side(images))
            if (size, size) != cameras:
                log.info(
                    "rendering %dx%d images, the size the policy in %s reads (--env.image_size)", size, size, policy
                )
            return size
        given = cameras[0] if cameras[0] == cameras[1] else max(cameras)
    problem = image_size_problem(images, (given, given), f"in {policy}", f"set --env.image_size={_side(images)}")
    if problem is not None:
        raise SystemExit(f"error: {problem}")
    return given


def _side(images: dict[str, tuple[int, ...]]) -> str:
    """The one square side every image has, else ``N``."""
    sides = {side for shape in images.values() for side in shape[-2:]}
    return str(sides.pop()) if len(sides) == 1 else "N"
