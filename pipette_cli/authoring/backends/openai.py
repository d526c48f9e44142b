"""OpenAI-compatible chat completions (OpenAI, vLLM, llama.cpp server, LM Studio...) over httpx.

Configuration from the environment (options override): ``PIPETTE_LLM_BASE_URL`` (or
``OPENAI_BASE_URL``; default ``https://api.openai.com/v1``), ``PIPETTE_LLM_MODEL`` (or
``OPENAI_MODEL``; default ``gpt-4o-mini``), ``PIPETTE_LLM_API_KEY`` (or ``OPENAI_API_KEY``;
optional for local servers), ``PIPETTE_LLM_TIMEOUT`` (s), ``PIPETTE_LLM_MAX_ATTEMPTS``.
Structured output: ``response_format = {"type": "json_schema", ...}`` with the pydantic schema.
"""

from __future__ import annotations

import os
from typing import Any

import httpx

from pipette_cli.authoring.backends import register_backend
from pipette_cli.authoring.backends.base import ChatBackend, Retryable, check_status, reply_json


class OpenAIBackend(ChatBackend):
    """Chat completions with JSON-schema structured output."""

    name = "openai"

    def __init__(self, *, base_url: str | None = None, model: str | None = None, api_key: str | None = None,
                 timeout_s: float | None = None, max_attempts: int | None = None,
                 transport: httpx.BaseTransport | None = None) -> None:
        env = os.environ.get
        super().__init__(model=model or env("PIPETTE_LLM_MODEL") or env("OPENAI_MODEL") or "gpt-4o-mini",
                         timeout_s=timeout_s, max_attempts=max_attempts, transport=transport)
        self.base_url = (base_url or env("PIPETTE_LLM_BASE_URL") or env("OPENAI_BASE_URL") or "https://api.openai.com/v1").rstrip("/")
        self.api_key = api_key or env("PIPETTE_LLM_API_KEY") or env("OPENAI_API_KEY")

    def send(self, messages: list[dict[str, str]], schema_name: str, schema: dict[str, Any]) -> str:
        headers = {"Authorization": f"Bearer {self.api_key}"} if self.api_key else {}
        body = {
            "model": self.model,
            "messages": messages,
            "temperature": 0,
            "response_format": {"type": "json_schema", "json_schema": {"name": schema_name, "schema": schema, "strict": True}},
        }
        response = self.client.post(f"{self.base_url}/chat/completions", json=body, headers=headers)
        check_status(response, self.name)
        data = reply_json(response)
        try:
            message = data["choices"][0]["message"]
        except (KeyError, IndexError, TypeError):
            raise Retryable(f"the reply has no choices[0].message: {str(data)[:120]}") from None
        if message.get("refusal"):
            raise Retryable(f"the model refused: {message['refusal'][:200]}")
        content = message.get("content")
        if not isinstance(content, str):
            raise Retryable("the reply's message has no text content")
        return content


@register_backend("openai")
def make_openai(**options: Any) -> OpenAIBackend:
    return OpenAIBackend(**options)
