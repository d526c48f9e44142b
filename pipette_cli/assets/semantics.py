"""Open an asset's USD stage, and read its task semantics (``pipette:*`` attributes) without
compiling it."""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from typing import Any

from pipette_cli.errors import AssetError

PREFIX = "pipette:"


def open_stage(path: Path) -> Any:
    """Open a USD stage, turning parse and composition failures into :class:`AssetError`."""
    # deferred: pxr.Usd (~110 ms; every command imports this module through the asset index)
    from pxr import Tf, Usd

    try:
        stage = Usd.Stage.Open(str(path))
    except Tf.ErrorException as exc:
        text = " ".join(str(exc).split())
        located = re.search(r"[^'\s]+:(\d+):(\d+): ([^']*)", text)
        reason = (
            f"line {located.group(1)}, column {located.group(2)}: {located.group(3).strip()}" if located else text[:300]
        )
        raise AssetError(f"{path.name}: cannot parse USD ({reason})") from None
    if stage is None:
        raise AssetError(f"{path.name}: cannot open USD stage")
    if not stage.GetDefaultPrim():
        raise AssetError(f"{path.name}: no defaultPrim; an asset needs one root prim named after its id")
    return stage


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
