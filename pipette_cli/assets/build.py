"""Generate asset files: run the registered generators and write ``<root>/<category>/<id>.usda``."""

from __future__ import annotations

import logging
from collections.abc import Iterable
from pathlib import Path

from pipette_cli.assets.generators import all_generators, get_generator
from pipette_cli.assets.usd_writer import write_usda

log = logging.getLogger(__name__)


def generate_assets(root: Path, ids: Iterable[str] | None = None) -> list[Path]:
    """Write the assets ``ids`` (all registered ones by default) under ``root``; return the paths."""
    gens = [get_generator(i) for i in ids] if ids is not None else list(all_generators().values())
    written = []
    for gen in gens:
        asset = gen.build()
        path = root / asset.category / f"{asset.asset_id}.usda"
        write_usda(asset, path)
        log.debug("wrote %s", path)
        written.append(path)
    return written
