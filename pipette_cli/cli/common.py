"""Shared CLI plumbing: the stderr console, global state, JSON output."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console

err_console = Console(stderr=True, highlight=False)
out_console = Console(highlight=False, soft_wrap=True)


@dataclass
class GlobalState:
    """Options given before the command (``pipette -v --registry-dir D tasks list``)."""

    verbosity: int = 0
    debug: bool = False
    registry_dirs: list[Path] = field(default_factory=list)


STATE = GlobalState()


def print_json(data: Any) -> None:
    """Write ``data`` as JSON to stdout (machine output, no rich markup)."""
    sys.stdout.write(json.dumps(data, indent=2, sort_keys=False, default=str) + "\n")
    sys.stdout.flush()
