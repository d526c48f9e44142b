"""Ollama's native chat API (``POST /api/chat`` with ``format`` = the JSON schema).

Configuration: ``OLLAMA_HOST`` (default ``http://127.0.0.1:11434``), ``PIPETTE_OLLAMA_MODEL``
(default ``qwen2.5:7b-instruct``), ``PIPETTE_LLM_TIMEOUT``, ``PIPETTE_LLM_MAX_ATTEMPTS``.
"""

from __future__ import annotations

import os
from typing import Any

import httpx

from pipette_cli.authoring.backends import register_backend
from pipette_cli.authoring.backends.base import ChatBackend, Retryable, check_status, reply_json


class OllamaBackend(ChatBackend):
    """Ollama chat with structured output."""

    name = "ollama"

    def __init__(self, *, base_url: str | None = None, model: str | None = None, timeout_s: float | None = None,
                 max_attempts: int | None = None, transport: httpx.BaseTransport | None = None, **_: Any) -> None:
        super().__init__(model=model or os.environ.get("PIPETTE_OLLAMA_MODEL") or "qwen2.5:7b-instruct",
                         timeout_s=timeout_s, max_attempts=max_attempts, transport=transport)
        host = base_url or os.environ.get("OLLAMA_HOST") or "http://127.0.0.1:11434"
        self.base_url = (host if host.startswith("http") else f"http://{host}").rstrip("/")

    def send(self, messages: list[dict[str, str]], schema_name: str, schema: dict[str, Any]) -> str:
        body = {"model": self.model, "messages": messages, "stream": False, "format": schema, "options": {"temperature": 0}}
        response = self.client.post(f"{self.base_url}/api/chat", json=body)
        check_status(response, self.name)
        data = reply_json(response)
        content = (data.get("message") or {}).get("content") if isinstance(data, dict) else None
        if not isinstance(content, str):
            raise Retryable(f"the reply has no message.content: {str(data)[:120]}")
        return content


@register_backend("ollama")
def make_ollama(**options: Any) -> OllamaBackend:
    return OllamaBackend(**options)
