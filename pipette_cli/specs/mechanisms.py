"""Scripted scene mechanisms as data (paper A.6), selected by ``type:``.

Passive mechanics (hinged lids that contact can close, a lift-off lid) are plain physics of
the assets and need no entry here. ``button_release`` is the paper's centrifuge lid release;
``instrument`` declares an instrument's state machine (closed, motorised lid or drawer, runs
started by a button, contents of its wells and shelves, a weighing pan). Runtime code registers
under the same names in :mod:`pipette_cli.sim.mechanisms` and :mod:`pipette_cli.sim.instruments`.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Literal

from pydantic import Field, model_validator

from pipette_cli.specs.base import BoundSpec, Name, Ref, Spec, TypedSpec, TypeRegistry, ref_field


class MechanismSpec(TypedSpec):
    """Base of all mechanisms; ``name`` is what evaluators refer to."""

    name: Name


MECHANISMS: TypeRegistry[MechanismSpec] = TypeRegistry("mechanism", MechanismSpec)
register_mechanism = MECHANISMS.register
if TYPE_CHECKING:  # to a type checker a field is its base spec; pydantic dispatches on the type key
    MechanismField = MechanismSpec
else:
    MechanismField = MECHANISMS.field_type()


@register_mechanism
class ButtonReleaseSpec(MechanismSpec):
    """When the gripper's sensing point enters a sphere around ``button``, the position target
    of ``joint`` moves linearly to ``target_deg`` within ``ramp_s`` (centrifuge lid release)."""

    type: Literal["button_release"] = "button_release"
    button: Ref = ref_field("object/site of the button")
    joint: Ref = ref_field("object/joint driven when the button fires")
    trigger_radius: float = Field(0.02, gt=0, description="metres around the button site")
    target_deg: float = -40.0
    ramp_s: float = Field(2.0, gt=0)
    stiffness: float = Field(200.0, gt=0)
    damping: float = Field(20.0, ge=0)
    max_force: float = Field(1000.0, gt=0)


class ClosureSpec(Spec):
    """When an instrument counts as closed: its lid, door or drawer joint within ``closed``
    (degrees for hinges, metres for slides). Reported as ``report`` (1 closed, 0 open)."""

    joint: Ref = ref_field("object/joint of the lid, door or drawer")
    closed: BoundSpec
    report: Name = "closed"


class MotorSpec(Spec):
    """A button-driven motor on the closure joint (a motorised lid or plate drawer, a lid release).

    ``toggle``: each press drives the joint to the other end (``open`` or ``shut``) over ``ramp_s``
    and holds it there. ``release``: a press while closed drives it to ``open`` and lets go there
    (a centrifuge lid popping open on its strut); it is closed by hand. Presses are ignored while a
    run is on (the lid or drawer is locked), and a running instrument holds it shut.
    """

    button: Ref = ref_field("object/site of the button")
    mode: Literal["toggle", "release"] = "toggle"
    open: float = Field(description="joint position when open (degrees or metres)")
    shut: float = Field(0.0, description="joint position when shut (degrees or metres)")
    ramp_s: float = Field(1.5, gt=0)
    trigger_radius: float = Field(0.02, gt=0, description="metres around the button site")
    stiffness: float = Field(200.0, gt=0)
    damping: float = Field(20.0, ge=0)
    max_force: float = Field(1000.0, gt=0)


class RunSpec(Spec):
    """A start button: a press starts a run of ``seconds`` only while the instrument is closed and
    idle (otherwise it is refused and counted); opening it during a run aborts the run."""

    button: Ref = ref_field("object/site of the start button")
    seconds: float = Field(10.0, gt=0, description="length of a run")
    trigger_radius: float = Field(0.02, gt=0, description="metres around the button site")


class TouchSpec(Spec):
    """A head worked by pressing on it (a vortex mixer's cup in touch mode): it runs while something
    other than the instrument presses it down with at least ``force_n``; a press held ``seconds``
    counts as a completed run. Reports as the start button's run does (``running``, ``run_time_s``,
    ``runs``)."""

    head: Ref = ref_field("object/body pressed on (the cup)")
    force_n: float = Field(1.0, gt=0, description="newtons down on the head that start it")
    seconds: float = Field(2.0, gt=0, description="length of a press that counts as a run")


class ZoneSpec(Spec):
    """A place in an instrument whose contents are reported (a rotor's wells, a shelf, a block).

    An object is in the zone when its origin (assets stand on their origin) lies within ``radius``
    of one of ``sites`` horizontally and between ``below`` under and ``above`` over it. Reported as
    ``name`` (how many objects) and ``name.object`` (1 or 0) for each tracked object.
    """

    name: Name
    sites: list[Ref] = Field(min_length=1, json_schema_extra={"ref": True})
    radius: float = Field(gt=0, description="metres, horizontally")
    above: float = Field(0.03, ge=0)
    below: float = Field(0.01, ge=0)
    objects: list[Name] | None = Field(None, description="objects tracked (default: every free scene object)")


class ScaleSpec(Spec):
    """A weighing pan: the vertical contact force on ``pan``'s bodies over g, low-pass filtered with
    time constant ``filter_s``, minus the tare. Reports ``mass_g``, ``stable`` (reading within
    ``stable_g`` of the unfiltered force) and ``tared`` (tare presses)."""

    pan: Ref = ref_field("object/body of the pan")
    tare_button: Ref | None = ref_field("object/site of the tare button", None)
    trigger_radius: float = Field(0.02, gt=0)
    filter_s: float = Field(0.2, gt=0)
    stable_g: float = Field(0.05, gt=0)


@register_mechanism
class InstrumentSpec(MechanismSpec):
    """An instrument's state machine as data: what closed means, a button-driven motor on the lid,
    door or drawer, a start button that runs it only when closed (or a head that runs while
    pressed), zones whose contents it reports and a weighing pan. Every part is optional; evaluators
    read the reported values (``instrument_state``) and recordings store them per control step."""

    type: Literal["instrument"] = "instrument"
    closure: ClosureSpec | None = None
    motor: MotorSpec | None = None
    run: RunSpec | None = None
    touch: TouchSpec | None = None
    contents: list[ZoneSpec] = []
    scale: ScaleSpec | None = None

    @model_validator(mode="after")
    def _parts(self) -> InstrumentSpec:
        if self.motor is not None and self.closure is None:
            raise ValueError("a motor needs a 'closure' (the joint it drives and when it counts as closed)")
        if not any((self.closure, self.run, self.touch, self.contents, self.scale)):
            raise ValueError("give at least one of 'closure', 'run', 'touch', 'contents', 'scale'")
        if self.run is not None and self.touch is not None:
            raise ValueError("give 'run' (a start button) or 'touch' (a head run by pressing it), not both")
        names = [zone.name for zone in self.contents]
        if len(set(names)) != len(names):
            raise ValueError("zone names in 'contents' must be unique")
        return self

    def refs(self) -> Iterator[tuple[tuple[str | int, ...], str]]:
        yield from super().refs()
        for part in ("closure", "motor", "run", "scale"):
            value = getattr(self, part)
            if value is None:
                continue
            for name, info in type(value).model_fields.items():
                ref = getattr(value, name)
                if info.json_schema_extra and info.json_schema_extra.get("ref") and isinstance(ref, str):
                    yield (part, name), ref
        for i, zone in enumerate(self.contents):
            for k, site in enumerate(zone.sites):
                yield ("contents", i, "sites", k), site
            for k, obj in enumerate(zone.objects or []):
                yield ("contents", i, "objects", k), obj
