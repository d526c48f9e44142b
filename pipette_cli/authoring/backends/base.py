"""The backend protocol, and the LLM backends' adapter to the shared structured-output loop.

A backend turns a description into a pydantic model (a :class:`TaskPlanSpec` or an
:class:`AssetDraftSpec`) and hands it to ``accept``, which finishes the work (lay out,
render, validate) or raises a :class:`~pipette_cli.errors.PipetteError` with ``problems``.
LLM backends ask through :mod:`pipette_cli.llm` (the server's structured-output form is
negotiated there) and re-ask with those problems a bounded number of times; the reply is
only ever parsed as JSON and validated, never executed.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import httpx
from pydantic import BaseModel

from pipette_cli.llm import ask_structured, make_client

if TYPE_CHECKING:
    from pipette_cli.authoring.parser import ParseResult

T = TypeVar("T")
M = TypeVar("M", bound=BaseModel)


class AuthoringBackend(Protocol):
    """Turns descriptions into validated drafts."""

    name: str

    def complete(
        self,
        *,
        system: str,
        user: str,
        schema: type[M],
        accept: Callable[[M], T],
        json_schema: dict[str, Any] | None = None,
    ) -> T:
        """Produce a ``schema`` instance for ``user`` (``system`` is the LLM instructions) and
        return ``accept(instance)``; ``accept`` raises PipetteError to reject it. ``json_schema``
        is what the server is sent (default: the schema's own, strict)."""
        ...

    def parse_task(self, description: str) -> ParseResult | None:
        """A deterministic parse (offline backend) or None (LLM backends use :meth:`complete`)."""
        ...


class ChatBackend:
    """An LLM server (``kind`` ``openai`` or ``ollama``, see :func:`pipette_cli.llm.make_client`)."""

    def __init__(
        self,
        kind: str,
        *,
        base_url: str | None = None,
        model: str | None = None,
        api_key: str | None = None,
        timeout_s: float | None = None,
        max_attempts: int | None = None,
        transport: httpx.BaseTransport | None = None,
        **_: Any,
    ) -> None:
        self.name = kind
        self.client = make_client(
            kind,
            base_url=base_url,
            model=model,
            api_key=api_key,
            timeout_s=timeout_s,
            max_attempts=max_attempts,
            transport=transport,
        )
        self.model = self.client.spec.model
        self.attempts_used = 0

    def parse_task(self, description: str) -> None:
        return None

    def complete(
        self,
        *,
        system: str,
        user: str,
        schema: type[M],
        accept: Callable[[M], T],
        json_schema: dict[str, Any] | None = None,
    ) -> T:
        trace: list[str] = []
        try:
            return ask_structured(
                self.client,
                system=system,
                user=user,
                schema=schema,
                accept=accept,
                json_schema=json_schema,
                fix_hint="Fix it (use only names from the lists above)",
                trace=trace,
            )
        finally:
            self.attempts_used = len(trace)
