"""Authoring backends: the offline parser, or an LLM server of the one registry
(:data:`pipette_cli.llm.SERVER_KINDS`, shared with ``pipette agent``).

``offline`` (default) parses descriptions deterministically; every LLM server kind (``openai``:
any OpenAI-compatible chat-completions server; ``ollama``) goes through :class:`ChatBackend`.
A new server kind is registered once, in :mod:`pipette_cli.llm.client`, and every front-end
offers it.
"""

from __future__ import annotations

from pipette_cli.authoring.backends.base import AuthoringBackend, ChatBackend
from pipette_cli.llm import OFFLINE, backend_names, check_backend


def make_backend(name: str, **options: object) -> AuthoringBackend:
    """The backend ``name`` configured with ``options`` (None values are left to the environment).

    Raises:
        BackendError: unknown backend, with the known ones.
    """
    if check_backend(name) == OFFLINE:
        from pipette_cli.authoring.backends.offline import OfflineBackend  # deferred: the parser and vocabulary

        return OfflineBackend()
    return ChatBackend(name, **{k: v for k, v in options.items() if v is not None})  # type: ignore[arg-type]


__all__ = ["AuthoringBackend", "backend_names", "make_backend"]
