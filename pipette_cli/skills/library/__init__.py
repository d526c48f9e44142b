"""The built-in skills, one module per family; importing this package registers them all, so
:func:`skill_runtime` (here, not in :mod:`~pipette_cli.skills.runtime`) always sees them."""

import importlib
import pkgutil

from pipette_cli.plugins import where
from pipette_cli.skills.runtime import SKILL_RUNTIMES, Skill
from pipette_cli.specs.expert import SKILLS, StepSpec

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")


def skill_runtime(spec: type[StepSpec]) -> Skill:
    """The runtime of the skill step ``spec``, built-in or registered by a third party."""
    return SKILL_RUNTIMES.get(SKILLS.name_of(spec))


def unmatched_skills() -> list[str]:
    """One line per skill whose spec has no runtime or whose runtime has no spec (none: they match)."""
    specs, runtimes = set(SKILLS.names()), set(SKILL_RUNTIMES.names())
    return [
        f"skill {name!r} has a spec ({where(SKILLS.get(name))}) but no runtime: decorate one with @skill"
        for name in sorted(specs - runtimes)
    ] + [
        f"skill {name!r} has a runtime ({where(SKILL_RUNTIMES.get(name))}) but no registered spec"
        for name in sorted(runtimes - specs)
    ]
