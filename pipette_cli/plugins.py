"""One registry type for every pluggable kind (evaluators, skills, mechanisms, asset generators,
program derivers, LLM backends, ...): things registered by name.

A name registered twice is an error that names both definitions; an unknown name is answered
with the closest known names.

Example:
    EVALUATORS: Plugins[EvaluatorFactory] = Plugins("evaluator", EvaluatorError)

    @EVALUATORS.register("region_hold")
    class RegionHold: ...

    EVALUATORS.get("region_hod")  # EvaluatorError: unknown evaluator 'region_hod'; did you mean 'region_hold'?
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from typing import Any, Generic, TypeVar

from pipette_cli.errors import PipetteError, suggest

T = TypeVar("T")


def where(item: Any) -> str:
    """``file:line`` of a class or function's definition (``module.name`` where no source is known)."""
    target = getattr(item, "func", item)  # functools.partial
    try:
        file = inspect.getsourcefile(target)
        line = inspect.getsourcelines(target)[1]
        return f"{file}:{line}"
    except (TypeError, OSError):
        return f"{getattr(target, '__module__', '?')}.{getattr(target, '__qualname__', type(target).__name__)}"


def _same(a: Any, b: Any) -> bool:
    """The same definition, also when its module was imported a second time."""
    if a is b:
        return True
    qualname_a, qualname_b = getattr(a, "__qualname__", None), getattr(b, "__qualname__", None)
    if qualname_a is None or qualname_b is None or "<lambda>" in qualname_a or "<locals>" in qualname_a:
        return False
    return (getattr(a, "__module__", None), qualname_a) == (getattr(b, "__module__", None), qualname_b)


class Plugins(Generic[T]):
    """Named things of one kind.

    Args:
        kind: What they are, for messages ("evaluator", "skill", ...).
        error: The error raised for a duplicate or unknown name.
    """

    def __init__(self, kind: str, error: type[PipetteError] = PipetteError) -> None:
        self.kind = kind
        self.error = error
        self._items: dict[str, T] = {}
        self._sources: dict[str, Any] = {}

    def add(self, name: str, item: T, *, source: Any = None) -> T:
        """Register ``item`` under ``name``; ``source`` is the class or function whose definition a
        duplicate-name error points at (default: ``item`` itself). Locations are looked up only
        for that error, so registering costs no source reading at import.

        Raises:
            PipetteError: (of the registry's error type) ``name`` is taken by another definition.
        """
        source = item if source is None else source
        if name in self._items and not _same(self._sources[name], source):
            raise self.error(
                f"{self.kind} {name!r} is defined twice: at {where(self._sources[name])} and at {where(source)}"
            )
        self._items[name] = item
        self._sources[name] = source
        return item

    def register(self, *names: str) -> Callable[[T], T]:
        """Decorator: register the decorated class or function under each of ``names``."""

        def decorate(item: T) -> T:
            for name in names:
                self.add(name, item)
            return item

        return decorate

    def get(self, name: str) -> T:
        """The thing registered as ``name``.

        Raises:
            PipetteError: (of the registry's error type) no such name, with the closest known ones.
        """
        try:
            return self._items[name]
        except KeyError:
            raise self.error(f"unknown {self.kind} {name!r}; {suggest(name, self._items)}") from None

    def remove(self, name: str) -> T | None:
        """Unregister ``name`` (a plugin unloaded, a test cleaning up); returns what was there."""
        self._sources.pop(name, None)
        return self._items.pop(name, None)

    def find(self, name: str) -> T | None:
        """The thing registered as ``name``, or None."""
        return self._items.get(name)

    def names(self) -> list[str]:
        return sorted(self._items)

    def items(self) -> Iterator[tuple[str, T]]:
        return iter(sorted(self._items.items()))

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __len__(self) -> int:
        return len(self._items)
