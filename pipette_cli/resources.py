"""Where the data shipped with Pipette lives: the registry, templates and assets.

In a wheel the three top-level folders are packaged under ``pipette_cli/_data``; in a
source checkout (editable install) they are read from the repository root.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

from pipette_cli.errors import PipetteError

DATA_FOLDERS = ("registry", "templates", "assets")


def data_dir(name: str) -> Path:
    """Return the folder of built-in data ``name`` (one of :data:`DATA_FOLDERS`).

    Raises:
        PipetteError: if ``name`` is unknown or the installation lacks the folder.
    """
    if name not in DATA_FOLDERS:
        raise PipetteError(f"unknown data folder {name!r}; expected one of {', '.join(DATA_FOLDERS)}")
    packaged = Path(str(files("pipette_cli") / "_data" / name))
    if packaged.is_dir():
        return packaged
    source = Path(__file__).resolve().parent.parent / name
    if source.is_dir():
        return source
    raise PipetteError(
        f"built-in folder {name!r} is missing from this installation (looked in {packaged} and {source})"
    )


def env_paths(variable: str) -> list[Path]:
    """Split an ``os.pathsep``-separated environment variable into existing-or-not paths."""
    raw = os.environ.get(variable, "")
    return [Path(p).expanduser() for p in raw.split(os.pathsep) if p.strip()]
