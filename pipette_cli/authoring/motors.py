"""Motorised lids and drawers (a thermal cycler's heated lid, a plate reader's drawer): the asset
drives the part (an actuator of its own) from a ``<part>_button``, so a drafted task opens and
closes it by pressing that button, through an ``instrument`` mechanism with a toggle motor
(docs/protocols.md), instead of grasping the handle."""

from __future__ import annotations

from pipette_cli.authoring.measure import AssetGeometry, JointInfo
from pipette_cli.specs.base import BoundSpec
from pipette_cli.specs.mechanisms import ClosureSpec, InstrumentSpec, MotorSpec

OPEN_SHARE = 0.95
"""The motor opens the part to this share of its joint's open limit."""


def motor_button(geom: AssetGeometry, joint: JointInfo) -> str | None:
    """The button that drives ``joint`` when the asset motorises it (an actuator named for the part
    and a ``<part>_button`` site, e.g. a thermal cycler's ``lid_button``), else ``None``."""
    part = joint.name.split("_")[0]
    if f"{part}_button" in geom.sites and any(a.startswith(part) for a in geom.semantics.get("actuators", [])):
        return f"{part}_button"
    return None


SHUT_TOLERANCE = {"hinge": 5.0, "slide": 0.01}
"""How far from 0 (degrees, metres) a lid, door or drawer still counts as shut."""


def shut_bound(joint: JointInfo) -> BoundSpec:
    """Where a lid, door or drawer counts as shut (a close stage's criterion, an instrument's
    closure): within :data:`SHUT_TOLERANCE` of 0, on its opening side."""
    tol = SHUT_TOLERANCE[joint.kind]
    return BoundSpec(max=tol) if joint.open_limit > 0 else BoundSpec(min=-tol)


def motorised(name: str, joint: JointInfo, button: str) -> InstrumentSpec:
    """The instrument mechanism of object ``name``: closed while ``joint`` is shut, and each press of
    ``button`` drives the part to the other end."""
    return InstrumentSpec(
        name=name,
        closure=ClosureSpec(joint=f"{name}/{joint.name}", closed=shut_bound(joint)),
        motor=MotorSpec(
            button=f"{name}/{button}", mode="toggle", open=round(OPEN_SHARE * joint.open_limit, 3), shut=0.0
        ),
    )
