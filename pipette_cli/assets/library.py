"""The asset index: which asset ids exist, where their ``.usda`` lives, and their category.

Assets are files ``<root>/<category>/<asset_id>.usda``. The built-in root ships with the
package; users add roots with ``PIPETTE_ASSET_PATH`` (``os.pathsep``-separated). This
module reads only the folder layout, never USD, so specs can be checked without usd-core.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path

from pipette_cli.assets.semantics import read_semantics
from pipette_cli.errors import AssetError, suggest
from pipette_cli.resources import data_dir, env_paths

ASSET_PATH_ENV = "PIPETTE_ASSET_PATH"
CATEGORIES = ("tools", "equipment", "consumables", "instruments")


@dataclass(frozen=True)
class AssetEntry:
    """One asset found on disk."""

    asset_id: str
    category: str
    path: Path

    def semantics(self) -> dict:
        """The asset's ``pipette:*`` semantics (reads the USD file on demand; needs usd-core)."""
        return read_semantics(self.path)


@dataclass(frozen=True)
class AssetLibrary:
    """All assets under a list of roots; later roots may not redefine an id."""

    entries: dict[str, AssetEntry]

    def ids(self) -> list[str]:
        return sorted(self.entries)

    def __contains__(self, asset_id: object) -> bool:
        return asset_id in self.entries

    def get(self, asset_id: str) -> AssetEntry:
        """Return the entry for ``asset_id`` or raise :class:`AssetError` with suggestions."""
        try:
            return self.entries[asset_id]
        except KeyError:
            raise AssetError(f"unknown asset {asset_id!r}; {suggest(asset_id, self.entries)}") from None


def asset_roots(extra: tuple[Path, ...] = ()) -> list[Path]:
    """Built-in asset root, then ``PIPETTE_ASSET_PATH`` entries, then ``extra``."""
    return [data_dir("assets"), *env_paths(ASSET_PATH_ENV), *extra]


def scan(roots: list[Path]) -> AssetLibrary:
    """Index every ``<category>/<id>.usda`` under ``roots``.

    Raises:
        AssetError: if a root is missing, or two files define the same id.
    """
    entries: dict[str, AssetEntry] = {}
    for root in roots:
        if not root.is_dir():
            raise AssetError(f"asset folder {root} does not exist")
        for path in sorted(root.glob("*/*.usda")):
            category = path.parent.name
            if category not in CATEGORIES:
                continue
            asset_id = path.stem
            if asset_id in entries:
                raise AssetError(f"asset id {asset_id!r} is defined twice: {entries[asset_id].path} and {path}")
            entries[asset_id] = AssetEntry(asset_id, category, path)
    return AssetLibrary(entries)


@cache
def load_asset_library(extra: tuple[Path, ...] = ()) -> AssetLibrary:
    """Scan the standard asset roots (cached per process)."""
    return scan(asset_roots(extra))
