"""`pipette demo --fast`: the whole pipeline on one task, every stage real (issue 11's CI variant)."""

from __future__ import annotations

import json

import pytest

pytestmark = pytest.mark.render


def test_fast_demo_runs_every_stage(run_cli, tmp_path) -> None:
    out = tmp_path / "demo"
    result = run_cli("demo", "--fast", "--out", out, "--json")
    assert result.exit_code == 0, result.stderr[-3000:]
    report = json.loads(result.stdout)
    assert report["demos"] == 2 and report["demo_successes"] == 2
    assert report["augmented_attempts"] == 4 and 1 <= report["augmented_kept"] <= 4
    assert report["dataset_mb"] > 0 and report["eval_episodes"] == 2 and 0.0 <= report["success_rate"] <= 1.0
    assert (out / "train/act/pipette_PickUpTestTube-v1_augmented/checkpoints/last/pretrained_model/config.json").is_file()
    assert len(list((out / "eval").glob("episode_*.json"))) == 2
    table = run_cli("eval", "report", out / "eval")
    assert table.exit_code == 0, table.stderr
    [row] = [line for line in table.stdout.splitlines() if "PickUpTestTube" in line]
    cells = [c.strip() for c in row.strip("|").split("|")]  # task | policy | raw | augmented
    assert cells[1] == "act" and cells[2] == "-" and cells[3] != "-"  # trained on augmented data: listed so
    assert (out / "augmented_sheet.png").stat().st_size > 0 and (out / "augmented.gif").stat().st_size > 0
    again = run_cli("demo", "--fast", "--out", out)
    assert again.exit_code == 1 and "is not empty" in again.stderr
