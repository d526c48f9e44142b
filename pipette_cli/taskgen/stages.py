"""Each plan step becomes a *stage*: a success criterion (a typed evaluator spec) and the skill steps
that satisfy it (typed expert steps), with thresholds read off the assets' geometry and a comment
saying where every derived number comes from.

| step | criterion | skills |
| --- | --- | --- |
| pick | ``lift_and_hold``: half the resting height, 3-8 cm | ``pick`` (``remove_from`` out of an enclosure) |
| place on a surface | ``region_hold`` disc on the site (0.5 x half the surface, the footprint fits), z band, tilt | ``pick`` + ``place_on`` |
| place into a rack | ``region_hold`` over the slot grid, below 40 % of the rack | ``pick`` + ``insert_into`` a free slot |
| place into a slot, rotor, cup | small disc on the site | ``pick`` + ``insert_into`` / ``place_on`` |
| place into a deep bin | disc over the opening, below its rim | ``pick`` + ``move`` over it + ``retreat`` (let go); ``place_on`` its floor for an object taller than the bin is deep |
| remove | ``displacement`` to a free bench spot (and down, off a raised source) | ``remove_from`` to that spot |
| open / close a hinge or slide | ``joint_threshold`` past 75 % open / within 5 deg (1 cm) of shut | ``open_hinge`` / ``close_hinge`` / ``slide`` |
| open a latched lid (a release ``button``) | ``joint_threshold`` past 75 % of the angle it pops to | ``press`` + ``wait`` |
| open / close a lift-off lid | lid lifted 10 cm and drawn back / seated on ``lid_seat`` | ``pick`` + ``move`` / ``place_on`` |
| press | ``mechanism_triggered`` (a ``button_release`` mechanism) | ``press`` + ``wait`` |
| position | ``near_target`` above the target | ``pick`` + ``position_over`` |
| place next to, left of, behind... | ``region_hold`` on the bench beside the other object (:mod:`.relation_stages`) | ``pick`` + ``place_on`` a free spot there |
| run | ``instrument_state``: ran 2 s, shut | ``press`` its start button + ``wait`` |

A placement's criterion is ``released``: it counts once the hand has let go, not while the object is
carried through its region or held where it goes.
"""

from __future__ import annotations

import numpy as np

from pipette_cli.language.assets import load_vocabulary
from pipette_cli.specs import evaluators as ev
from pipette_cli.specs import expert as sk
from pipette_cli.specs.base import BoundSpec
from pipette_cli.specs.mechanisms import ButtonReleaseSpec
from pipette_cli.taskgen.fit import check_hole_fit, fit_radius
from pipette_cli.taskgen.hatch_stages import HatchStages
from pipette_cli.taskgen.layout import Footprint
from pipette_cli.taskgen.measure import AssetGeometry, measure_asset, r, stands_alone
from pipette_cli.taskgen.plan import PlanError, PlanStepSpec
from pipette_cli.taskgen.relation_stages import RelationStages
from pipette_cli.taskgen.resolve import FIT_PLAY, diameter
from pipette_cli.taskgen.scene import FLAT_SITES, hatch_joint, open_value, receiving_site
from pipette_cli.taskgen.stage_base import Stage, reference_point

SLOTS = ("cuvette_slot",)
"""Receptacles an object goes *into* (``insert_into``); the others are surfaces it is set on."""
DEEP = 0.05
"""Metres a container's walls rise above its floor site for objects to be dropped in rather than set down."""


class StageBuilder(HatchStages, RelationStages):
    """Turns the steps of a laid-out plan into stages (see the module docstring)."""

    def build(self, step: PlanStepSpec) -> Stage:
        stage: Stage = getattr(self, f"_{step.action}")(step)
        return stage

    # ------------------------------------------------------------------ pick
    def _pick(self, step: PlanStepSpec) -> Stage:
        name = step.object
        geom = self.geom(name)
        gain = self.th.lift_height_m or r(max(0.03, min(0.08, 0.5 * geom.height)))
        hold = self.hold(0.5)
        upright = geom.semantics.get("upright", True) and geom.height > 1.5 * 2 * max(geom.half_xy)
        tilt = self.th.max_tilt_deg or (35.0 if upright else None)
        criterion = ev.LiftAndHoldSpec(
            object=name, min_height_gain=gain, hold_s=hold, max_tilt_deg=tilt, timeout_s=self.timeout(10)
        )
        comments = {
            "min_height_gain": "from the description"
            if self.th.lift_height_m
            else f"VERIFY: half the object's resting height ({geom.height * 1000:.0f} mm), clipped to 3-8 cm"
        }
        if tilt:
            comments["max_tilt_deg"] = (
                "from the description"
                if self.th.max_tilt_deg
                else "tall upright object: tilting past this fails (paper A.8 uses 35)"
            )
        program = self._take(name, lift=max(0.08, gain + 0.05), hold_s=hold + 0.5)
        if isinstance(program[0], sk.RemoveFromSpec):
            program = [program[0].model_copy(update={"hold_s": hold + 0.5})]
        self.held_at.pop(name, None)
        return Stage(step, criterion, program, comments, [name])

    # ------------------------------------------------------------------ place
    def _place(self, step: PlanStepSpec) -> Stage:
        if step.relation is not None:
            return self._beside(step)
        item, dest = step.object, step.required_target()
        igeom, dgeom = self.geom(item), self.scene.geoms.get(dest) or self.geom(dest)
        site = receiving_site(dgeom, step.part, self.placed[item].asset)
        if site is None or ("lid_seat" in dgeom.sites and site != "lid_seat"):
            raise PlanError(
                f"impossible request: the {self.human(dest)} has no surface, slot or opening to put the "
                f"{self.human(item)} in or on"
            )
        take = self._take(item)
        if site == "slot_grid":
            stage = self._into_rack(step, igeom, dgeom)
        elif site == "rotor_center" and "rotor_wells" in dgeom.semantics:
            stage = self._into_well(step, dgeom)
        elif site in SLOTS:
            stage = self._onto(step, igeom, dgeom, site, insert=True)
        elif site == "opening" or (
            float(dgeom.high[2]) - float(dgeom.sites[site][2]) >= DEEP and site in ("center", "inside_bottom")
        ):
            stage = self._drop_in(step, igeom, dgeom, site)
        else:
            flat = site in FLAT_SITES or (site.startswith("shelf_") and site.endswith("_center"))
            if flat and not stands_alone(self.placed[item].asset):
                raise PlanError(
                    f"impossible request: the {self.human(item)} cannot stand on the {self.human(dest)} by itself "
                    f"(it tips over or rolls away); put it in a rack or holder there, or use one that stands on its own"
                )
            stage = self._onto(step, igeom, dgeom, site, insert=False)
        stage.program = take + stage.program
        self.held_at[item] = (dest, site)
        return stage

    def _fit_radius(self, step: PlanStepSpec, igeom: AssetGeometry, dgeom: AssetGeometry, site: str) -> float:
        """Radius of the disc the item's origin must end in on ``site``; refuses what does not fit."""
        return fit_radius(igeom, dgeom, site, item=self.human(step.object), dest=self.human(step.required_target()))

    def _onto(self, step: PlanStepSpec, igeom: AssetGeometry, dgeom: AssetGeometry, site: str, insert: bool) -> Stage:
        item, dest = step.object, step.required_target()
        radius = self.th.xy_tolerance_m or self._fit_radius(step, igeom, dgeom, site)
        surface = (
            float(dgeom.sites[site][2]) + self.placed[dest].pos[2]
            if not dgeom.free
            else self.placed[dest].pos[2] + float(dgeom.sites[site][2])
        )
        ref, lift = reference_point(item, igeom)
        upright = bool(igeom.semantics.get("upright", True))
        tilt = self.th.max_tilt_deg or (15.0 if upright else None)
        criterion = ev.RegionHoldSpec(
            object=ref,
            within=ev.CircleSpec(center=f"{dest}/{site}", radius=radius),
            z=BoundSpec(min=r(surface - 0.01), max=r(surface + lift + 0.03)),
            max_tilt_deg=tilt,
            hold_s=self.hold(1.0),
            timeout_s=self.carry_timeout(item, self.placed[dest].pos),
            released=True,
        )
        comments = {
            "within": "from the description"
            if self.th.xy_tolerance_m
            else f"VERIFY: at most half of the {site.replace('_', ' ')}'s half-width, and the object's footprint stays on it",
            "z": f"VERIFY: resting on the surface at z = {surface:.3f} m (bench {self.bench:.2f})",
        }
        if ref != item:
            comments["object"] = "a lying object's middle (its grasp site), not its end"
        if tilt:
            comments["max_tilt_deg"] = (
                "from the description" if self.th.max_tilt_deg else "an upright object must arrive upright"
            )
        skill: sk.StepSpec = (
            sk.InsertIntoSpec(object=item, target=f"{dest}/{site}")
            if insert
            else sk.PlaceOnSpec(object=item, target=f"{dest}/{site}")
        )
        return Stage(step, criterion, [skill], comments, [item, dest])

    def _into_well(self, step: PlanStepSpec, dgeom: AssetGeometry) -> Stage:
        """Into a centrifuge's rotor: ``insert_into`` the well nearest the robot; done when it stands
        in any well (its base at a well's floor, leaning or not), not lying across the rotor."""
        item, dest = step.object, step.required_target()
        width = float(dgeom.semantics.get("well_diameter", 0.0))
        d = diameter(load_vocabulary(), self.placed[item].asset)
        if width and d is not None and d + FIT_PLAY > width:
            raise PlanError(
                f"impossible request: the {self.human(item)} ({d * 1000:.0f} mm across) does not fit the "
                f"{self.human(dest)}'s {width * 1000:.0f} mm rotor wells"
            )
        wells = {k: np.asarray(v) for k, v in dgeom.sites.items() if k.startswith("well_")}
        px, py, pz = self.placed[dest].pos
        well = min(wells, key=lambda k: (float(np.hypot(px + wells[k][0], py + wells[k][1])), k))
        floor, center = np.array(list(wells.values())), np.asarray(dgeom.sites["rotor_center"])
        ring = float(np.max(np.hypot(*(floor[:, :2] - center[:2]).T))) + 0.5 * width + 0.005
        z = BoundSpec(min=r(pz + floor[:, 2].min() - 0.01), max=r(pz + floor[:, 2].max() + 0.01))
        comments = {
            "within": "the ring of wells and half a well more, round the rotor (it moves with the instrument)",
            "z": "VERIFY: its base at a rotor well's floor (lying across the rotor it is higher)",
        }
        criterion = ev.RegionHoldSpec(
            object=item,
            within=ev.CircleSpec(center=f"{dest}/rotor_center", radius=r(ring)),
            z=z,
            hold_s=self.hold(1.0),
            timeout_s=self.carry_timeout(item, self.placed[dest].pos),
            released=True,
        )
        return Stage(step, criterion, [sk.InsertIntoSpec(object=item, target=f"{dest}/{well}")], comments, [item, dest])

    def _into_rack(self, step: PlanStepSpec, igeom: AssetGeometry, dgeom: AssetGeometry) -> Stage:
        item, dest = step.object, step.required_target()
        check_hole_fit(
            load_vocabulary(),
            self.placed[item].asset,
            self.placed[dest].asset,
            item=self.human(item),
            dest=self.human(dest),
        )
        slots = np.array([v for k, v in dgeom.sites.items() if k.startswith("slot_")])
        pitch = float(dgeom.semantics.get("pitch", 0.02))
        lo, hi = slots.min(axis=0), slots.max(axis=0)
        px, py, pz = self.placed[dest].pos
        slot_z = float(slots[:, 2].mean())
        height = float(dgeom.high[2])
        slot = self.scene.pick_slot(dest, dgeom)
        comments = {"x": f"VERIFY: the slot grid of {dest} plus half a {pitch * 1000:.0f} mm pitch"}
        hang = igeom.semantics.get("hang_height")
        if slot_z > 0.05:  # hanging holders (pipette stands): the item is off the bench
            x = BoundSpec(min=r(px + dgeom.low[0] - 0.03), max=r(px + dgeom.high[0] + 0.03))
            y = BoundSpec(min=r(py + dgeom.low[1] - 0.03), max=r(py + dgeom.high[1] + 0.03))
            if hang:  # by its collar: where its origin hangs, not lying on the bench nor across the stand's top
                hung = pz + slot_z - float(hang)
                z = BoundSpec(min=r(hung - 0.01), max=r(hung + 0.02))
                comments["z"] = f"VERIFY: hung by its collar, its origin {float(hang) * 1000:.0f} mm below the slot"
            else:
                z = BoundSpec(min=r(pz + igeom.origin_height + 0.025))
                comments["z"] = "VERIFY: hung, its origin is 25 mm above where it lies on the bench"
        else:
            x = BoundSpec(min=r(px + lo[0] - pitch / 2), max=r(px + hi[0] + pitch / 2))
            y = BoundSpec(min=r(py + lo[1] - pitch / 2), max=r(py + hi[1] + pitch / 2))
            z = BoundSpec(min=r(pz + slot_z - 0.01), max=r(pz + slot_z + 0.4 * height + 0.01))
            comments["z"] = (
                f"VERIFY: standing in a slot (floor {slot_z * 1000:.0f} mm), below 40 % of the "
                f"{height * 1000:.0f} mm holder, so lying on top does not count"
            )
        criterion = ev.RegionHoldSpec(
            object=item,
            x=x,
            y=y,
            z=z,
            hold_s=self.hold(1.0),
            timeout_s=self.carry_timeout(item, (px, py)),
            released=True,
        )
        return Stage(step, criterion, [sk.InsertIntoSpec(object=item, target=f"{dest}/{slot}")], comments, [item, dest])

    def _drop_in(self, step: PlanStepSpec, igeom: AssetGeometry, dgeom: AssetGeometry, site: str) -> Stage:
        item, dest = step.object, step.required_target()
        rim = self.placed[dest].pos[2] + float(dgeom.high[2])
        radius = self._fit_radius(step, igeom, dgeom, site if site != "opening" else "opening")
        criterion = ev.RegionHoldSpec(
            object=item,
            within=ev.CircleSpec(center=f"{dest}/{site}", radius=max(radius, 0.01)),
            z=BoundSpec(max=r(rim)),
            hold_s=self.hold(0.5),
            timeout_s=self.carry_timeout(item, self.placed[dest].pos),
            released=True,
        )
        comments = {
            "z": f"inside: below its rim at z = {rim:.3f} m",
            "within": "VERIFY: over the middle of its opening",
        }
        if site != "opening" and float(igeom.height) > float(dgeom.high[2]) - float(dgeom.sites[site][2]):
            # it stands out over the rim on the floor: set down there, held above the rim (a tube
            # stood in an ice bucket), not let fall from over it to topple against a wall
            return Stage(
                step, criterion, [sk.PlaceOnSpec(object=item, target=f"{dest}/{site}")], comments, [item, dest]
            )
        over = max(0.03, float(igeom.height)) + 0.03
        program: list[sk.StepSpec] = [
            sk.MoveSpec(
                object=item,
                to=sk.TargetSpec(
                    at=f"{dest}/{site}",
                    offset=(0.0, 0.0, r(rim - self.placed[dest].pos[2] - float(dgeom.sites[site][2]) + over)),
                ),
            ),
            sk.RetreatSpec(distance=0.08),
        ]
        return Stage(step, criterion, program, comments, [item, dest])

    # ------------------------------------------------------------------ remove
    def _remove(self, step: PlanStepSpec) -> Stage:
        item = step.object
        source = step.source or (self.held_at.get(item) or (None, None))[0]
        if source is None:
            raise PlanError(f"say where the {self.human(item)} is taken from")
        igeom, sgeom = self.geom(item), self.geom(source)
        start = np.asarray(self.placed[item].pos)
        spos = self.placed[source].pos
        hx, hy = sgeom.half_xy
        d = r(max(hx, hy) + max(igeom.half_xy) + 0.03)
        spot = self.scene.layout.place(
            _footprint(igeom, (self.ws.center_x - 0.1, float(start[1]))), self.bench, away=((spos[0], spos[1]), d)
        )
        if spot is None:
            raise PlanError(
                f"impossible layout: no free spot on the bench within reach to set the {self.human(item)} down "
                f"away from the {self.human(source)}"
            )
        offset = (r(spot[0] - start[0]), r(spot[1] - start[1]), 0.0)
        axis = int(np.argmax(np.abs(offset[:2])))
        moved = 0.6 * offset[axis]
        delta: dict[str, BoundSpec] = {"xy"[axis]: BoundSpec(max=r(moved)) if moved < 0 else BoundSpec(min=r(moved))}
        rise = float(start[2]) - (self.bench + igeom.origin_height)
        comments = {
            "delta": f"VERIFY: set down on the bench {abs(offset[axis]) * 1000:.0f} mm away along {'xy'[axis]}"
            " (a free spot the layout keeps clear)"
        }
        if rise >= 0.03:
            delta["z"] = BoundSpec(max=r(-(rise - 0.01)))
            comments["delta"] += f", and down from {rise * 1000:.0f} mm above the bench"
        upright = bool(igeom.semantics.get("upright", True))
        criterion = ev.DisplacementSpec(
            object=item,
            delta=ev.AxisDeltaSpec(**delta),
            hold_s=self.hold(0.5),
            max_tilt_deg=(self.th.max_tilt_deg or 30.0) if upright else None,
            timeout_s=self.carry_timeout(item, spot),
        )
        target = sk.TargetSpec(point=(spot[0], spot[1], r(self.bench + 0.02)))
        program: list[sk.StepSpec] = [sk.RemoveFromSpec(object=item, source=source, to=target, hold_s=0.2)]
        self.held_at.pop(item, None)
        return Stage(step, criterion, program, comments, [item, source])

    # ------------------------------------------------------------------ press
    def _press(self, step: PlanStepSpec) -> Stage:
        name = step.object
        geom = measure_asset(self.placed[name].asset)
        joint = hatch_joint(geom, "lid", self.human(name))
        later = self.checked.steps[self.checked.steps.index(step) + 1 :]
        if any(s.object == name and s.action in ("close", "run") for s in later):
            stage = self._press_open(step, geom, joint)  # closed or run later: the instrument's release
            if stage is not None:
                return stage
        target = float(geom.semantics.get("lid_open_angle_deg", 0.4 * joint.open_limit))
        mechanism = ButtonReleaseSpec(
            name=f"{name}_release",
            button=f"{name}/button",
            joint=f"{name}/{joint.name}",
            trigger_radius=float(geom.semantics.get("button_trigger_radius", 0.02)),
            target_deg=target,
        )
        bound = BoundSpec(max=r(target + 1.0)) if target < 0 else BoundSpec(min=r(target - 1.0))
        criterion = ev.MechanismTriggeredSpec(mechanism=mechanism.name, target=bound, timeout_s=self.timeout(10))
        comments = {"target": "fired and the lid target within 1 deg of its open angle (paper A.6: -39 for -40)"}
        program: list[sk.StepSpec] = [sk.PressSpec(button=f"{name}/button"), sk.WaitSpec(seconds=3.0)]
        return Stage(step, criterion, program, comments, [name], [mechanism])

    # ------------------------------------------------------------------ position
    def _position(self, step: PlanStepSpec) -> Stage:
        item, target = step.object, step.required_target()
        igeom, tgeom = self.geom(item), self.geom(target)
        site = next(
            (
                s
                for s in (
                    "center",
                    "plate_center",
                    "pan_center",
                    "platform_center",
                    "inside_bottom",
                    "well_a1",
                    "neck",
                    "cap_top",
                    "cup_center",
                )
                if s in tgeom.sites
            ),
            None,
        )
        point = f"{item}/tip" if "tip" in igeom.sites else item
        tip_z = self.placed[item].pos[2] + (igeom.sites["tip"][2] if "tip" in igeom.sites else 0.0)
        hx, hy = tgeom.half_xy
        radius = self.th.xy_tolerance_m or r(max(0.02, min(hx, hy)))
        top = self.placed[target].pos[2] + float(tgeom.high[2])
        min_z = r(max(top + 0.03, tip_z + 0.03))
        hold = self.hold(0.5)
        where = f"{target}/{site}" if site else target
        criterion = ev.NearTargetSpec(
            object=point, target=where, max_xy_distance=radius, min_z=min_z, hold_s=hold, timeout_s=self.timeout(12)
        )
        comments = {
            "max_xy_distance": "from the description"
            if self.th.xy_tolerance_m
            else f"VERIFY: within the target's half-width ({min(hx, hy) * 1000:.0f} mm)",
            "min_z": f"VERIFY: 3 cm above the target's top ({top:.3f} m) and above where the "
            f"{'tip' if 'tip' in igeom.sites else 'object'} starts",
        }
        height = r(
            max(0.05, min_z - (self.placed[target].pos[2] + float(tgeom.sites[site][2]) if site else top) + 0.04)
        )
        program = [
            *self._take(item),
            sk.PositionOverSpec(
                object=item, point=point if "/" in point else None, target=where, height=height, hold_s=hold + 0.5
            ),
        ]
        self.held_at.pop(item, None)
        return Stage(step, criterion, program, comments, [item, target])


def _footprint(geom: AssetGeometry, preferred: tuple[float, float]) -> Footprint:
    return Footprint(geom.boxes, [(0.0, 0.0)], preferred, margin=0.02)


__all__ = ["Stage", "StageBuilder", "open_value"]
