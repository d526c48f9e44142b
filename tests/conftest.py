"""Shared test fixtures: offscreen GL, and running the ``pipette`` CLI in-process."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
_shared = Path(__file__).resolve().parents[2] / "shared" / "menagerie"
if "MENAGERIE_ROOT" not in os.environ and _shared.is_dir():
    os.environ["MENAGERIE_ROOT"] = str(_shared)  # offline checkout beside the repo (CI layout)

# CI runs ``.venv/bin/python -m pytest`` without activating the environment, so its scripts
# (lerobot-train, lerobot-eval) are not on PATH there; drop them here too so code that relies on
# PATH fails in every run, not only in CI.
_scripts = str(Path(sys.executable).parent)
os.environ["PATH"] = os.pathsep.join(d for d in os.environ.get("PATH", "").split(os.pathsep) if d != _scripts)

FIXTURES = Path(__file__).parent / "fixtures"


@dataclass
class CliResult:
    exit_code: int
    stdout: str
    stderr: str


@pytest.fixture
def fixtures_dir() -> Path:
    return FIXTURES


@pytest.fixture
def run_cli(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch):
    """Run ``pipette ARGS...`` in this process; returns exit code, stdout and stderr."""
    from pipette_cli.cli.main import run

    def invoke(*args: str) -> CliResult:
        monkeypatch.setattr(sys, "argv", ["pipette", *map(str, args)])
        capsys.readouterr()
        code = 0
        try:
            run()
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        out, err = capsys.readouterr()
        return CliResult(code, out, err)

    return invoke
