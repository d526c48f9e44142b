"""A placement relative to another object: "put the tube next to the beaker", "left of the rack",
"behind the balance", "in front of the shaker" (directions as seen from the robot: left is its +y,
behind is farther from its base, +x).

The object is set down on the bench in a region beside the reference: for a direction, a strip on
that side as long as the reference is wide; for "next to", a disc around the reference, on the bench
(not on or in it). The layout keeps a free spot there, and the reference stays where it was put
(no randomised start), so the region is fixed in the bench frame. The criterion is ``released``.
"""

from __future__ import annotations

import numpy as np

from pipette_cli.specs import evaluators as ev
from pipette_cli.specs import expert as sk
from pipette_cli.specs.base import BoundSpec
from pipette_cli.taskgen.measure import r
from pipette_cli.taskgen.plan import PlanStepSpec
from pipette_cli.taskgen.stage_base import Stage, StageBase, reference_point

REACH = 0.12
"""Metres past the reference's side the region extends (the object's own width added)."""
WORDS = {
    "next_to": "next to",
    "left_of": "left of",
    "right_of": "right of",
    "behind": "behind",
    "in_front_of": "in front of",
}


class RelationStages(StageBase):
    """The relation placements of :class:`~pipette_cli.taskgen.stages.StageBuilder`."""

    def _beside(self, step: PlanStepSpec) -> Stage:
        item, ref = step.object, step.required_target()
        relation = step.relation or "next_to"
        igeom, rgeom = self.geom(item), self.geom(ref)
        placed = self.placed[ref]  # it stays put: the scene keeps a free spot beside it (SceneBuilder.beside)
        center = np.asarray(placed.pos[:2]) + 0.5 * (rgeom.low[:2] + rgeom.high[:2])
        r_half = 0.5 * (rgeom.high[:2] - rgeom.low[:2])
        i_half = np.asarray(igeom.half_xy)
        spot, direction = self.scene.out.beside[item]
        ref_point, lift = reference_point(item, igeom)
        z = BoundSpec(min=r(self.bench - 0.01), max=r(self.bench + lift + 0.03))
        human = f"{WORDS[relation]} the {self.human(ref)}"
        if relation == "next_to":
            radius = r(float(np.hypot(*r_half)) + float(max(i_half)) + REACH)
            criterion = ev.RegionHoldSpec(
                object=ref_point,
                within=ev.CircleSpec(center=ref, radius=radius),
                z=z,
                hold_s=self.hold(1.0),
                timeout_s=self.carry_timeout(item, spot),
                released=True,
            )
            comments = {"within": f"VERIFY: {human}: within {radius * 1000:.0f} mm of it, set down on the bench"}
        else:
            axis = 0 if direction[0] else 1
            other = 1 - axis
            sign = direction[axis]
            near = center[axis] + sign * r_half[axis]
            far = near + sign * (2 * i_half[axis] + REACH)
            bounds = {
                "xy"[axis]: BoundSpec(min=r(min(near, far)), max=r(max(near, far))),
                "xy"[other]: BoundSpec(
                    min=r(center[other] - r_half[other] - i_half[other]),
                    max=r(center[other] + r_half[other] + i_half[other]),
                ),
            }
            criterion = ev.RegionHoldSpec(
                object=ref_point,
                **bounds,
                z=z,
                hold_s=self.hold(1.0),
                timeout_s=self.carry_timeout(item, spot),
                released=True,
            )
            comments = {
                "xy"[axis]: f"VERIFY: {human}: beside its side, at most {REACH * 1000:.0f} mm past the object's width"
            }
        comments["z"] = "set down on the bench (not on or in it)"
        tilt = self.th.max_tilt_deg or (15.0 if igeom.semantics.get("upright", True) else None)
        if tilt:
            criterion = criterion.model_copy(update={"max_tilt_deg": tilt})
        target = sk.TargetSpec(point=(r(spot[0]), r(spot[1]), r(self.bench)))
        program = [*self._take(item), sk.PlaceOnSpec(object=item, target=target)]
        self.held_at.pop(item, None)
        return Stage(step, criterion, program, comments, [item, ref])


__all__ = ["RelationStages"]
