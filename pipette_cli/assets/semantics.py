"""Read an asset's task semantics (``pipette:*`` attributes) without compiling it."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

PREFIX = "pipette:"


def read_semantics(path: Path) -> dict[str, Any]:
    """Return the ``pipette:*`` attributes of the default prim as plain Python values.

    Arrays become lists, ``double3`` become lists of floats. Raises
    :class:`~pipette_cli.errors.AssetError` if the file does not parse. Cached per file and
    modification time; the caller gets its own copy.
    """
    stat = path.stat()
    return {k: (list(v) if isinstance(v, list) else v) for k, v in _read(path, stat.st_mtime_ns, stat.st_size).items()}


@lru_cache(maxsize=512)
def _read(path: Path, mtime_ns: int, size: int) -> dict[str, Any]:
    from pipette_cli.assets.loader import open_stage

    stage = open_stage(path)  # keep the stage alive while its prims are read
    root = stage.GetDefaultPrim()
    out: dict[str, Any] = {"id": root.GetName()}
    for attr in root.GetAttributes():
        name = attr.GetName()
        if not name.startswith(PREFIX):
            continue
        out[name[len(PREFIX) :]] = _plain(attr.Get())
    return out


def _plain(value: Any) -> Any:
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    try:
        return [_plain(v) for v in value]
    except TypeError:
        return str(value)
