"""Variants and the augmentation spec: which perturbations are applied together to every demo.

The perturbations themselves (lighting, speed, joint noise, camera pose, object pose, surface
colour) live in :mod:`pipette_cli.specs.perturbations`, shared with evaluation suites; a variant
names them by their ``atom`` (``light+speed``), with the paper's defaults unless overridden.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import Field, ValidationError, model_validator

from pipette_cli.errors import SpecError, suggest
from pipette_cli.specs.base import Spec
from pipette_cli.specs.perturbations import PERTURBATIONS, PerturbationField, PerturbationSpec


class VariantSpec(Spec):
    """One augmented version of every demo: a set of perturbations applied together."""

    name: str = Field(min_length=1)
    perturbations: list[PerturbationField] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique(self) -> VariantSpec:
        kinds = [p.type for p in self.perturbations]
        if len(kinds) != len(set(kinds)):
            raise ValueError(f"variant {self.name!r} lists a perturbation type twice: {kinds}")
        return self

    @property
    def physics(self) -> bool:
        """True when the variant must be re-simulated (otherwise it reuses the original physics)."""
        return any(p.physics for p in self.perturbations)

    def get(self, kind: type[PerturbationSpec]) -> PerturbationSpec | None:
        return next((p for p in self.perturbations if isinstance(p, kind)), None)

    def scaled(self, factor: float) -> VariantSpec:
        return self.model_copy(update={"perturbations": [p.scaled(factor) for p in self.perturbations]})

    def magnitude(self) -> str:
        return ";".join(p.magnitude() for p in self.perturbations) or "-"


class AugmentSpec(Spec):
    """Everything that decides the augmented episodes (stored with the output for resuming)."""

    variants: list[VariantSpec] = Field(min_length=1)
    seed: int = Field(0, description="base seed of the perturbations' random numbers")
    settle_s: float = Field(1.0, ge=0, description="s the last target is held when the actions run out undecided")
    image_size: Annotated[int, Field(ge=0)] = 0
    """Square image side; 0: the input file's."""
    batch: bool = Field(
        False, description="screen physics variants with one mujoco.rollout first (tasks without mechanisms)"
    )

    EXECUTION_ONLY: ClassVar[frozenset[str]] = frozenset({"batch"})
    """Fields that change how the episodes are made, not which: a resumed run may differ in them."""

    @model_validator(mode="after")
    def _names(self) -> AugmentSpec:
        names = [v.name for v in self.variants]
        if len(names) != len(set(names)):
            raise ValueError(f"variant names must be unique: {names}")
        return self


ORIGINAL = "original"
PAPER_GRID = ("light", "speed", "light+speed", "light+cam", "speed+cam", "light+speed+cam")
"""The reference implementation's variant grid."""


def make_variants(names: list[str], atoms: dict[str, PerturbationSpec]) -> list[VariantSpec]:
    """Variants from names such as ``light``, ``speed+noise``, ``paper`` (the grid), ``original``
    or ``object+light*5`` (five variants ``object+light@1`` ... ``@5``, each drawing its own values).

    Args:
        names: Variant names; atoms joined by ``+``.
        atoms: Perturbation per atom name (``light``, ``speed``, ``noise``, ``cam``, ``object``, ``table``).

    Raises:
        SpecError: an unknown atom or a bad ``*N``.
    """
    expanded: list[str] = []
    for name in names:
        base, star, count = name.partition("*")
        if not star:
            expanded.extend(PAPER_GRID if name == "paper" else [name])
        elif count.isdigit() and 1 <= int(count) <= 1000 and base not in (ORIGINAL, "paper"):
            expanded.extend(f"{base}@{k}" for k in range(1, int(count) + 1))
        else:
            raise SpecError(f"--variants: {name!r}: NAME*N repeats a perturbed variant N times (1 <= N <= 1000)")
    variants = []
    for name in dict.fromkeys(expanded):
        if name == ORIGINAL:
            variants.append(VariantSpec(name=ORIGINAL))
            continue
        parts = name.partition("@")[0].split("+")
        unknown = [p for p in parts if p not in atoms]
        if unknown:
            raise SpecError(
                f"--variants: unknown perturbation {unknown[0]!r} in {name!r}; {suggest(unknown[0], [*atoms, 'paper', ORIGINAL])}"
            )
        variants.append(VariantSpec(name=name, perturbations=[atoms[p] for p in parts]))
    return variants


def default_atoms(**overrides: dict[str, object]) -> dict[str, PerturbationSpec]:
    """One perturbation per atom with the paper's defaults, each overridable by a dict of fields.

    Raises:
        SpecError: an impossible parameter, naming the field (``speed.factor: ...``).
    """
    kinds = {cls.atom: cls for cls in map(PERTURBATIONS.get, PERTURBATIONS.names())}
    atoms: dict[str, PerturbationSpec] = {}
    problems = []
    for atom, cls in kinds.items():
        try:
            atoms[atom] = cls(**{k: v for k, v in overrides.get(atom, {}).items() if v is not None})
        except ValidationError as exc:
            for e in exc.errors():
                loc = ".".join(str(x) for x in e["loc"])
                problems.append(f"{cls.__name__} ({atom}).{loc}: {e['msg']} (got {e.get('input')!r})")
    if problems:
        raise SpecError(problems)
    return atoms
