"""Success criteria as data: one spec class per evaluator family, selected by ``type:``.

The runtime implementations live in :mod:`pipette_cli.evaluators`; each registers under the
same name. Third-party packages add a family with :func:`register_evaluator` — no central
list is edited. Angles are in degrees, lengths in metres, times in seconds, positions in the
bench frame (origin on the floor under the robot base, z up, bench top at z = 0.55 m).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, model_validator

from pipette_cli.specs.base import BoundSpec, Ref, Spec, TypedSpec, TypeRegistry, ref_field

PositiveS = Annotated[float, Field(gt=0, description="seconds")]
HoldS = Annotated[float, Field(ge=0, description="seconds the condition must hold without interruption")]
TiltDeg = Annotated[float, Field(gt=0, le=180, description="degrees")]


class EvaluatorSpec(TypedSpec):
    """Base of all success criteria."""

    timeout_s: PositiveS | None = Field(None, description="episode fails with reason 'timeout' after this")
    instruction: str | None = Field(
        None, min_length=1, description="as a stage of a sequence: the language instruction for this stage"
    )


EVALUATORS: TypeRegistry[EvaluatorSpec] = TypeRegistry("evaluator", EvaluatorSpec)
register_evaluator = EVALUATORS.register
if TYPE_CHECKING:  # to a type checker a field is its base spec; pydantic dispatches on the type key
    EvaluatorField = EvaluatorSpec
else:
    EvaluatorField = EVALUATORS.field_type()


def evaluator_types() -> list[str]:
    """Names of every registered evaluator family."""
    return EVALUATORS.names()


@register_evaluator
class LiftAndHoldSpec(EvaluatorSpec):
    """Object rises ``min_height_gain`` above its start and stays there ``hold_s``; tilting past
    ``max_tilt_deg`` (angle between its up axis now and at start) fails the episode."""

    type: Literal["lift_and_hold"] = "lift_and_hold"
    object: Ref = ref_field("object to lift")
    min_height_gain: float = Field(gt=0, description="metres above the initial height")
    hold_s: HoldS = 0.5
    max_tilt_deg: TiltDeg | None = None


class CircleSpec(Spec):
    """A horizontal disc around a site; radius given or derived from a part's bounding box.

    ``radius_from_bbox`` takes half the shorter side of that part's xy bounding box, times
    ``radius_scale`` (paper A.8: balance pan, scale 0.5).
    """

    center: Ref = ref_field("site (object/site) at the disc centre")
    radius: float | None = Field(None, gt=0)
    radius_from_bbox: Ref | None = ref_field("part whose bounding box sets the radius", None)
    radius_scale: float = Field(1.0, gt=0)

    @model_validator(mode="after")
    def _one_radius(self) -> CircleSpec:
        if (self.radius is None) == (self.radius_from_bbox is None):
            raise ValueError("give exactly one of 'radius' and 'radius_from_bbox'")
        return self


@register_evaluator
class RegionHoldSpec(EvaluatorSpec):
    """Object's position lies within per-axis bounds (and optionally a disc) for ``hold_s``."""

    type: Literal["region_hold"] = "region_hold"
    object: Ref = ref_field("object whose position is tested")
    x: BoundSpec | None = None
    y: BoundSpec | None = None
    z: BoundSpec | None = None
    within: CircleSpec | None = None
    hold_s: HoldS = 0.5
    max_tilt_deg: TiltDeg | None = None
    released: bool = Field(
        False,
        description="the robot touches the object nowhere while it holds (it was let go: set down, hung, inserted)",
    )

    @model_validator(mode="after")
    def _some_region(self) -> RegionHoldSpec:
        if not any((self.x, self.y, self.z, self.within)):
            raise ValueError("give at least one of 'x', 'y', 'z', 'within'")
        return self

    def refs(self):  # the disc's refs live one level down
        yield from super().refs()
        if self.within is not None:
            yield ("within", "center"), self.within.center
            if self.within.radius_from_bbox:
                yield ("within", "radius_from_bbox"), self.within.radius_from_bbox


@register_evaluator
class StablePlacementSpec(RegionHoldSpec):
    """Region hold that also requires the object to be at rest: |z_t - z_{t-1}| per control step
    at most ``max_dz_per_step`` during the hold (paper A.8, petri dish placement)."""

    type: Literal["stable_placement"] = "stable_placement"  # type: ignore[assignment]
    max_dz_per_step: float = Field(0.002, gt=0)


@register_evaluator
class JointThresholdSpec(EvaluatorSpec):
    """A joint's position lies within ``bound`` for ``hold_s`` (hinges in degrees, slides in metres)."""

    type: Literal["joint_threshold"] = "joint_threshold"
    joint: Ref = ref_field("object/joint")
    bound: BoundSpec
    unit: Literal["deg", "m"] = "deg"
    hold_s: HoldS = 0.25


class AxisDeltaSpec(Spec):
    """Per-axis bounds on an object's displacement from its initial position."""

    x: BoundSpec | None = None
    y: BoundSpec | None = None
    z: BoundSpec | None = None

    @model_validator(mode="after")
    def _some_axis(self) -> AxisDeltaSpec:
        if not any((self.x, self.y, self.z)):
            raise ValueError("give at least one of 'x', 'y', 'z'")
        return self


@register_evaluator
class DisplacementSpec(EvaluatorSpec):
    """Object moved from its start by the given per-axis amounts, held ``hold_s``."""

    type: Literal["displacement"] = "displacement"
    object: Ref = ref_field("object whose displacement is tested")
    delta: AxisDeltaSpec
    hold_s: HoldS = 0.3
    max_tilt_deg: TiltDeg | None = None


@register_evaluator
class NearTargetSpec(EvaluatorSpec):
    """A point on an object comes within ``max_xy_distance`` of a target (horizontal distance)
    while at least ``min_z`` high (paper A.8, pipette positioning). Near but lower ends as
    failure reason ``too_low`` at the timeout."""

    type: Literal["near_target"] = "near_target"
    object: Ref = ref_field("object (or object/site) that must approach")
    target: Ref = ref_field("object or object/site to approach")
    max_xy_distance: float = Field(gt=0)
    min_z: float | None = Field(None, description="height the object must be carried at")
    hold_s: HoldS = 0.0


@register_evaluator
class MechanismTriggeredSpec(EvaluatorSpec):
    """A scene mechanism has fired and the target of the joint it drives is within ``target``
    (paper A.6: centrifuge button, triggered and target angle < -39 deg)."""

    type: Literal["mechanism_triggered"] = "mechanism_triggered"
    mechanism: str = Field(pattern=r"^[a-z][a-z0-9_]*$", description="name of a scene mechanism")
    target: BoundSpec
    unit: Literal["deg", "m"] = "deg"


class CompositeSpec(EvaluatorSpec):
    """Base of evaluators combining others."""

    of: list[EvaluatorField] = Field(min_length=1)


@register_evaluator
class AllOfSpec(CompositeSpec):
    """Succeeds when every child succeeds at the same time; fails when any child fails."""

    type: Literal["all"] = "all"


@register_evaluator
class AnyOfSpec(CompositeSpec):
    """Succeeds when any child succeeds; fails when every child has failed."""

    type: Literal["any"] = "any"


@register_evaluator
class SequenceSpec(CompositeSpec):
    """Children must succeed in order; each starts being checked after the previous one succeeded.
    Each stage may carry its own ``instruction`` (per-stage language, stored per frame)."""

    type: Literal["sequence"] = "sequence"


@register_evaluator
class InstrumentStateSpec(EvaluatorSpec):
    """Values an instrument reports (:class:`~pipette_cli.specs.mechanisms.InstrumentSpec`) lie in
    their bounds all at once for ``hold_s``; e.g. the centrifuge ran at least 2 s with a tube in a
    rotor well and the lid closed: ``{run_time_s: {min: 2}, rotor: {min: 1}, closed: {min: 1}}``."""

    type: Literal["instrument_state"] = "instrument_state"
    mechanism: str = Field(pattern=r"^[a-z][a-z0-9_]*$", description="name of a scene mechanism")
    values: dict[str, BoundSpec] = Field(min_length=1, description="reported value -> bound (flags are 1 or 0)")
    hold_s: HoldS = 0.0
