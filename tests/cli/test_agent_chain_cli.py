"""Chained requests run end to end from a clean folder on CPU-sized settings (slow: 1-2 min each
on 2 cores): `pipette agent "collect 2 demos ..., then augment them ... and convert the result" --yes`
records real MuJoCo demos, augments them with success verification and writes a LeRobot dataset;
"serve CKPT ..., then evaluate it ..." keeps the policy server running beside the evaluation."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "fixtures" / "policy"))

from pipette_cli.demos.store import scan
from pipette_cli.lerobot.stats import dataset_stats


@pytest.mark.slow
def test_collect_augment_convert_chain_runs_from_one_request(tmp_path: Path) -> None:
    request = "collect 2 demos of PickUpTestTube at 32 px, then augment them with 2 workers and convert the result"
    result = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "agent", request, "--yes"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, "COLUMNS": "200"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    raw = scan(tmp_path / "data" / "PickUpTestTube.h5")
    assert len(raw.episodes) == 2 and raw.info.image_height == 32 and not raw.pending
    augmented = scan(tmp_path / "data" / "PickUpTestTube_augmented.h5")
    kept = len(augmented.episodes)
    assert kept > 0 and all(ref.summary.success for ref in augmented.episodes)
    stats = dataset_stats(tmp_path / "datasets" / "pipette_PickUpTestTube-v1" / "augmented")
    assert stats["episodes"] == kept
    for step in ("step 1/3 pipette collect", "step 2/3 pipette augment", "step 3/3 pipette convert"):
        assert step in result.stderr


@pytest.mark.slow
def test_serve_then_evaluate_keeps_the_server_running_beside_the_evaluation(tmp_path: Path) -> None:
    import json
    import socket

    from tiny_policy import make_tiny_act

    make_tiny_act(tmp_path / "ckpt" / "act", image_size=32)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    request = f"serve ckpt/act on port {port}, then evaluate it on the test tube task for 1 episode with 32 px images"
    result = subprocess.run(
        [sys.executable, "-m", "pipette_cli.cli.main", "agent", request, "--yes"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "COLUMNS": "200"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads((tmp_path / "evals" / "PickUpTestTube" / "summary.json").read_text())
    assert summary["episodes"] == 1 and summary["policy_type"] == "act"
    assert f"serving act from ckpt/act on tcp://127.0.0.1:{port}" in result.stdout
    with socket.socket() as s:  # the server was stopped when the plan ended
        s.bind(("127.0.0.1", port))
