"""``pipette serve``: loads a saved LeRobot policy, serves it on loopback, refuses what it should."""

from __future__ import annotations

import json
import socket
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "policy"))

from tiny_policy import make_tiny_act, observation

pytestmark = pytest.mark.timeout(60)


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_serve_answers_a_client_then_stops_after_max_requests(run_cli, tmp_path) -> None:
    from pipette_cli.serving.client import PolicyClient, PolicyRequestError

    policy = make_tiny_act(tmp_path / "act", image_size=24)
    endpoint = f"tcp://127.0.0.1:{_free_port()}"
    answers: dict[str, object] = {}

    def client() -> None:
        with PolicyClient(endpoint, timeout_ms=30_000) as c:
            answers["info"] = c.info()
            answers["action"] = c.act(observation(image_size=24), task="close the lid", reset=True)
            try:
                c.act(observation(image_size=32))
            except PolicyRequestError as exc:
                answers["error"] = exc.type

    thread = threading.Thread(target=client, daemon=True)
    thread.start()
    result = run_cli(
        "serve", "--policy", policy, "--bind", endpoint, "--device", "cpu", "--max-requests", "3", "--json"
    )
    thread.join(10)
    assert result.exit_code == 0, result.stderr
    decoder, text, docs = json.JSONDecoder(), result.stdout.strip(), []
    while text:  # stdout is nothing but the two JSON documents
        doc, end = decoder.raw_decode(text)
        docs.append(doc)
        text = text[end:].strip()
    ready, stopped = docs
    assert ready["event"] == "ready" and ready["endpoint"] == endpoint and ready["policy"]["policy_type"] == "act"
    assert stopped == {
        "event": "stopped",
        "requests": 3,
        "actions": 1,
        "errors": 1,
        "mean_inference_ms": stopped["mean_inference_ms"],
    }
    assert answers["info"]["images"]["observation.images.wrist"] == [3, 24, 24]
    assert answers["action"].shape == (8,) and np.isfinite(answers["action"]).all()
    assert answers["error"] == "bad_shape"


def test_serve_takes_a_training_run_folder_as_its_last_checkpoint(run_cli, tmp_path) -> None:
    run = tmp_path / "outputs" / "train" / "act" / "pipette_PickUpTestTube-v1_raw"
    make_tiny_act(run / "checkpoints" / "000005" / "pretrained_model", image_size=16)
    (run / "checkpoints" / "last").symlink_to("000005")
    endpoint = f"tcp://127.0.0.1:{_free_port()}"
    thread = threading.Thread(target=lambda: _info(endpoint), daemon=True)
    thread.start()
    result = run_cli("serve", "--policy", run, "--bind", endpoint, "--device", "cpu", "--max-requests", "1")
    thread.join(10)
    last = run / "checkpoints" / "last" / "pretrained_model"
    assert result.exit_code == 0, result.stderr
    assert f"policy: {last}" in " ".join(result.stderr.split()) and f"serving act from {last}" in result.stdout
    # the folder above holds two runs now: it names them instead of picking one
    make_tiny_act(run.parent / "other_raw" / "checkpoints" / "last" / "pretrained_model", image_size=16)
    result = run_cli("serve", "--policy", run.parent, "--bind", endpoint)
    assert result.exit_code == 1 and "holds 2 training runs; pass one of them" in result.stderr


def _info(endpoint: str) -> None:
    from pipette_cli.serving.client import PolicyClient

    with PolicyClient(endpoint, timeout_ms=30_000) as c:
        c.info()


def test_serve_refuses_a_folder_that_is_not_a_policy(run_cli, tmp_path) -> None:
    result = run_cli("serve", "--policy", tmp_path)
    assert result.exit_code == 1
    assert result.stderr.strip().count("\n") == 0 and "no config.json" in result.stderr


def test_serve_refuses_a_network_address_without_allow_remote(run_cli, tmp_path) -> None:
    result = run_cli("serve", "--policy", tmp_path, "--bind", "tcp://0.0.0.0:5555")
    assert result.exit_code == 1 and "--allow-remote" in result.stderr
    # with the flag the address is accepted and the next problem (no policy) is reported instead
    result = run_cli("serve", "--policy", tmp_path, "--bind", "tcp://0.0.0.0:5555", "--allow-remote")
    assert result.exit_code == 1 and "no config.json" in result.stderr


def test_serve_reports_an_address_in_use(run_cli, tmp_path) -> None:
    policy = make_tiny_act(tmp_path / "act", image_size=16)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        result = run_cli("serve", "--policy", policy, "--bind", f"tcp://127.0.0.1:{taken.getsockname()[1]}")
    assert result.exit_code == 1 and "cannot bind" in result.stderr


def test_serve_reports_a_broken_policy_folder_in_one_line(run_cli, tmp_path) -> None:
    policy = make_tiny_act(tmp_path / "act", image_size=16)
    (policy / "model.safetensors").write_bytes(b"not weights")
    result = run_cli("serve", "--policy", policy)
    assert result.exit_code == 1 and "cannot load the policy" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
