"""The backend protocol and the shared structured-output loop of the LLM backends.

A backend turns a description into a pydantic model (a :class:`TaskDraftSpec` or an
:class:`AssetDraftSpec`) and hands it to ``accept``, which finishes the work (lay out,
render, validate) or raises a :class:`~pipette_cli.errors.PipetteError` with ``problems``.
LLM backends then re-ask with those problems, a bounded number of times; the reply is only
ever parsed as JSON and validated, never executed.
"""

from __future__ import annotations

import json
import logging
import os
import re
import time
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

import httpx
from pydantic import BaseModel, ValidationError

from pipette_cli.authoring.draft import strict_json_schema
from pipette_cli.errors import BackendError, PipetteError

log = logging.getLogger(__name__)

T = TypeVar("T")
M = TypeVar("M", bound=BaseModel)
Accept = Callable[[Any], T]

TIMEOUT_ENV = "PIPETTE_LLM_TIMEOUT"
ATTEMPTS_ENV = "PIPETTE_LLM_MAX_ATTEMPTS"
DEFAULT_TIMEOUT_S = 60.0
DEFAULT_ATTEMPTS = 3


class AuthoringBackend(Protocol):
    """Turns descriptions into validated drafts."""

    name: str

    def complete(self, *, system: str, user: str, schema: type[M], accept: Callable[[M], T]) -> T:
        """Produce a ``schema`` instance for ``user`` (``system`` is the LLM instructions) and
        return ``accept(instance)``; ``accept`` raises PipetteError to reject it."""
        ...

    def parse_task(self, description: str) -> Any | None:
        """A deterministic parse (offline backend) or None (LLM backends use :meth:`complete`)."""
        ...


def problems_of(exc: PipetteError) -> list[str]:
    return list(getattr(exc, "problems", None) or [str(exc)])


def env_float(name: str, default: float) -> float:
    raw = os.environ.get(name)
    try:
        return float(raw) if raw else default
    except ValueError:
        raise BackendError(f"{name}={raw!r} is not a number") from None


def strip_fences(text: str) -> str:
    """Small models wrap JSON in Markdown fences; take what is inside."""
    m = re.search(r"```(?:json)?\s*(.*?)```", text, flags=re.S)
    return m.group(1).strip() if m else text.strip()


class ChatBackend:
    """Shared loop: send, parse JSON, validate with pydantic, accept; re-ask on failure.

    Subclasses implement :meth:`send` (one HTTP request -> the reply's text content).
    """

    name = "chat"

    def __init__(self, *, model: str, timeout_s: float | None = None, max_attempts: int | None = None,
                 transport: httpx.BaseTransport | None = None) -> None:
        self.model = model
        self.timeout_s = float(timeout_s if timeout_s is not None else env_float(TIMEOUT_ENV, DEFAULT_TIMEOUT_S))
        self.max_attempts = int(max_attempts if max_attempts is not None else env_float(ATTEMPTS_ENV, DEFAULT_ATTEMPTS))
        if self.max_attempts < 1 or self.timeout_s <= 0:
            raise BackendError("the LLM timeout must be > 0 s and the attempts >= 1")
        self.client = httpx.Client(timeout=httpx.Timeout(self.timeout_s), transport=transport)
        self.attempts_used = 0

    def parse_task(self, description: str) -> None:
        return None

    def send(self, messages: list[dict[str, str]], schema_name: str, schema: dict[str, Any]) -> str:
        raise NotImplementedError

    def complete(self, *, system: str, user: str, schema: type[M], accept: Callable[[M], T]) -> T:
        messages = [{"role": "system", "content": system}, {"role": "user", "content": user}]
        json_schema = strict_json_schema(schema)  # type: ignore[arg-type]
        last: list[str] = []
        for attempt in range(1, self.max_attempts + 1):
            self.attempts_used = attempt
            try:
                content = self.send(messages, schema.__name__, json_schema)
            except httpx.TimeoutException:
                last = [f"attempt {attempt}: no answer within {self.timeout_s:g} s (timeout)"]
                log.warning("%s backend: %s", self.name, last[0])
                continue
            except httpx.TransportError as exc:
                last = [f"attempt {attempt}: cannot reach the server: {exc}"]
                log.warning("%s backend: %s", self.name, last[0])
                time.sleep(min(0.2 * attempt, 1.0))
                continue
            except _Retryable as exc:
                last = [f"attempt {attempt}: {exc}"]
                log.warning("%s backend: %s", self.name, last[0])
                continue
            try:
                data = json.loads(strip_fences(content))
            except json.JSONDecodeError as exc:
                last = [f"attempt {attempt}: the reply is not valid JSON ({exc.msg} at character {exc.pos})"]
                messages += [{"role": "assistant", "content": content[:4000]},
                             {"role": "user", "content": "Your reply was not valid JSON: "
                              f"{exc.msg} at character {exc.pos}. Reply with one JSON object matching the schema, nothing else."}]
                continue
            try:
                instance = schema.model_validate(data)
            except ValidationError as exc:
                errors = [f"{'.'.join(map(str, e['loc'])) or '<top>'}: {e['msg']}" for e in exc.errors(include_url=False)]
                last = [f"attempt {attempt}: the reply does not match the schema: {'; '.join(errors[:8])}"]
                messages += [{"role": "assistant", "content": content[:4000]},
                             {"role": "user", "content": "Your JSON does not match the schema:\n- " + "\n- ".join(errors[:12])
                              + "\nFix these fields and reply with the whole corrected JSON object."}]
                continue
            try:
                return accept(instance)
            except PipetteError as exc:
                problems = problems_of(exc)
                last = [f"attempt {attempt}: the draft was rejected: {'; '.join(problems[:6])}"]
                messages += [{"role": "assistant", "content": content[:4000]},
                             {"role": "user", "content": "This draft cannot become a task:\n- " + "\n- ".join(problems[:12])
                              + "\nFix it (use only asset ids from the list) and reply with the whole corrected JSON object."}]
                continue
        raise backend_error([f"{self.name} backend ({self.model}): no valid answer after {self.max_attempts} attempt(s)", *last])


def backend_error(lines: list[str]) -> BackendError:
    """A :class:`BackendError` whose ``problems`` the CLI prints one per line."""
    exc = BackendError("; ".join(lines))
    exc.problems = list(lines)  # type: ignore[attr-defined]
    return exc


class _Retryable(Exception):
    """A server answer worth retrying (rate limit, 5xx, malformed envelope)."""


def check_status(response: httpx.Response, name: str) -> None:
    """Raise for HTTP errors: retryable ones (429, 5xx) or a final :class:`BackendError`."""
    if response.status_code == 429 or response.status_code >= 500:
        raise _Retryable(f"server answered HTTP {response.status_code}")
    if response.status_code >= 400:
        body = response.text[:300].replace("\n", " ")
        hint = " (check the API key)" if response.status_code in (401, 403) else " (check the model name and base URL)" if response.status_code == 404 else ""
        raise BackendError(f"{name} backend: HTTP {response.status_code}{hint}: {body}")


def reply_json(response: httpx.Response) -> Any:
    try:
        return response.json()
    except (json.JSONDecodeError, ValueError):
        raise _Retryable(f"the server's reply is not JSON: {response.text[:120]!r}") from None


Retryable = _Retryable
