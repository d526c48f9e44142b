"""Motorised and latched lids and drawers, worked through their buttons rather than their handles.

* A motorised part (a thermal cycler's heated lid, a plate reader's drawer): the asset drives it
  (an actuator of its own) from a ``<part>_button``, so a drafted task opens and closes it by
  pressing that button, through an ``instrument`` mechanism with a toggle motor (docs/protocols.md).
* A latched lid (a centrifuge's): the asset has a lid-release ``button``, an actuator on the lid
  and the angle the lid pops open to (``lid_open_angle_deg``). The latch holds it shut, so a
  drafted task opens it by pressing the release (an ``instrument`` motor in ``release`` mode: the
  lid springs to that angle and is let go there), and closes it by pushing it down by hand from
  that angle, where it rests open (and where the arm reaches it, unlike near its limit, past
  upright, behind the hinge).
"""

from __future__ import annotations

from pipette_cli.specs.base import BoundSpec
from pipette_cli.specs.mechanisms import ClosureSpec, InstrumentSpec, MotorSpec
from pipette_cli.taskgen.measure import AssetGeometry, JointInfo

OPEN_SHARE = 0.95
"""The motor opens the part to this share of its joint's open limit."""


def motor_button(geom: AssetGeometry, joint: JointInfo) -> str | None:
    """The button that drives ``joint`` when the asset motorises it (an actuator named for the part
    and a ``<part>_button`` site, e.g. a thermal cycler's ``lid_button``), else ``None``."""
    part = joint.name.split("_")[0]
    if f"{part}_button" in geom.sites and any(a.startswith(part) for a in geom.semantics.get("actuators", [])):
        return f"{part}_button"
    return None


def release_angle(geom: AssetGeometry, joint: JointInfo) -> float | None:
    """The angle a latched lid pops open to when its release ``button`` is pressed (its
    ``lid_open_angle_deg``), or ``None`` when ``joint`` is not such a lid."""
    if (
        joint.name != "lid_hinge"
        or "button" not in geom.sites
        or "lid_open_angle_deg" not in geom.semantics
        or not any(a.startswith("lid") for a in geom.semantics.get("actuators", []))
    ):
        return None
    return float(geom.semantics["lid_open_angle_deg"])


SHUT_TOLERANCE = {"hinge": 5.0, "slide": 0.01}
"""How far from 0 (degrees, metres) a lid, door or drawer still counts as shut."""


def shut_bound(joint: JointInfo) -> BoundSpec:
    """Where a lid, door or drawer counts as shut (a close stage's criterion, an instrument's
    closure): within :data:`SHUT_TOLERANCE` of 0, on its opening side."""
    tol = SHUT_TOLERANCE[joint.kind]
    return BoundSpec(max=tol) if joint.open_limit > 0 else BoundSpec(min=-tol)


def motorised(name: str, joint: JointInfo, button: str, release: float | None = None) -> InstrumentSpec:
    """The instrument mechanism of object ``name``: closed while ``joint`` is shut, and each press of
    ``button`` drives the part to the other end; with ``release`` (an angle), a press while shut
    pops the lid open to it and lets it go (it is closed by hand, and the latch then holds it)."""
    motor = (
        MotorSpec(button=f"{name}/{button}", mode="release", open=release, shut=0.0)
        if release is not None
        else MotorSpec(button=f"{name}/{button}", mode="toggle", open=round(OPEN_SHARE * joint.open_limit, 3), shut=0.0)
    )
    return InstrumentSpec(
        name=name, closure=ClosureSpec(joint=f"{name}/{joint.name}", closed=shut_bound(joint)), motor=motor
    )
