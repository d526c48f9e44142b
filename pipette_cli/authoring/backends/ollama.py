"""Ollama's native chat API (``POST /api/chat`` with ``format`` = the JSON schema).

Configuration (``OLLAMA_HOST``, ``PIPETTE_OLLAMA_MODEL``...): :func:`pipette_cli.llm.make_client`.
"""

from __future__ import annotations

from typing import Any

from pipette_cli.authoring.backends import register_backend
from pipette_cli.authoring.backends.base import ChatBackend


@register_backend("ollama")
def make_ollama(**options: Any) -> ChatBackend:
    return ChatBackend("ollama", **options)
