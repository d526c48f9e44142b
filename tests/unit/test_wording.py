"""``errors.plural``: the one way a message counts things."""

from __future__ import annotations

import pytest

from pipette_cli.errors import plural


@pytest.mark.parametrize(
    ("count", "noun", "many", "said"),
    [
        (1, "episode", None, "1 episode"),
        (0, "episode", None, "0 episodes"),
        (2, "failed episode", None, "2 failed episodes"),
        (1, "query", "queries", "1 query"),
        (3, "query", "queries", "3 queries"),
    ],
)
def test_plural(count: int, noun: str, many: str | None, said: str) -> None:
    assert plural(count, noun, many) == said
