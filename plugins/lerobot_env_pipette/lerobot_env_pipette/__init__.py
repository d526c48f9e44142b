"""LeRobot env plugin for Pipette tasks.

LeRobot imports installed distributions whose name starts with ``lerobot_env_`` (see
``lerobot.utils.import_utils.register_third_party_plugins``); importing this one registers
the ``pipette`` env type, so

    lerobot-eval --policy.path=OUT/pretrained_model --env.type=pipette \\
        --env.task=pipette/PickUpTestTube-v1 --eval.n_episodes=10 --eval.batch_size=1

evaluates a LeRobot policy in a Pipette task. Images are ``observation.images.top|main|wrist``,
the state ``observation.state``, the action joint targets plus the gripper command.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_IMAGES, OBS_STATE

CAMERAS = ("top", "main", "wrist")


@EnvConfig.register_subclass("pipette")
@dataclass
class PipetteEnvConfig(EnvConfig):
    """A Pipette task as a LeRobot environment (policy queried at the vision rate, 10 Hz)."""

    task: str | None = "pipette/PickUpTestTube-v1"
    fps: int = 10
    image_size: int = 400
    render_profile: str = "fast"
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from pipette_cli.registry import load_registry

        spec = load_registry().get(self.task)
        self.task = spec.id
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
