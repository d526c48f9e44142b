"""One root error for Pipette, with a subclass per domain, and the wording its messages share
(did-you-mean, plurals).

The CLI turns any :class:`PipetteError` into a one-line message and its ``exit_code`` (1, or a
kind's own: 3 for an evaluation whose policy server was lost); anything else is a bug and keeps
its traceback.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping


class PipetteError(Exception):
    """Root of every error Pipette raises on purpose.

    Attributes:
        exit_code: The CLI's exit status for it (1; a kind whose run can be resumed may differ).
    """

    exit_code: int = 1


class SpecError(PipetteError):
    """A task spec (YAML or generated) is malformed or inconsistent.

    Attributes:
        problems: One ``file:line: field: message`` string per problem found.
    """

    def __init__(self, problems: list[str] | str) -> None:
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        head = self.problems[0] if self.problems else "invalid spec"
        more = f" (and {len(self.problems) - 1} more)" if len(self.problems) > 1 else ""
        super().__init__(head + more)


class TaskNotFound(PipetteError):
    """A task id is not in the registry."""


class SuiteNotFound(PipetteError):
    """An evaluation suite id is not registered, or a task is not part of the suite."""


class AssetError(PipetteError):
    """An asset is missing, broken, or fails validation."""


class EvaluatorError(PipetteError):
    """A success criterion cannot be built or evaluated."""


class SimError(PipetteError):
    """A scene cannot be built or simulated."""


class InfeasibleTask(SimError):
    """A robot physically cannot do a task (payload, reach, gripper width); the message names the limit."""


class BackendError(PipetteError):
    """An LLM backend failed (network, timeout, invalid answer)."""


class DatasetError(PipetteError):
    """A recorded HDF5 file or a LeRobot dataset is unusable."""


def suggest(name: str, choices: Iterable[str], *, n: int = 3, shown_as: Mapping[str, str] | None = None) -> str:
    """Return a "did you mean" hint for ``name`` among ``choices``, or a list of valid names.

    Args:
        name: The unknown name the user gave.
        choices: The valid names.
        n: How many close matches to offer.
        shown_as: A choice's name as shown (a task's short name -> its id), each shown once.

    Returns:
        A sentence fragment such as ``"did you mean 'a' or 'b'?"``.
    """
    pool = sorted(set(choices))
    close = difflib.get_close_matches(name, pool, n=n, cutoff=0.5)
    if not close:
        lowered = {c.lower(): c for c in pool}
        close = [lowered[c] for c in difflib.get_close_matches(name.lower(), list(lowered), n=n, cutoff=0.4)]
    if close:
        once = dict.fromkeys((shown_as or {}).get(c, c) for c in close)  # one task named two ways: once
        return "did you mean " + " or ".join(repr(c) for c in once) + "?"
    shown = ", ".join(pool[:12]) + (", ..." if len(pool) > 12 else "")
    return f"valid names: {shown}" if pool else "none are defined"


def plural(count: int, noun: str, many: str | None = None) -> str:
    """``count`` and ``noun``, in the plural unless ``count`` is 1: ``1 episode``, ``0 episodes``, ``3 failed episodes``.

    Args:
        count: How many.
        noun: The singular (the last word takes the ``s``).
        many: The plural where it is not ``noun + "s"`` (``"batches"``).
    """
    return f"{count} {noun if count == 1 else many or noun + 's'}"
