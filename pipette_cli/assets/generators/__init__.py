"""Parametric asset generators, one module per category, registered by asset id.

A generator is a function returning an :class:`~pipette_cli.assets.model.AssetDef`.
Families (tubes, beakers, racks...) register several ids with different parameters.
Registering an id twice is an error, so two generators can never write the same file.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass

from pipette_cli.assets.model import AssetDef
from pipette_cli.errors import AssetError, suggest
from pipette_cli.plugins import Plugins

Factory = Callable[[], AssetDef]
_MODULES = ("tools", "equipment", "consumables", "instruments")


@dataclass(frozen=True)
class Generator:
    asset_id: str
    category: str
    factory: Factory

    def build(self) -> AssetDef:
        asset = self.factory()
        if asset.asset_id != self.asset_id or asset.category != self.category:
            raise AssetError(f"generator {self.asset_id!r} built {asset.asset_id!r} ({asset.category})")
        return asset


GENERATORS: Plugins[Generator] = Plugins("asset generator", AssetError)


def register(asset_id: str, category: str, factory: Factory) -> None:
    """Register ``factory`` as the generator of ``asset_id``; ids are unique."""
    GENERATORS.add(asset_id, Generator(asset_id, category, factory), source=factory)


def generator(asset_id: str, category: str) -> Callable[[Factory], Factory]:
    """Decorator form of :func:`register`."""

    def wrap(factory: Factory) -> Factory:
        register(asset_id, category, factory)
        return factory

    return wrap


def all_generators() -> dict[str, Generator]:
    """Every registered generator (imports the category modules on first use)."""
    for name in _MODULES:
        importlib.import_module(f"{__name__}.{name}")
    return dict(GENERATORS.items())


def get_generator(asset_id: str) -> Generator:
    gens = all_generators()
    if asset_id not in gens:
        raise AssetError(f"no generator for asset {asset_id!r}; {suggest(asset_id, gens)}")
    return gens[asset_id]
