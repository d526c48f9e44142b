"""Authoring backends behind one protocol, registered by name.

``offline`` (default) parses descriptions deterministically; ``openai`` talks to any
OpenAI-compatible chat-completions server; ``ollama`` to an Ollama server. Adding a backend
is a module in this package that calls :func:`register_backend`; no central list is edited.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable

from pipette_cli.authoring.backends.base import AuthoringBackend
from pipette_cli.errors import BackendError
from pipette_cli.plugins import Plugins

BackendFactory = Callable[..., AuthoringBackend]
BACKENDS: Plugins[BackendFactory] = Plugins("backend", BackendError)


def register_backend(name: str) -> Callable[[BackendFactory], BackendFactory]:
    """Register a factory ``(**options) -> AuthoringBackend`` under ``name``."""
    return BACKENDS.register(name)


def _load() -> None:
    for module in pkgutil.iter_modules(__path__):
        if module.name != "base":
            importlib.import_module(f"{__name__}.{module.name}")


def backend_names() -> list[str]:
    _load()
    return BACKENDS.names()


def make_backend(name: str, **options: object) -> AuthoringBackend:
    """The backend ``name`` configured with ``options`` (None values are left to the environment).

    Raises:
        BackendError: unknown backend, with the known ones.
    """
    _load()
    return BACKENDS.get(name)(**{k: v for k, v in options.items() if v is not None})


__all__ = ["AuthoringBackend", "backend_names", "make_backend", "register_backend"]
