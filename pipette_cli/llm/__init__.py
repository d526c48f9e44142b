"""Structured output from LLM servers, shared by ``pipette new-task`` and ``pipette agent``.

:class:`ChatClient` talks to an OpenAI-compatible server (OpenAI, vLLM, llama.cpp's
``llama-server``, llama-cpp-python's server, LM Studio) or to Ollama's native API, and finds
out which structured-output form each server accepts (:mod:`.client`). :func:`ask_structured`
is the loop on top: send, extract the JSON, validate it with pydantic and the caller's check,
and re-ask with the errors a bounded number of times (:mod:`.structured`). Nothing an LLM
answers is ever executed; it is parsed as JSON and validated.
"""

from __future__ import annotations

from pipette_cli.llm.client import (
    FORMS,
    OFFLINE,
    SERVER_KINDS,
    ChatClient,
    FormatRejected,
    Retryable,
    ServerSpec,
    backend_names,
    check_backend,
    forget_formats,
    make_client,
    server_kind,
)
from pipette_cli.llm.structured import ask_structured, backend_error, extract_json, strict_json_schema

__all__ = [
    "FORMS",
    "OFFLINE",
    "SERVER_KINDS",
    "ChatClient",
    "FormatRejected",
    "Retryable",
    "ServerSpec",
    "ask_structured",
    "backend_error",
    "backend_names",
    "check_backend",
    "extract_json",
    "forget_formats",
    "make_client",
    "server_kind",
    "strict_json_schema",
]
