"""Runtime success evaluators, one module per family, each registered by its spec ``type``.

Importing this package imports every module in it (found with :mod:`pkgutil`), so a new
family is added by dropping a module here that uses
:func:`~pipette_cli.evaluators.base.register`; no list is edited. Third-party families
register from their own package the same way, before :func:`make_evaluator` is called.

Example:
    >>> from pipette_cli.evaluators import make_evaluator
    >>> evaluator = make_evaluator(task.success)      # doctest: +SKIP
    >>> evaluator.reset(world)                         # doctest: +SKIP
    >>> verdict = evaluator.update(world)              # once per control step  # doctest: +SKIP
"""

from __future__ import annotations

import importlib
import pkgutil

from pipette_cli.evaluators.base import (
    Evaluator,
    MechanismState,
    Verdict,
    WorldState,
    make_evaluator,
    register,
    registered_types,
)

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")

__all__ = [
    "Evaluator",
    "MechanismState",
    "Verdict",
    "WorldState",
    "make_evaluator",
    "register",
    "registered_types",
]
