"""The LeRobot env plugin: ``--env.type=pipette`` resolves and yields LeRobot-shaped batches."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.render


def test_lerobot_discovers_the_plugin_and_builds_the_env() -> None:
    from lerobot.envs.configs import EnvConfig
    from lerobot.envs.factory import make_env
    from lerobot.envs.utils import preprocess_observation
    from lerobot.utils.import_utils import register_third_party_plugins

    register_third_party_plugins()  # what lerobot-eval does at start-up
    config = EnvConfig.get_choice_class("pipette")(task="PlaceFlaskOnShaker", image_size=32)
    assert config.gym_id == "pipette/PlaceFlaskOnShaker-v1"
    assert config.features_map["pixels/wrist"] == "observation.images.wrist"
    vec = make_env(config, n_envs=1)["pipette"][0]
    try:
        obs, _ = vec.reset(seed=[0])
        batch = preprocess_observation(obs)
        assert {k: tuple(v.shape) for k, v in batch.items()} == {
            "observation.images.top": (1, 3, 32, 32),
            "observation.images.main": (1, 3, 32, 32),
            "observation.images.wrist": (1, 3, 32, 32),
            "observation.state": (1, 7),  # Piper: 6 joints + gripper
        }
        assert vec.call("task_description")[0].startswith("Put the Erlenmeyer flask")
        assert vec.call("_max_episode_steps")[0] == 20 * 30 + 1
        _, reward, terminated, truncated, info = vec.step(np.asarray(obs["agent_pos"], dtype=np.float32))
        assert reward[0] == 0.0 and not terminated[0]
    finally:
        vec.close()
