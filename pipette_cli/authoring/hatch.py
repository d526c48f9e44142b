"""Hatch families of the drafting code: open, close (hinged, sliding or lift-off lids), press.

A mixin of :class:`~pipette_cli.authoring.compose.Composer`: the joint to move comes from the
named part (lid, door, drawer, sash) or the instrument's only joint; the start state and the
goal bound come from the joint's range (0 = shut).
"""

from __future__ import annotations

import re
from typing import Any

from pipette_cli.authoring.draft import DraftError, DraftObjectSpec
from pipette_cli.authoring.layout import BENCH_Z, PlacedObject
from pipette_cli.authoring.measure import AssetGeometry, JointInfo, measure_asset

PART_JOINTS = {"lid": ("lid_hinge",), "door": ("door_hinge",), "drawer": ("drawer_slide",), "sash": ("sash_slide",),
               "knob": ("heat_knob_joint", "speed_knob_joint")}


def _r(value: float, nd: int = 3) -> float:
    return round(float(value), nd) + 0.0


def _open_value(joint: JointInfo) -> float:
    """Where an opened joint is set at reset: 95 % of the way to its open limit."""
    return 0.95 * joint.open_limit


def _separate_lid(geom: AssetGeometry) -> str | None:
    m = re.search(r"separate asset (\w+)", str(geom.semantics.get("description", "")))
    return m.group(1) if m else None


class HatchFamilies:
    """open / close / press; relies on the Composer's draft, layout and bookkeeping."""

    def _hatch_instrument(self):
        inst = self.draft.one("instrument")
        if self.info(inst).graspable and not self.info(inst).static:
            raise DraftError(f"impossible request: {inst.asset} is a loose object with nothing to {self.draft.intent}")
        return inst

    def _pick_joint(self, inst, geom: AssetGeometry) -> JointInfo:
        joints = {n: j for n, j in geom.joints.items()}
        if inst.part and inst.part in PART_JOINTS:
            options = [joints[n] for n in PART_JOINTS[inst.part] if n in joints]
            if not options:
                parts = [p for p, names in PART_JOINTS.items() if any(n in joints for n in names)]
                raise DraftError(f"{inst.asset} has no {inst.part}; its moving parts: {', '.join(parts) or 'none'}")
            if len(options) > 1:
                raise DraftError(f"{inst.asset} has {len(options)} {inst.part}s ({', '.join(o.name for o in options)}); say which")
            return options[0]
        movable = [j for j in joints.values() if not j.name.endswith("knob_joint")]
        if len(movable) == 1:
            return movable[0]
        openable = sorted(a for a, i in self.vocab.assets.items()
                          if i.static and any(not j.endswith("knob_joint") for j in i.semantics.get("joints", [])))
        if not movable:
            raise DraftError(
                f"impossible request: {inst.asset} has nothing to {self.draft.intent} (no lid, door, drawer or sash joint); "
                f"instruments that open: {', '.join(openable)}"
            )
        raise DraftError(f"{inst.asset} has several moving parts ({', '.join(j.name for j in movable)}); say which")

    def _compose_open(self):
        return self._compose_hatch(opening=True)

    def _compose_close(self):
        return self._compose_hatch(opening=False)

    def _compose_hatch(self, opening: bool):
        inst = self._hatch_instrument()
        geom0 = measure_asset(inst.asset)
        ws = self.layout.workspace
        lid_asset = _separate_lid(geom0)
        if not geom0.joints and lid_asset:
            return self._compose_lift_off_lid(inst, geom0, lid_asset, opening)
        joint = self._pick_joint(inst, geom0)
        open_value = _open_value(joint)
        start = 0.0 if opening else open_value
        handle = next((s for s in ("lid_handle", "door_handle", "sash_handle", "drawer_center") if s in geom0.sites), None)
        placed, geom = self.place_static(inst, (ws.center_x - 0.08, 0.0), handle, (), extra_states=(((joint.name, open_value),),),
                                         randomize={"xy": (0.02, 0.02)})
        placed.randomize = {"xy": (0.02, 0.02)}
        name = placed.name
        if start != 0.0 or not opening:
            self.joint_states.append({"joint": f"{name}/{joint.name}", "value": _r(start, 3)})
            self.comments[f"scene.joint_states.{len(self.joint_states) - 1}"] = (
                f"open: 95 % of the {joint.open_limit:g} {joint.unit} limit; VERIFY it stays open by itself")
        else:
            self.joint_states.append({"joint": f"{name}/{joint.name}", "value": 0.0})
        sign = 1.0 if joint.open_limit > 0 else -1.0
        tol = 5.0 if joint.kind == "hinge" else 0.01
        if opening:
            goal = _r(0.75 * joint.open_limit, 3)
            bound = {"min": goal} if sign > 0 else {"max": goal}
            note = f"VERIFY: open past 75 % of the {joint.open_limit:g} {joint.unit} limit"
        else:
            bound = {"max": tol} if sign > 0 else {"min": -tol}
            note = f"VERIFY: within {tol:g} {joint.unit} of shut (0)"
        success: dict[str, Any] = {"type": "joint_threshold", "joint": f"{name}/{joint.name}", "bound": bound}
        if joint.kind == "slide":
            success["unit"] = "m"
        success["hold_s"] = self.th.hold_s if self.th.hold_s is not None else 0.5
        success["timeout_s"] = self.th.timeout_s or 10
        self.comments["success.bound"] = note
        return success, [name]

    def _compose_lift_off_lid(self, inst, geom: AssetGeometry, lid_asset: str, opening: bool):
        ws = self.layout.workspace
        lid_geom = measure_asset(lid_asset)
        seat = geom.sites.get("lid_seat", (0.0, 0.0, float(geom.high[2])))
        lid_boxes = lid_geom.boxes.copy()
        lid_boxes[:, [2, 5]] += seat[2]
        placed, _ = self.place_static(inst, (ws.center_x + 0.05, 0.0 if opening else ws.lane_y), "lid_seat" if "lid_seat" in geom.sites else None)
        lid = DraftObjectSpec(asset=lid_asset, role="item")
        name = self.object_name(lid)
        if opening:
            pos = (placed.pos[0] + seat[0], placed.pos[1] + seat[1], _r(BENCH_Z + seat[2], 4))
            self.placed[name] = PlacedObject(name, lid_asset, pos, comment=f"on {placed.name}/lid_seat; VERIFY it rests on the rim")
            self.layout.add_obstacle(lid_geom.boxes, pos)
            depth = _r(2 * lid_geom.half_xy[0], 2)
            success = {"type": "displacement", "object": name,
                       "delta": {"x": {"max": -depth}, "z": {"min": 0.10}},
                       "hold_s": self.th.hold_s if self.th.hold_s is not None else 0.3, "timeout_s": self.th.timeout_s or 15}
            self.comments["success.delta"] = (f"lifted 10 cm (paper A.8) and drawn toward the robot by its own depth "
                                              f"({depth * 1000:.0f} mm) so it clears the tank")
        else:
            placed_lid = self.place(name, lid, lid_geom, (ws.center_x - 0.05, -ws.lane_y - 0.05), randomize={"xy": (0.02, 0.02), "yaw_deg": 5})
            placed_lid.comment = "lid beside the bath; VERIFY reachable"
            success = {"type": "region_hold", "object": name, "within": {"center": f"{placed.name}/lid_seat", "radius": 0.015},
                       "z": {"min": _r(BENCH_Z + seat[2] - 0.015), "max": _r(BENCH_Z + seat[2] + 0.015)},
                       "max_tilt_deg": 5.0, "hold_s": self.th.hold_s if self.th.hold_s is not None else 0.5,
                       "timeout_s": self.th.timeout_s or 20}
            self.comments["success.z"] = "VERIFY: seated on the rim (lid_seat site height)"
        return success, [name, placed.name]

    def _compose_press(self):
        inst = self._hatch_instrument()
        geom0 = measure_asset(inst.asset)
        ws = self.layout.workspace
        if "button" not in geom0.sites:
            with_button = sorted(a for a, i in self.vocab.assets.items() if "button" in i.semantics.get("sites", []))
            raise DraftError(f"impossible request: {inst.asset} has no button to press; instruments with a button: {', '.join(with_button)}")
        joint = self._pick_joint(DraftObjectSpec(asset=inst.asset, role="instrument", part="lid"), geom0)
        target = float(geom0.semantics.get("lid_open_angle_deg", 0.4 * joint.open_limit))
        placed, _ = self.place_static(inst, (ws.center_x - 0.1, 0.0), "button", (), extra_states=(((joint.name, target),),),
                                      randomize={"xy": (0.02, 0.02)})
        placed.randomize = {"xy": (0.02, 0.02)}
        name = placed.name
        self.joint_states.append({"joint": f"{name}/{joint.name}", "value": 0.0})
        self.mechanisms.append({"type": "button_release", "name": "release", "button": f"{name}/button",
                                "joint": f"{name}/{joint.name}",
                                "trigger_radius": float(geom0.semantics.get("button_trigger_radius", 0.02)),
                                "target_deg": target})
        self.comments["scene.mechanisms.0"] = "paper A.6: the button ramps the lid servo's target to target_deg"
        bound = {"max": _r(target + 1.0, 3)} if target < 0 else {"min": _r(target - 1.0, 3)}
        success = {"type": "mechanism_triggered", "mechanism": "release", "target": bound,
                   "timeout_s": self.th.timeout_s or 10}
        self.comments["success.target"] = "fired and the lid target within 1 deg of its open angle (paper A.6: -39 for -40)"
        return success, [name]
