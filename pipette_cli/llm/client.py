"""One chat request to an LLM server, in the structured-output form that server accepts.

Servers disagree on how to ask for JSON that follows a schema:

* OpenAI, vLLM, LM Studio and llama.cpp's ``llama-server`` take
  ``response_format = {"type": "json_schema", "json_schema": {"name", "schema", "strict"}}``;
* llama-cpp-python's server (``python -m llama_cpp.server``) rejects that (HTTP 500) and takes
  ``{"type": "json_object", "schema": ...}``, which ``llama-server`` accepts too;
* some only know ``{"type": "json_object"}`` (JSON, any shape) or nothing at all;
* Ollama's native ``/api/chat`` takes ``format`` = the schema, or ``"json"``.

:class:`ChatClient` tries the forms of its server kind best first (:data:`FORMS`); an answer
of HTTP 4xx/5xx whose body names the rejected field (``response_format``, ``json_schema``,
``schema``, ``grammar``...) moves on to the next form, and the form that worked is remembered
per base URL for the rest of the process. Each form is tried at most once per request, so a
server that accepts none fails with one clear error. Forms that cannot carry the schema put
it into the system message instead.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, Literal, cast

import httpx

from pipette_cli.errors import BackendError
from pipette_cli.plugins import Plugins

log = logging.getLogger(__name__)

Kind = Literal["openai", "ollama"]
FORMS: dict[str, tuple[str, ...]] = {
    "openai": ("json_schema", "json_object_schema", "json_object", "prompt"),
    "ollama": ("schema", "json", "prompt"),
}
"""Structured-output forms per server kind, best first."""
CARRIES_SCHEMA = frozenset({"json_schema", "json_object_schema", "schema"})
_FORMAT_WORDS = ("response_format", "json_schema", "json_object", "schema", "grammar", "format")
_working: dict[str, str] = {}
"""Base URL -> the form that server accepted (this process)."""

TIMEOUT_ENV = "PIPETTE_LLM_TIMEOUT"
ATTEMPTS_ENV = "PIPETTE_LLM_MAX_ATTEMPTS"
FORMAT_ENV = "PIPETTE_LLM_RESPONSE_FORMAT"


class Retryable(Exception):
    """A server answer worth asking again (rate limit, 5xx, a malformed envelope)."""


class FormatRejected(BackendError):
    """The server refused every structured-output form this client knows."""


@dataclass(frozen=True)
class ServerSpec:
    """Where and how to ask (see :func:`make_client` for the environment defaults)."""

    kind: Kind
    base_url: str
    model: str
    api_key: str | None = None
    timeout_s: float = 60.0
    max_attempts: int = 3
    max_tokens: int = 1024
    response_format: str | None = None
    """Force one form of :data:`FORMS` instead of negotiating."""


ServerAddress = Callable[[str | None, str | None, str | None], tuple[str, str, str | None]]
"""(base URL, model, API key as given) -> (base URL, model, API key), the environment filling gaps."""
SERVER_KINDS: Plugins[ServerAddress] = Plugins("LLM backend", BackendError)
"""The one registry of LLM server kinds; every language front-end (`pipette agent`, `new-task`,
`assets new`) offers ``offline`` and these (:func:`backend_names`)."""


def server_kind(name: str) -> Callable[[ServerAddress], ServerAddress]:
    """Register how a server kind finds its address, model and key (its chat protocol and
    structured-output forms are :data:`FORMS` and :class:`ChatClient`)."""
    return SERVER_KINDS.register(name)


@server_kind("openai")
def _openai(base_url: str | None, model: str | None, api_key: str | None) -> tuple[str, str, str | None]:
    env = os.environ.get
    url = base_url or env("PIPETTE_LLM_BASE_URL") or env("OPENAI_BASE_URL") or "https://api.openai.com/v1"
    name = model or env("PIPETTE_LLM_MODEL") or env("OPENAI_MODEL") or "gpt-4o-mini"
    return url, name, api_key or env("PIPETTE_LLM_API_KEY") or env("OPENAI_API_KEY")


@server_kind("ollama")
def _ollama(base_url: str | None, model: str | None, api_key: str | None) -> tuple[str, str, str | None]:
    host = base_url or os.environ.get("OLLAMA_HOST") or "http://127.0.0.1:11434"
    url = host if host.startswith("http") else f"http://{host}"
    return url, model or os.environ.get("PIPETTE_OLLAMA_MODEL") or "qwen2.5:7b-instruct", api_key


OFFLINE = "offline"
"""The backend every language front-end has without a server: its own deterministic parser."""


def backend_names() -> list[str]:
    """Every backend a language front-end accepts: ``offline``, then the LLM server kinds."""
    return [OFFLINE, *SERVER_KINDS.names()]


def check_backend(name: str) -> str:
    """``name`` if a front-end can use it.

    Raises:
        BackendError: an unknown backend, with every known one.
    """
    if name not in backend_names():
        raise BackendError(f"unknown backend {name!r}; use {', '.join(backend_names())}")
    return name


def _env_number(name: str, default: float) -> float:
    raw = os.environ.get(name)
    try:
        return float(raw) if raw else default
    except ValueError:
        raise BackendError(f"{name}={raw!r} is not a number") from None


def make_client(
    kind: str,
    *,
    base_url: str | None = None,
    model: str | None = None,
    api_key: str | None = None,
    timeout_s: float | None = None,
    max_attempts: int | None = None,
    response_format: str | None = None,
    transport: httpx.BaseTransport | None = None,
) -> ChatClient:
    """A client configured from the arguments, else the environment.

    ``openai``: ``PIPETTE_LLM_BASE_URL`` (or ``OPENAI_BASE_URL``; default ``https://api.openai.com/v1``),
    ``PIPETTE_LLM_MODEL`` (or ``OPENAI_MODEL``; default ``gpt-4o-mini``), ``PIPETTE_LLM_API_KEY`` (or
    ``OPENAI_API_KEY``). ``ollama``: ``OLLAMA_HOST`` (default ``http://127.0.0.1:11434``),
    ``PIPETTE_OLLAMA_MODEL`` (default ``qwen2.5:7b-instruct``). Both: ``PIPETTE_LLM_TIMEOUT`` (s),
    ``PIPETTE_LLM_MAX_ATTEMPTS``, ``PIPETTE_LLM_RESPONSE_FORMAT`` (one of :data:`FORMS`).

    Raises:
        BackendError: an unknown kind or form, or a bad timeout/attempt count.
    """
    env = os.environ.get
    url, name, key = SERVER_KINDS.get(kind)(base_url, model, api_key)
    form = response_format or env(FORMAT_ENV) or None
    if form is not None and form not in FORMS[kind]:
        raise BackendError(f"response format {form!r} is not one of {', '.join(FORMS[kind])} ({kind} servers)")
    spec = ServerSpec(
        cast(Kind, kind),
        url.rstrip("/"),
        name,
        key,  # one of the two, checked above
        timeout_s=float(timeout_s if timeout_s is not None else _env_number(TIMEOUT_ENV, 60.0)),
        max_attempts=int(max_attempts if max_attempts is not None else _env_number(ATTEMPTS_ENV, 3)),
        response_format=form,
    )
    if spec.max_attempts < 1 or spec.timeout_s <= 0:
        raise BackendError("the LLM timeout must be > 0 s and the attempts >= 1")
    return ChatClient(spec, transport=transport)


def forget_formats() -> None:
    """Forget which form each server accepted (tests; a server restarted as another kind)."""
    _working.clear()


def _says_format(response: httpx.Response) -> bool:
    if not (400 <= response.status_code < 600) or response.status_code in (401, 403, 404, 429):
        return False
    body = response.text[:2000].lower()
    return any(word in body for word in _FORMAT_WORDS)


def _check_status(response: httpx.Response, kind: str) -> None:
    """Raise for HTTP errors: retryable ones (429, 5xx) or a final :class:`BackendError`."""
    if response.status_code == 429 or response.status_code >= 500:
        raise Retryable(f"server answered HTTP {response.status_code}")
    if response.status_code >= 400:
        body = response.text[:300].replace("\n", " ")
        hint = {
            401: " (check the API key)",
            403: " (check the API key)",
            404: " (check the model name and base URL)",
        }.get(response.status_code, "")
        raise BackendError(f"{kind} backend: HTTP {response.status_code}{hint}: {body}")


def _reply_json(response: httpx.Response) -> Any:
    try:
        return response.json()
    except (json.JSONDecodeError, ValueError):
        raise Retryable(f"the server's reply is not JSON: {response.text[:120]!r}") from None


class ChatClient:
    """Chat requests to one server; see the module docstring for the form negotiation."""

    def __init__(self, spec: ServerSpec, *, transport: httpx.BaseTransport | None = None) -> None:
        self.spec = spec
        self.http = httpx.Client(timeout=httpx.Timeout(spec.timeout_s), transport=transport)
        self.form_used: str | None = None

    def with_options(self, **changes: Any) -> ChatClient:
        """The same server with other :class:`ServerSpec` fields (shares the HTTP client)."""
        clone = ChatClient.__new__(ChatClient)
        clone.spec, clone.http, clone.form_used = replace(self.spec, **changes), self.http, None
        return clone

    def candidate_forms(self) -> list[str]:
        """The forms to try, the one this server accepted before first."""
        if self.spec.response_format:
            return [self.spec.response_format]
        forms = list(FORMS[self.spec.kind])
        known = _working.get(self.spec.base_url)
        return [known, *(f for f in forms if f != known)] if known in forms else forms

    def chat(self, messages: list[dict[str, str]], *, schema_name: str, schema: dict[str, Any]) -> str:
        """Send ``messages`` asking for JSON following ``schema``; return the reply's text.

        Raises:
            Retryable: a rate limit, a server error or a malformed envelope (ask again).
            FormatRejected: the server refused every structured-output form.
            BackendError: any other HTTP error (authentication, unknown model...).
            httpx.TransportError: the server cannot be reached or did not answer in time.
        """
        refused: list[str] = []
        for form in self.candidate_forms():
            response = self.http.post(
                self._url(), json=self._body(form, messages, schema_name, schema), headers=self._headers()
            )
            if _says_format(response) and form != "prompt":
                refused.append(f"{form} (HTTP {response.status_code}: {response.text[:160].strip()})")
                log.info("%s refused response format %s; trying the next form", self.spec.base_url, form)
                continue
            _check_status(response, self.spec.kind)
            content = self._content(_reply_json(response))
            _working[self.spec.base_url] = self.form_used = form
            return content
        raise FormatRejected(f"{self.spec.base_url} accepted no structured-output form: " + "; ".join(refused))

    def _url(self) -> str:
        return (
            f"{self.spec.base_url}/api/chat" if self.spec.kind == "ollama" else f"{self.spec.base_url}/chat/completions"
        )

    def _headers(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.spec.api_key}"} if self.spec.api_key else {}

    def _body(self, form: str, messages: list[dict[str, str]], name: str, schema: dict[str, Any]) -> dict[str, Any]:
        if form not in CARRIES_SCHEMA:  # the schema goes into the instructions instead
            note = "Reply with one JSON object following this JSON schema, nothing else:\n" + json.dumps(
                schema, separators=(",", ":")
            )
            messages = (
                [{"role": "system", "content": note}, *messages]
                if messages[0]["role"] != "system"
                else [{"role": "system", "content": messages[0]["content"] + "\n\n" + note}, *messages[1:]]
            )
        body: dict[str, Any] = {"model": self.spec.model, "messages": messages}
        if self.spec.kind == "ollama":
            body.update(stream=False, options={"temperature": 0, "num_predict": self.spec.max_tokens})
            if form != "prompt":
                body["format"] = schema if form == "schema" else "json"
            return body
        body.update(temperature=0, max_tokens=self.spec.max_tokens)
        if form == "json_schema":
            strict = _is_strict(schema)
            body["response_format"] = {
                "type": "json_schema",
                "json_schema": {"name": name, "schema": schema, "strict": strict},
            }
        elif form == "json_object_schema":
            body["response_format"] = {"type": "json_object", "schema": schema}
        elif form == "json_object":
            body["response_format"] = {"type": "json_object"}
        return body

    def _content(self, data: Any) -> str:
        if self.spec.kind == "ollama":
            content = (data.get("message") or {}).get("content") if isinstance(data, dict) else None
            if not isinstance(content, str):
                raise Retryable(f"the reply has no message.content: {str(data)[:120]}")
            return content
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


def _is_strict(schema: Any) -> bool:
    """Whether ``schema`` fits OpenAI's strict mode: every object closed, every property required."""
    if isinstance(schema, dict):
        if schema.get("type") == "object" or "properties" in schema:
            if schema.get("additionalProperties") is not False:
                return False
            if set(schema.get("required", [])) != set(schema.get("properties", {})):
                return False
        return all(_is_strict(v) for v in schema.values())
    if isinstance(schema, list):
        return all(_is_strict(v) for v in schema)
    return True
