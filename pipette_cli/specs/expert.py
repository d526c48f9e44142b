"""Expert programs as data: the ``expert:`` section of a task YAML, one skill step per item.

A program is an ordered list of steps, each selected by its ``skill:`` field::

    expert:
      - {skill: pick, object: tube}
      - {skill: place_on, object: tube, target: balance/pan_center}

Steps name scene objects (``tube``) and the sites and joints of their assets
(``balance/pan_center``, ``centrifuge/lid_hinge``); the registry checks every name against the
scene and the assets, with file:line and did-you-mean. The runtime of each skill lives in
:mod:`pipette_cli.skills`; it reads geometry from the assets' semantics and the robot's facts,
so the same program runs on every robot. Lengths in metres, angles in degrees, times in seconds.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import ConfigDict, Field, model_validator

from pipette_cli.specs.base import Name, PluggableSpec, Ref, Spec, TypeRegistry, Vec3


def part_field(description: str, part: Literal["site", "joint", "any"] = "any", default: Any = ...) -> Any:
    """A reference to a scene object or one of its ``part``s (a site or joint of its asset)."""
    return Field(default, description=description, json_schema_extra={"ref": True, "part": part})


class TargetSpec(Spec):
    """Where something goes: a site or object (``at``), shifted by ``offset``, or a ``point`` in the
    bench frame. ``relative_to_start`` measures ``offset`` from where ``at`` stood at reset."""

    at: Ref | None = part_field("object or object/site", "site", None)
    offset: Vec3 = (0.0, 0.0, 0.0)
    point: Vec3 | None = None
    relative_to_start: bool = False

    @model_validator(mode="after")
    def _one(self) -> TargetSpec:
        if (self.at is None) == (self.point is None):
            raise ValueError("give exactly one of 'at' and 'point'")
        return self

    def refs(self) -> Iterator[tuple[tuple[str | int, ...], str]]:
        if self.at is not None:
            yield ("at",), self.at


Target = Annotated[Ref | TargetSpec, Field(description="object/site, or {at, offset} or {point}")]


class StepSpec(PluggableSpec):
    """Base of every skill step."""

    skill: str
    label: str | None = Field(None, description="a name for this step in reports (default: the skill and its object)")

    def refs(self) -> Iterator[tuple[tuple[str | int, ...], str]]:
        yield from super().refs()
        for name in type(self).model_fields:
            value = getattr(self, name)
            if isinstance(value, TargetSpec):
                for loc, ref in value.refs():
                    yield (name, *loc), ref

    def parts(self) -> Iterator[tuple[tuple[str | int, ...], str, str]]:
        """Yield ``(field path, ref, part kind)`` for refs that name a site or joint."""
        for name, info in type(self).model_fields.items():
            extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
            value = getattr(self, name)
            if extra.get("ref") and isinstance(value, str) and "/" in value:
                yield (name,), value, str(extra.get("part", "any"))
            elif isinstance(value, TargetSpec) and value.at and "/" in value.at:
                yield (name, "at"), value.at, "site"

    def describe(self) -> str:
        """One line naming the step, e.g. ``pick tube`` or ``close_hinge centrifuge/lid_hinge``."""
        if self.label:
            return self.label
        subject = next(
            (getattr(self, f) for f in ("object", "joint", "button") if isinstance(getattr(self, f, None), str)), ""
        )
        return f"{self.skill} {subject}".strip()


SKILLS: TypeRegistry[StepSpec] = TypeRegistry("skill", StepSpec, key="skill")
register_skill = SKILLS.register
if TYPE_CHECKING:  # to a type checker a field is its base spec; pydantic dispatches on the type key
    StepField = StepSpec
else:
    StepField = SKILLS.field_type()


def skill_names() -> list[str]:
    return SKILLS.names()


GraspMode = Literal["auto", "top", "pinch", "side"]


@register_skill
class PickSpec(StepSpec):
    """Grasp ``object`` and lift it. The grasp comes from the object's shape and semantics: an upright
    tube or flask about its axis (at its ``grasp`` site), a lying tool across its body, a dish or plate
    pinched near its rim with the hand pitched down; ``at`` names another site to grasp (a handle, a
    neck)."""

    skill: Literal["pick"] = "pick"
    object: Name = part_field("object to pick up")
    at: Ref | None = part_field("object/site to grasp at (default: the asset's grasp site or shape)", "site", None)
    grasp: GraspMode = "auto"
    height: float | None = Field(None, description="grasp this far above the object's base (overrides the grasp site)")
    lift: float = Field(0.10, ge=0, description="metres to lift after the grasp")
    hold_s: float = Field(0.0, ge=0, description="seconds to hold still after lifting")


@register_skill
class PlaceOnSpec(StepSpec):
    """Carry the held ``object`` to ``target`` and set it down level: its base on the target's surface."""

    skill: Literal["place_on"] = "place_on"
    object: Name = part_field("the held object")
    target: Target = part_field("where the object's base goes", "site")
    release: bool = True
    retreat: float = Field(0.08, ge=0, description="metres to back off after releasing")


@register_skill
class InsertIntoSpec(StepSpec):
    """Insert the held ``object`` into ``target`` (a slot, rack hole, rotor well or holder) along the
    vertical: the object's mating point (its base, or where it hangs from) ends on the target site."""

    skill: Literal["insert_into"] = "insert_into"
    object: Name = part_field("the held object")
    target: Ref = part_field("object/site of the slot, hole or well", "site")
    axis: Literal["auto", "keep"] = Field("auto", description="auto: turn the object's long axis upright first")
    release: bool = True
    retreat: float = Field(0.08, ge=0)


@register_skill
class RemoveFromSpec(StepSpec):
    """Take ``object`` out of ``source`` (an instrument, rack or holder) and set it on a free bench spot
    (``to: bench``), on a target, or keep holding it clear of the source (``to: hold``)."""

    skill: Literal["remove_from"] = "remove_from"
    object: Name = part_field("object to take out")
    source: Name = Field(alias="from", description="the instrument, rack or holder it is in")
    to: Literal["bench", "hold"] | TargetSpec = Field("bench", description="bench, hold, or a target mapping")
    at: Ref | None = part_field("object/site to grasp at", "site", None)
    hold_s: float = Field(1.0, ge=0)

    model_config = ConfigDict(populate_by_name=True)

    def refs(self) -> Iterator[tuple[tuple[str | int, ...], str]]:
        yield from super().refs()
        yield ("from",), self.source


class HingeSpec(StepSpec):
    """Base of the hinge skills."""

    joint: Ref = part_field("object/joint of the hinge", "joint")
    to_deg: float | None = Field(None, description="target angle (default: the asset's open/closed angle)")
    handle: Ref | None = part_field("object/site to grasp or push at (default: the asset's handle)", "site", None)
    hold_s: float = Field(0.5, ge=0)


@register_skill
class OpenHingeSpec(HingeSpec):
    """Open a hinged lid (horizontal axis) or door (vertical axis) by its handle or edge."""

    skill: Literal["open_hinge"] = "open_hinge"


@register_skill
class CloseHingeSpec(HingeSpec):
    """Close a hinged lid or door by pushing it along its arc on the side that shuts it."""

    skill: Literal["close_hinge"] = "close_hinge"


@register_skill
class SlideSpec(StepSpec):
    """Move a sliding part (drawer, sash, sliding lid) along its joint to ``to`` (metres, or open/closed)."""

    skill: Literal["slide"] = "slide"
    joint: Ref = part_field("object/joint of the slide", "joint")
    to: float | Literal["open", "closed"] = "open"
    handle: Ref | None = part_field("object/site to grasp (default: the asset's handle)", "site", None)
    hold_s: float = Field(0.5, ge=0)


@register_skill
class PressSpec(StepSpec):
    """Press a button: approach along its face's normal and push ``depth`` in."""

    skill: Literal["press"] = "press"
    button: Ref = part_field("object/site of the button", "site")
    depth: float = Field(0.003, ge=0, le=0.03, description="metres to push the button in")
    hold_s: float = Field(0.3, ge=0)


@register_skill
class PositionOverSpec(StepSpec):
    """Hold the held tool's ``point`` (its tip) ``height`` above ``target`` for ``hold_s``."""

    skill: Literal["position_over"] = "position_over"
    object: Name = part_field("the held tool")
    point: Ref | None = part_field(
        "object/site of the tool that must be over the target (default: its tip)", "site", None
    )
    target: Target = part_field("what to hold the tool over", "site")
    height: float = Field(0.05, description="metres above the target")
    hold_s: float = Field(1.0, ge=0)


@register_skill
class TiltSpec(StepSpec):
    """Tilt the held object by ``angle_deg`` about a horizontal axis (pouring), hold, and tilt back."""

    skill: Literal["tilt"] = "tilt"
    object: Name = part_field("the held object")
    angle_deg: float = Field(gt=-150, lt=150)
    hold_s: float = Field(1.0, ge=0)
    back: bool = True


@register_skill
class MoveSpec(StepSpec):
    """Move the hand (and what it holds) ``by`` an offset or ``to`` a target, keeping its orientation."""

    skill: Literal["move"] = "move"
    object: Name | None = part_field("the held object whose base goes to the target", "any", None)
    by: Vec3 | None = None
    to: Target | None = part_field("where the hand (or the held object's base) goes", "site", None)
    hold_s: float = Field(0.0, ge=0)

    @model_validator(mode="after")
    def _one(self) -> MoveSpec:
        if (self.by is None) == (self.to is None):
            raise ValueError("give exactly one of 'by' and 'to'")
        return self


@register_skill
class RetreatSpec(StepSpec):
    """Back away: release (if holding), lift ``distance`` and, with ``home``, return to the home pose."""

    skill: Literal["retreat"] = "retreat"
    distance: float = Field(0.10, ge=0)
    home: bool = False
    hold_s: float = Field(0.0, ge=0)


@register_skill
class WaitSpec(StepSpec):
    """Hold still for ``seconds``."""

    skill: Literal["wait"] = "wait"
    seconds: float = Field(gt=0)
