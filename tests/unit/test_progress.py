"""Progress for logs: a long stage emits a line every few seconds (stage, done/total, rate, eta)
when its output is not a terminal, and a training run's steps reach it from lerobot-train's log."""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import pytest

from pipette_cli.progress import ProgressLines, duration, progress_interval


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_a_line_every_interval_with_rate_eta_and_note() -> None:
    clock, lines = Clock(), []
    progress = ProgressLines("collect", lines.append, unit="episodes", interval_s=5, clock=clock, heartbeat=False)
    progress.start(20)
    clock.now += 2
    progress.update(advance=1, note="1 ok 0 failed")
    assert lines == []  # not due yet
    clock.now += 3
    progress.update(advance=1, note="2 ok 0 failed")
    assert lines == ["collect: 2/20 episodes (10 %), 5 s elapsed, 0.4 episodes/s, eta 45 s; 2 ok 0 failed"]
    clock.now += 1
    progress.update(advance=1)
    assert len(lines) == 1  # 1 s after the last line
    clock.now += 115
    progress.update(10)
    assert lines[-1] == "collect: 10/20 episodes (50 %), 2m01s elapsed, 4.96 episodes/min, eta 2m01s; 2 ok 0 failed"
    clock.now += 1
    progress.update(advance=1)
    progress.stop()  # the final state, not shown yet
    assert len(lines) == 3 and lines[-1].startswith("collect: 11/20 episodes (55 %), 2m02s elapsed")
    progress.stop()
    assert len(lines) == 3


def test_the_final_state_is_not_repeated() -> None:
    clock, lines = Clock(), []
    progress = ProgressLines("convert", lines.append, unit="episodes", interval_s=0, clock=clock, heartbeat=False)
    progress.start(2)
    progress.update(1)
    progress.update(2)
    progress.stop()
    assert [line.split(",")[0] for line in lines] == ["convert: 1/2 episodes (50 %)", "convert: 2/2 episodes (100 %)"]


def test_a_resumed_stage_rates_only_what_it_did_itself() -> None:
    clock, lines = Clock(), []
    progress = ProgressLines("train", lines.append, unit="steps", interval_s=1, clock=clock, heartbeat=False)
    progress.start(1000, done=None)  # resumed: the first logged step is the baseline
    clock.now += 30
    progress.update(600)
    assert lines == ["train: 600/1000 steps (60 %), 30 s elapsed"]  # no rate from one point
    clock.now += 10
    progress.update(620)
    assert lines[-1] == "train: 620/1000 steps (62 %), 40 s elapsed, 0.5 steps/s, eta 12m40s"


def test_the_heartbeat_emits_while_nothing_advances() -> None:
    lines: list[str] = []
    progress = ProgressLines("train", lines.append, unit="steps", interval_s=0.05)
    progress.start(300)
    deadline = time.monotonic() + 5
    while len(lines) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    progress.stop()
    assert len(lines) >= 3 and all(line.startswith("train: 0/300 steps (0 %), ") for line in lines)
    count = len(lines)
    time.sleep(0.2)
    assert len(lines) == count and not any(t.name.startswith("progress train") for t in threading.enumerate())


def test_interval_and_durations(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PIPETTE_PROGRESS_INTERVAL", "2.5")
    assert progress_interval() == 2.5 and progress_interval(7) == 7
    monkeypatch.setenv("PIPETTE_PROGRESS_INTERVAL", "soon")
    assert progress_interval() == 10.0
    assert [duration(s) for s in (0.4, 59, 61, 3599, 3725)] == ["0 s", "59 s", "1m01s", "59m59s", "1h02m"]


def test_logged_steps_of_lerobot_train() -> None:
    from pipette_cli.lerobot.train import logged_step

    assert logged_step("INFO 2025 ot_train.py:380 step:20 smpl:160 ep:1 epch:0.05 loss:3.206 grdn:80.1") == 20
    assert logged_step("step:2K smpl:16K ep:40 epch:4.88 loss:0.093") == 2000
    assert logged_step("Checkpoint policy after step 300") is None and logged_step("timestep:5") is None


def fake_training(tmp: Path, steps: int, pause_s: float) -> str:
    """A stand-in for lerobot-train that logs a step line every ``pause_s`` seconds."""
    script = tmp / "fake-lerobot-train"
    script.write_text(f"""#!{sys.executable}
import sys, time, pathlib
args = dict(a[2:].split("=", 1) for a in sys.argv[1:] if "=" in a)
print("loading the dataset", flush=True)
for step in range(1, {steps} + 1):
    time.sleep({pause_s})
    print(f"INFO ot_train.py:380 step:{{step}} smpl:{{8 * step}} ep:0 epch:0.01 loss:1.0", flush=True)
ckpt = pathlib.Path(args["output_dir"]) / "checkpoints/last/pretrained_model"
ckpt.mkdir(parents=True)
(ckpt / "config.json").write_text("{{}}")
""")
    script.chmod(0o755)
    return str(script)


def test_pipette_train_without_a_terminal_prints_periodic_progress(
    run_cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pipette_cli.cli.train as train_cli

    monkeypatch.chdir(tmp_path)
    info = Path("datasets/pipette_PickUpTestTube-v1/raw/meta/info.json")
    info.parent.mkdir(parents=True)
    info.write_text("{}")
    monkeypatch.setattr(train_cli, "lerobot_train_executable", lambda: fake_training(tmp_path, 6, 0.15))
    monkeypatch.setenv("PIPETTE_PROGRESS_INTERVAL", "0.2")
    result = run_cli("train", "--tasks", "PickUpTestTube", "--policy", "act", "--steps", "6")
    assert result.exit_code == 0, result.stderr
    progress = [line for line in result.stderr.splitlines() if line.startswith("train pipette/PickUpTestTube-v1: ")]
    assert len(progress) >= 3, result.stderr  # periodic lines while it runs, and the final one
    assert progress[-1].startswith("train pipette/PickUpTestTube-v1: 6/6 steps (100 %), ")
    assert any("steps/s, eta" in line for line in progress[:-1]), progress
