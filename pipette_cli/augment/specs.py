"""Perturbation and variant specs (pydantic, ``type:``-dispatched) with the paper's defaults.

Each perturbation is a frozen ``*Spec`` registered in :data:`PERTURBATIONS` under its ``type``;
impossible parameters (``s_v <= 0``, a negative radius, ...) fail validation before any work.
``physics`` says whether the perturbation changes what is simulated (speed, joint noise,
object pose) or only what is rendered (lighting, camera pose). ``scaled(f)`` returns the
same perturbation with its magnitude multiplied by ``f`` in ``(0, 1]`` (``--target-yield``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, ClassVar, Literal

from pydantic import Field, ValidationError, model_validator

from pipette_cli.errors import SpecError, suggest
from pipette_cli.specs.base import Spec, TypedSpec, TypeRegistry


class PerturbationSpec(TypedSpec):
    """Base of every perturbation."""

    physics: ClassVar[bool] = False
    atom: ClassVar[str] = ""
    """Short name used in variant names (``light``, ``speed``, ...)."""

    def scaled(self, factor: float) -> PerturbationSpec:
        raise NotImplementedError

    def magnitude(self) -> str:
        """Human-readable magnitude for the yield report."""
        raise NotImplementedError


PERTURBATIONS: TypeRegistry[PerturbationSpec] = TypeRegistry("perturbation", PerturbationSpec)
if TYPE_CHECKING:  # to a type checker a field is its base spec; pydantic dispatches on the type key
    PerturbationField = PerturbationSpec
else:
    PerturbationField = PERTURBATIONS.field_type()


@PERTURBATIONS.register
class LightingSpec(PerturbationSpec):
    """``I' = s_I I`` for every light of the scene (and the headlight)."""

    type: Literal["lighting"] = "lighting"
    atom: ClassVar[str] = "light"
    scale: float = Field(0.8, gt=0, description="s_I, every light's intensity factor; paper A.7")
    headlight: bool = Field(True, description="scale the viewer headlight too")

    def scaled(self, factor: float) -> LightingSpec:
        return self.model_copy(update={"scale": 1.0 + (self.scale - 1.0) * factor})

    def magnitude(self) -> str:
        return f"s_I={self.scale:.3g}"


@PERTURBATIONS.register
class SpeedSpec(PerturbationSpec):
    """Resample the joint targets along ``x_i = x_{i-1} + s_v m_i`` (paper A.7)."""

    type: Literal["speed"] = "speed"
    atom: ClassVar[str] = "speed"
    physics: ClassVar[bool] = True
    factor: float = Field(1.2, gt=0, description="s_v, speed factor of the resampling; paper A.7")
    rho: float = Field(0.10, ge=0, description="rho, strength of the local speed noise; paper A.7")
    window: int = Field(11, ge=1, description="moving-average length smoothing the noise")
    interpolation: Literal["catmull_rom", "linear"] = "catmull_rom"

    def scaled(self, factor: float) -> SpeedSpec:
        return self.model_copy(update={"factor": 1.0 + (self.factor - 1.0) * factor, "rho": self.rho * factor})

    def magnitude(self) -> str:
        return f"s_v={self.factor:.3g},rho={self.rho:.3g}"


@PERTURBATIONS.register
class JointNoiseSpec(PerturbationSpec):
    """``eta ~ N(0, sigma^2)`` clipped to ``+-bound`` rad, added to the arm joint targets."""

    type: Literal["joint_noise"] = "joint_noise"
    atom: ClassVar[str] = "noise"
    physics: ClassVar[bool] = True
    sigma: float = Field(0.005, ge=0, description="rad, std of the joint-target noise; paper A.7")
    bound: float = Field(0.02, ge=0, description="rad, bound of the joint-target noise; paper A.7")

    def scaled(self, factor: float) -> JointNoiseSpec:
        return self.model_copy(update={"sigma": self.sigma * factor, "bound": self.bound * factor})

    def magnitude(self) -> str:
        return f"sigma={self.sigma:.3g},clip={self.bound:.3g}"


@PERTURBATIONS.register
class CameraPoseSpec(PerturbationSpec):
    """Move one camera by ``delta = r U^(1/3) n/|n|`` (uniform in a ball of radius r)."""

    type: Literal["camera_pose"] = "camera_pose"
    atom: ClassVar[str] = "cam"
    camera: Literal["random", "top", "main", "wrist"] = Field(
        "random", description="which camera; random: one per variant"
    )
    radius: float = Field(0.2, ge=0, description="m, for the top and main cameras")
    wrist_radius: float = Field(0.002, ge=0, description="m, for the wrist camera")

    def scaled(self, factor: float) -> CameraPoseSpec:
        return self.model_copy(update={"radius": self.radius * factor, "wrist_radius": self.wrist_radius * factor})

    def magnitude(self) -> str:
        return f"r={self.radius:.3g},r_wrist={self.wrist_radius:.3g}"


@PERTURBATIONS.register
class ObjectPoseSpec(PerturbationSpec):
    """Move the task's target object by up to ``xy`` metres and ``yaw_deg`` and carry the
    demonstration along with it (object-centric transform, as in MimicGen)."""

    type: Literal["object_pose"] = "object_pose"
    atom: ClassVar[str] = "object"
    physics: ClassVar[bool] = True
    object: str | None = Field(None, description="scene object (default: the task's first target)")
    xy: float = Field(0.02, ge=0, description="m, uniform in [-xy, xy] along x and y")
    yaw_deg: float = Field(0.0, ge=0, le=180, description="uniform in [-yaw, yaw] about the vertical")
    ramp_steps: int = Field(15, ge=0, description="control steps over which the offset is blended in")

    def scaled(self, factor: float) -> ObjectPoseSpec:
        return self.model_copy(update={"xy": self.xy * factor, "yaw_deg": self.yaw_deg * factor})

    def magnitude(self) -> str:
        return f"xy={self.xy:.3g},yaw={self.yaw_deg:.3g}"


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
    """Variants from names such as ``light``, ``speed+noise``, ``paper`` (the grid) or ``original``.

    Args:
        names: Variant names; atoms joined by ``+``.
        atoms: Perturbation per atom name (``light``, ``speed``, ``noise``, ``cam``, ``object``).

    Raises:
        SpecError: an unknown atom.
    """
    expanded: list[str] = []
    for name in names:
        expanded.extend(PAPER_GRID if name == "paper" else [name])
    variants = []
    for name in dict.fromkeys(expanded):
        if name == ORIGINAL:
            variants.append(VariantSpec(name=ORIGINAL))
            continue
        parts = name.split("+")
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
    kinds = {
        "light": LightingSpec,
        "speed": SpeedSpec,
        "noise": JointNoiseSpec,
        "cam": CameraPoseSpec,
        "object": ObjectPoseSpec,
    }
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
