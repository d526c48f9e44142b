"""`pipette train` -> `pipette serve` -> `pipette eval`, offline on CPU: a tiny ACT trained for 2 steps
on a tiny converted dataset through the real `lerobot-train`, its checkpoint served over ZeroMQ
and evaluated for 2 episodes with JSON logs (issue 8)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import h5py
import pytest

from pipette_cli.demos.collect import collect
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert, default_root
from pipette_cli.registry import load_registry

pytestmark = pytest.mark.render
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "demos"
sys.path.insert(0, str(FIXTURES))
import demo_experts  # noqa: E402

TASK = "testlab/HoldTube-v1"
TINY_ACT = [
    "--policy.dim_model=32",
    "--policy.dim_feedforward=64",
    "--policy.n_heads=2",
    "--policy.n_encoder_layers=1",
    "--policy.n_vae_encoder_layers=1",
    "--policy.latent_dim=8",
    "--policy.chunk_size=4",
    "--policy.n_action_steps=4",
    "--num_workers=0",
    "--log_freq=1",
]


def test_tiny_act_trains_offline_and_writes_a_checkpoint(tmp_path: Path, run_cli, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    rec = tmp_path / "rec.h5"
    collect(
        load_registry([FIXTURES / "registry"]).get(TASK),
        rec,
        episodes=1,
        seed=0,
        image_size=32,
        expert_factory=demo_experts.Wiggle,
    )
    with h5py.File(rec, "r+") as f:  # Wiggle never lifts the tube; the verdict is not under test
        f["episodes/episode_000000"].attrs.update(success=True, failed=False, reason="")
    root = default_root(TASK, DatasetVersion.raw)
    convert([rec], ConvertOptions(repo_id="local/testlab_HoldTube-v1_raw", root=root, video=False))

    args = [
        "--registry-dir",
        str(FIXTURES / "registry"),
        "train",
        "--tasks",
        "HoldTube",
        "--policy",
        "act",
        "--steps",
        "2",
        "--batch-size",
        "2",
        "--device",
        "cpu",
        "--offline",
        "--json",
        *(f"--extra={a}" for a in TINY_ACT),
    ]
    result = run_cli(*args)
    run_dir = Path("outputs/train/act/testlab_HoldTube-v1_raw")
    log = Path("outputs/train/act/testlab_HoldTube-v1_raw.log")
    assert result.exit_code == 0, log.read_text()[-3000:] if log.exists() else result.stderr
    [report] = json.loads(result.stdout)
    checkpoint = run_dir / "checkpoints/last/pretrained_model"
    assert report["returncode"] == 0 and Path(report["checkpoint"]) == checkpoint
    config = json.loads((checkpoint / "config.json").read_text())
    assert config["type"] == "act" and config["dim_model"] == 32 and config["pretrained_backbone_weights"] is None
    assert (checkpoint / "model.safetensors").stat().st_size > 0
    train_config = json.loads((checkpoint / "train_config.json").read_text())
    assert train_config["steps"] == 2 and train_config["dataset"]["root"] == str(root)
    text = log.read_text()
    assert "step:2" in text and "End of training" in text  # lerobot-train's own output, tee'd

    again = run_cli(*args)  # default --if-exists skip: nothing runs, the checkpoint is kept
    assert again.exit_code == 0 and json.loads(again.stdout)[0]["action"] == "skip"
    assert log.read_text() == text

    # issue 8's chain: the trained checkpoint is served and evaluated for 2 episodes over ZeroMQ

    from pipette_cli.serving.server import LeRobotRunner, PolicyServer, serving_in_thread

    with serving_in_thread(PolicyServer(LeRobotRunner(checkpoint, device="cpu"), "tcp://127.0.0.1:0")) as server:
        evaluation = run_cli(
            "--registry-dir",
            str(FIXTURES / "registry"),
            "eval",
            "HoldTube",
            "--endpoint",
            server.endpoint,
            "--episodes",
            "2",
            "--image-size",
            "32",
            "--out",
            "evals/act_raw",
            "--json",
        )
    assert evaluation.exit_code == 0, evaluation.stderr
    summary = json.loads(evaluation.stdout)
    assert summary["episodes"] == 2 and summary["task"] == TASK and summary["dataset_version"] == "raw"
    logs = sorted(Path("evals/act_raw").glob("episode_*.json"))
    assert len(logs) == 2
    for path in logs:
        log = json.loads(path.read_text())
        assert log["policy_queries"] >= 5 and log["failed_queries"] == 0 and log["control_steps"] == 15
