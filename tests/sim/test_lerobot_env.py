"""The LeRobot env plugin: ``--env.type=pipette`` resolves and yields LeRobot-shaped batches."""

from __future__ import annotations

import sys
from pathlib import Path

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
        _, reward, terminated, _truncated, _info = vec.step(np.asarray(obs["agent_pos"], dtype=np.float32))
        assert reward[0] == 0.0 and not terminated[0]
    finally:
        vec.close()


def test_lerobot_eval_runs_a_lerobot_policy_in_a_pipette_task(tmp_path) -> None:
    """``lerobot-eval --env.type=pipette`` end to end with a tiny, untrained ACT policy (no downloads),
    rendered at the policy's image size without being told."""
    import json
    import os
    import subprocess
    import sys

    import torch
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.act.modeling_act import ACTPolicy
    from lerobot.policies.factory import make_pre_post_processors

    size = 32
    inputs = {
        f"observation.images.{c}": PolicyFeature(FeatureType.VISUAL, (3, size, size)) for c in ("top", "main", "wrist")
    }
    inputs["observation.state"] = PolicyFeature(FeatureType.STATE, (8,))
    outputs = {"action": PolicyFeature(FeatureType.ACTION, (8,))}
    config = ACTConfig(
        input_features=inputs,
        output_features=outputs,
        pretrained_backbone_weights=None,
        chunk_size=5,
        n_action_steps=5,
        dim_model=32,
        dim_feedforward=64,
        n_encoder_layers=1,
        n_decoder_layers=1,
        n_heads=2,
        push_to_hub=False,
        device="cpu",
    )
    stats = {
        key: {
            "mean": torch.zeros(f.shape),
            "std": torch.ones(f.shape),
            "min": torch.zeros(f.shape),
            "max": torch.ones(f.shape),
        }
        for key, f in {**inputs, **outputs}.items()
    }
    policy_dir = tmp_path / "policy"
    ACTPolicy(config).save_pretrained(policy_dir)
    for processor in make_pre_post_processors(config, dataset_stats=stats):
        processor.save_pretrained(policy_dir)
    out = tmp_path / "eval"
    cli = os.path.join(os.path.dirname(sys.executable), "lerobot-eval")
    result = subprocess.run(
        [
            cli,
            f"--policy.path={policy_dir}",
            "--env.type=pipette",
            "--env.task=pipette/CloseCentrifugeLid-v1",
            "--eval.n_episodes=1",
            "--eval.batch_size=1",
            "--policy.device=cpu",
            f"--output_dir={out}",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "HF_HUB_OFFLINE": "1"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    # no --env.image_size: the env renders what the policy reads, not the task's 400 px
    assert f"rendering {size}x{size} images, the size the policy in {policy_dir} reads" in result.stderr
    info = json.loads((out / "eval_info.json").read_text())
    overall = info["overall"]
    assert overall["n_episodes"] == 1 and overall["pc_success"] == 0.0  # an untrained policy does not close the lid


def _tiny_act(path, size: int):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "policy"))
    from tiny_policy import make_tiny_act

    return make_tiny_act(path, image_size=size)


def test_the_env_renders_at_the_size_the_policy_reads(tmp_path, monkeypatch) -> None:
    from lerobot.envs.configs import EnvConfig
    from lerobot.utils.import_utils import register_third_party_plugins

    register_third_party_plugins()
    policy = _tiny_act(tmp_path / "policy", 48)
    config_class = EnvConfig.get_choice_class("pipette")
    monkeypatch.setattr(sys, "argv", ["lerobot-eval", "--env.type=pipette"])
    assert config_class(task="CloseCentrifugeLid").image_size == 400  # no policy: the task's cameras
    monkeypatch.setattr(sys, "argv", ["lerobot-eval", f"--policy.path={policy}", "--env.type=pipette"])
    adapted = config_class(task="CloseCentrifugeLid")
    assert adapted.image_size == 48 and adapted.features["pixels/top"].shape == (48, 48, 3)
    assert config_class(task="CloseCentrifugeLid", image_size=48).image_size == 48
    with pytest.raises(SystemExit) as stopped:
        config_class(task="CloseCentrifugeLid", image_size=400)
    assert str(stopped.value) == (
        f"error: the policy in {policy} reads top images of 48x48, but this evaluation renders 400x400 "
        "(set --env.image_size=48)"
    )


def test_lerobot_eval_stops_with_one_line_when_told_another_size(tmp_path) -> None:
    import os
    import subprocess

    policy = _tiny_act(tmp_path / "policy", 32)
    cli = os.path.join(os.path.dirname(sys.executable), "lerobot-eval")
    result = subprocess.run(
        [
            cli,
            f"--policy.path={policy}",
            "--env.type=pipette",
            "--env.task=pipette/CloseCentrifugeLid-v1",
            "--env.image_size=400",
            "--policy.device=cpu",
            f"--output_dir={tmp_path / 'eval'}",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "HF_HUB_OFFLINE": "1"},
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr, result.stderr[-3000:]
    assert result.stderr.strip().splitlines()[-1] == (
        f"error: the policy in {policy} reads top images of 32x32, but this evaluation renders 400x400 "
        "(set --env.image_size=32)"
    )
    assert not (tmp_path / "eval").exists()  # stopped before any episode
