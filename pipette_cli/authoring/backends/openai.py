"""OpenAI-compatible chat completions (OpenAI, vLLM, llama.cpp, llama-cpp-python, LM Studio...).

Configuration and the structured-output form each server accepts: :func:`pipette_cli.llm.make_client`.
"""

from __future__ import annotations

from typing import Any

from pipette_cli.authoring.backends import register_backend
from pipette_cli.authoring.backends.base import ChatBackend


@register_backend("openai")
def make_openai(**options: Any) -> ChatBackend:
    return ChatBackend("openai", **options)
