"""`pipette demo --fast`: the whole pipeline on one task, every stage real (issue 11's CI variant)."""

from __future__ import annotations

import json
from pathlib import Path

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
    assert (
        out / "train/act/pipette_CloseSpectrophotometerLid-v1_augmented/checkpoints/last/pretrained_model/config.json"
    ).is_file()
    assert len(list((out / "eval").glob("episode_*.json"))) == 2
    table = run_cli("eval", "report", out / "eval")
    assert table.exit_code == 0, table.stderr
    [row] = [line for line in table.stdout.splitlines() if "CloseSpectrophotometerLid" in line]
    cells = [c.strip() for c in row.strip("|").split("|")]  # task | policy | raw | augmented
    assert cells[1] == "act" and cells[2] == "-" and cells[3] != "-"  # trained on augmented data: listed so
    assert (out / "augmented_sheet.png").stat().st_size > 0 and (out / "augmented.gif").stat().st_size > 0
    assert report["learned"] is None and "smoke run" in result.stderr  # 2 steps: not judged, and says so
    for stage in ("collect: 2/2 episodes", "augment: 2/2 demos", "train: 2/2 steps", "eval: 2/2 episodes"):
        assert f"{stage} (100 %), " in result.stderr, stage  # no terminal: every stage's progress as lines
    assert (out / "summary.png").stat().st_size > 0 and len(report["videos"]) == 2  # one GIF per evaluation episode
    assert all(Path(p).stat().st_size > 0 for p in [*report["videos"], *report["plots"], report["augmented_video"]])
    logs = [json.loads(p.read_text()) for p in sorted((out / "eval").glob("episode_*.json"))]
    assert [f["episode"] for f in report["failed_episodes"]] == [e["episode"] for e in logs if not e["success"]]
    again = run_cli("demo", "--fast", "--out", out)
    assert again.exit_code == 1 and "is not empty" in again.stderr


def test_a_policy_below_the_success_bar_is_reported_as_a_failure() -> None:
    from pipette_cli.demo import verdict_line

    report = {
        "eval_episodes": 10,
        "eval_successes": 3,
        "learned": False,
        "min_success_rate": 0.5,
        "failures": {"not_closed": 7},
        "train_steps": 300,
    }
    assert "FAILED: only 3/10" in verdict_line(report) and "not_closed" in verdict_line(report)
    assert "works: 8/10" in verdict_line({**report, "eval_successes": 8, "learned": True})
