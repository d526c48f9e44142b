"""The default backend: a deterministic parser over the asset vocabulary, no network."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from pydantic import BaseModel

from pipette_cli.authoring.parser import ParseResult, parse_description
from pipette_cli.language.assets import load_vocabulary

T = TypeVar("T")
M = TypeVar("M", bound=BaseModel)


class OfflineBackend:
    """Parses; never re-asks (the same text gives the same draft)."""

    name = "offline"

    def parse_task(self, description: str) -> ParseResult:
        return parse_description(description, load_vocabulary())

    def complete(
        self,
        *,
        system: str,
        user: str,
        schema: type[M],
        accept: Callable[[M], T],
        json_schema: dict[str, Any] | None = None,
    ) -> T:
        raise NotImplementedError("the offline backend parses (parse_task / parse_asset); it does not chat")
