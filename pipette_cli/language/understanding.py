"""What both front-ends say about words they did not understand: one wording, one rule.

A plan with words it does not use is shown with the list of them and is never run or written
without the user looking (``--yes`` refuses it); ``--json`` carries the list as ``not_understood``.
"""

from __future__ import annotations


def _quoted(words: list[str]) -> str:
    return ", ".join(repr(w) for w in words)


def not_understood_line(words: list[str], what: str | None = "plan") -> str:
    """``not understood: 'zorbly' (the plan above does not use it)`` (without the parenthesis when
    ``what`` is None); empty without words."""
    if not words:
        return ""
    said = f"not understood: {_quoted(words)}"
    return said if what is None else f"{said} (the {what} above does not use {'it' if len(words) == 1 else 'them'})"


PAST = {"run": "run", "write": "written"}


def refused_under_yes(words: list[str], do: str = "run") -> str:
    """Why ``--yes`` does not ``do`` (``run``, ``write``) a plan with words it does not use."""
    verb = "is" if len(words) == 1 else "are"
    return (
        f"not {PAST[do]}: the request's {_quoted(words)} {verb} not understood; rephrase the request "
        f"(or leave those words out) to {do} it with --yes"
    )
