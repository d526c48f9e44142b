"""Scripted scene mechanisms as data (paper A.6), selected by ``type:``.

Passive mechanics (hinged lids that contact can close, a lift-off lid, a balance pan) are
plain physics of the assets and need no entry here. Runtime code registers under the same
names in :mod:`pipette_cli.sim.mechanisms`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from pydantic import Field

from pipette_cli.specs.base import Name, Ref, TypedSpec, TypeRegistry, ref_field


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
