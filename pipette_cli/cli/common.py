"""Shared CLI plumbing: the stderr console, global state, JSON output."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel
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


def spec_default(model: type[BaseModel], field: str) -> Any:
    """The default of ``model.field``: CLI options bound to a spec take their default from it, so
    each default lives once."""
    return model.model_fields[field].get_default(call_default_factory=True)


def spec_help(model: type[BaseModel], field: str, text: str = "") -> str:
    """``text`` followed by the field's own description (units, the paper's symbol and section)."""
    description = model.model_fields[field].description or ""
    return f"{text} ({description})" if text and description else text or description
