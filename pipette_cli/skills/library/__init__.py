"""The built-in skills, one module per family; importing this package registers them all, so
:func:`skill_runtime` (here, not in :mod:`~pipette_cli.skills.runtime`) always sees them."""

import importlib
import pkgutil

from pipette_cli.skills.runtime import SKILL_RUNTIMES, Skill

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")


def skill_runtime(name: str) -> Skill:
    """The runtime of the skill step type ``name``, built-in or registered by a third party."""
    return SKILL_RUNTIMES.get(name)
