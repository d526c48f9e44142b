"""Draft -> task plan: checks against the asset library, scene layout, evaluator, names.

Everything here is deterministic. Thresholds come from the assets' geometry and sites (the
pan's size, a rack's slot grid, a lid's joint range); every derived number carries a comment
saying where it came from, and the fields a person must verify are marked ``VERIFY``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pipette_cli.authoring.draft import DraftError, DraftObjectSpec, TaskDraftSpec
from pipette_cli.authoring.hatch import HatchFamilies, _open_value, _r
from pipette_cli.authoring.layout import BENCH_Z, Footprint, Layout, PlacedObject
from pipette_cli.authoring.measure import AssetGeometry, measure_asset
from pipette_cli.authoring.vocabulary import Vocabulary
from pipette_cli.errors import suggest
from pipette_cli.specs.robot import DEFAULT_ROBOT, robot_spec

CATEGORY = {"pick": "consumable_handling", "position": "consumable_handling", "place": "placement_relocation",
            "insert": "placement_relocation", "transfer": "placement_relocation", "open": "hatch_control",
            "close": "hatch_control", "press": "hatch_control"}
SURFACE_SITES = ("pan_center", "platform_center", "plate_center", "shelf_0_center", "top_center", "lid_seat",
                 "drawer_center", "block_center", "cuvette_slot", "rotor_center", "cup_center", "work_center",
                 "ring_center", "inside_bottom", "opening", "center")
RECEPTACLES = ("cuvette_slot", "rotor_center", "cup_center", "block_center", "drawer_center")
SURFACE_SIZE = {"pan_center": "pan_size", "platform_center": "platform_size", "plate_center": "plate_size",
                "shelf_0_center": "shelf_size", "shelf_1_center": "shelf_size", "top_center": "top_size",
                "center": "inner_size", "drawer_center": "plate_pocket", "block_center": "block_size",
                "cuvette_slot": "cuvette_size"}
RANDOMIZE_PER_REACH = 0.035
"""Amplitude (m) of a free object's start-position randomisation per metre of the robot's reach."""
TIMEOUT_S = 15.0
"""Time limit of a placement for a robot of at least :data:`TIMEOUT_REACH`; a shorter arm moves slower."""
TIMEOUT_REACH = 0.75


@dataclass
class TaskPlan:
    """Everything the draft template needs; built by :func:`compose`."""

    task_id: str
    name: str
    family: str
    category: str
    tags: list[str]
    instruction: str
    description: str
    robot: str
    initial_joints: list[float]
    objects: list[PlacedObject]
    joint_states: list[dict[str, Any]]
    mechanisms: list[dict[str, Any]]
    targets: list[str]
    success: dict[str, Any]
    comments: dict[str, str]
    notes: list[tuple[str, str]]
    cameras: dict[str, dict[str, Any]]
    draft: TaskDraftSpec = field(repr=False, default=None)  # type: ignore[assignment]

    @property
    def file_stem(self) -> str:
        short = self.task_id.split("/", 1)[1].rsplit("-v", 1)[0]
        return re.sub(r"(?<!^)(?=[A-Z])", "_", short).lower()


def _camel(asset_id: str) -> str:
    text = re.sub(r"(\d)_(\d)", r"\1p\2", asset_id)
    return "".join(part[:1].upper() + part[1:] for part in text.split("_"))


class Composer(HatchFamilies):
    """Turns one draft into a :class:`TaskPlan` (hatch families in :mod:`.hatch`)."""

    def __init__(self, draft: TaskDraftSpec, vocab: Vocabulary, *, namespace: str = "generated",
                 task_id: str | None = None, remarks: tuple[str, ...] = ()) -> None:
        self.draft = draft
        self.vocab = vocab
        self.namespace = namespace
        self.explicit_id = task_id
        self.remarks = list(remarks)
        self.robot = draft.robot or DEFAULT_ROBOT
        self.comments: dict[str, str] = {}
        self.notes: list[tuple[str, str]] = []
        self.joint_states: list[dict[str, Any]] = []
        self.mechanisms: list[dict[str, Any]] = []
        self.placed: dict[str, PlacedObject] = {}
        self.roles: dict[str, str] = {}
        self.layout = Layout(self.robot)
        self.th = draft.thresholds

    # ------------------------------------------------------------------ checks
    def check_assets(self) -> None:
        problems = []
        for i, obj in enumerate(self.draft.objects):
            if obj.asset not in self.vocab.assets:
                problems.append(f"objects.{i}.asset: unknown asset {obj.asset!r}; {suggest(obj.asset, self.vocab.assets)}")
        if problems:
            raise DraftError(problems)
        seen: set[str] = set()
        for obj in self.draft.objects:
            if obj.asset in seen and self.vocab.assets[obj.asset].static:
                raise DraftError(f"{obj.asset} appears twice in different roles; an instrument cannot hold itself")
            seen.add(obj.asset)

    def info(self, obj: DraftObjectSpec):
        return self.vocab.assets[obj.asset]

    def require_free(self, obj: DraftObjectSpec, verb: str) -> None:
        info = self.info(obj)
        if not info.graspable:
            free = sorted(a for a, i in self.vocab.assets.items() if i.graspable and set(i.kinds) & set(info.kinds))
            hint = f"; graspable look-alikes: {', '.join(free[:4])}" if free else "; graspable objects are tools and consumables"
            raise DraftError(f"impossible request: {obj.asset} is fixed {info.category.rstrip('s')} (static); "
                             f"the robot cannot {verb.format(it='it')}{hint}")

    # ------------------------------------------------------------------ naming
    def object_name(self, obj: DraftObjectSpec) -> str:
        info = self.info(obj)
        base = re.sub(r"[^a-z0-9]+", "_", (info.kinds[0] if info.kinds else obj.asset).split()[-1]).strip("_") or "object"
        if base in ("tube", "rack") and obj.role in ("destination", "source") and base in {p.name for p in self.placed.values()}:
            base = obj.role
        name = base
        n = 2
        while name in self.placed:
            name = f"{base}_{n}"
            n += 1
        return name

    # ------------------------------------------------------------------ geometry helpers
    def receiving_site(self, obj: DraftObjectSpec, geom: AssetGeometry, item: DraftObjectSpec | None) -> str | None:
        sites = geom.sites
        part = obj.part or ""
        if part.startswith("shelf_") and f"{part}_center" in sites:
            return f"{part}_center"
        if part in ("pan", "platform", "plate", "block", "cup", "rotor") and any(s.startswith(part) for s in sites):
            return next(s for s in sites if s.startswith(part))
        if item is not None and "lid_seat" in sites and "lid" in item.asset:
            return "lid_seat"
        for name in SURFACE_SITES:
            if name == "lid_seat":
                continue
            if name in sites:
                return name
        return None

    def opened_states(self, obj: DraftObjectSpec, geom: AssetGeometry, site: str | None) -> tuple[tuple[str, float], ...]:
        """Joints that must stand open so the robot reaches ``site`` (doors, lids, drawers)."""
        states = []
        for joint in geom.joints.values():
            if joint.name.endswith(("knob_joint",)) or joint.name == "sash_slide":
                continue
            if site in (None, "button"):
                continue
            states.append((joint.name, _open_value(joint)))
        return tuple(states)

    def place(self, name: str, obj: DraftObjectSpec, geom: AssetGeometry, preferred: tuple[float, float],
              key_site: str | None = None, extra_boxes: list[np.ndarray] = (), randomize: dict | None = None,
              z: float = BENCH_Z, euler: tuple[float, float, float] | None = None) -> PlacedObject:
        if key_site == "slot_grid":
            slots = np.array([v for k, v in geom.sites.items() if k.startswith("slot_")])
            key = tuple(slots[:, :2].mean(axis=0))
        else:
            key = (0.0, 0.0) if key_site is None else geom.sites[key_site][:2]
        boxes = np.vstack([geom.boxes, *extra_boxes]) if len(extra_boxes) else geom.boxes
        margin = max(randomize["xy"]) if randomize else 0.0
        spot = self.layout.place(Footprint(boxes, key, preferred, margin), z=z)
        if spot is None:
            ws = self.layout.workspace
            raise DraftError(
                f"impossible layout: found no place for {obj.asset} ({obj.role}) on the bench within the "
                f"{self.robot}'s reach ({ws.min_reach:.2f}-{ws.max_reach:.2f} m) clear of the robot and the other objects; "
                "try another robot (--robot / 'with the UR5e') or a smaller object"
            )
        zpos = z + (geom.origin_height + 0.001 if geom.free else 0.0)
        placed = PlacedObject(name, obj.asset, (spot[0], spot[1], _r(zpos, 4)),
                              euler if euler is not None else geom.rest_euler_deg, randomize)
        self.placed[name] = placed
        return placed

    def free_randomize(self, geom: AssetGeometry) -> dict[str, Any]:
        amp = round(RANDOMIZE_PER_REACH * robot_spec(self.robot).reach, 2)
        hx, hy = geom.half_xy
        round_ = geom.semantics.get("upright", True) and abs(hx - hy) < 0.2 * max(hx, hy)
        return {"xy": (amp, amp), "yaw_deg": 180 if round_ else 15}

    # ------------------------------------------------------------------ families
    def compose(self) -> TaskPlan:
        self.check_assets()
        intent = self.draft.intent
        handler = getattr(self, f"_compose_{intent}")
        success, targets = handler()
        for obj in self.draft.with_role("distractor"):
            geom = measure_asset(obj.asset)
            name = self.object_name(obj)
            ws = self.layout.workspace
            placed = self.place(name, obj, geom, (ws.center_x + 0.1, 0.0),
                                randomize=self.free_randomize(geom) if geom.free else None)
            placed.comment = "distractor: not part of the success criterion"
        for remark in self.remarks:
            index = next((i for i, p in enumerate(self.placed.values()) if remark.split(";")[-1].strip().endswith(p.asset)), None)
            self.notes.append((f"scene.objects.{index}.asset" if index is not None else "scene.objects",
                               f"VERIFY the choice: {remark}."))
        return self.finish(success, targets)

    def _compose_pick(self):
        item = self.draft.one("item")
        self.require_free(item, "pick {it} up")
        geom = measure_asset(item.asset)
        ws = self.layout.workspace
        source = self.draft.one("source")
        name = self.object_name(item)
        if source is not None:
            self.put_on_source(item, geom, name, source)
        else:
            placed = self.place(name, item, geom, (ws.center_x, 0.0), randomize=self.free_randomize(geom))
            placed.comment = "VERIFY reachable: layout by pipette new-task"
        gain = self.th.lift_height_m or _r(max(0.03, min(0.08, 0.5 * geom.height)), 3)
        tilt = self.th.max_tilt_deg or (35.0 if geom.semantics.get("upright", True) and geom.height > 1.5 * 2 * max(geom.half_xy) else None)
        success: dict[str, Any] = {"type": "lift_and_hold", "object": name, "min_height_gain": gain,
                                   "hold_s": self.th.hold_s if self.th.hold_s is not None else 0.5}
        self.comments["success.min_height_gain"] = (
            "from the description" if self.th.lift_height_m else
            f"VERIFY: half the object's resting height ({geom.height * 1000:.0f} mm), clipped to 3-8 cm"
        )
        if tilt:
            success["max_tilt_deg"] = tilt
            self.comments["success.max_tilt_deg"] = "tall upright object: tilting past this fails (paper A.8 uses 35)" if not self.th.max_tilt_deg else "from the description"
        success["timeout_s"] = self.th.timeout_s or 10
        return success, [name, *([self.roles["source"]] if source else [])]

    def remember(self, role: str, name: str) -> None:
        self.roles[role] = name

    def place_static(self, obj: DraftObjectSpec, preferred: tuple[float, float], site: str | None,
                     open_joints: tuple[tuple[str, float], ...] = (), extra_states: tuple[tuple[tuple[str, float], ...], ...] = (),
                     randomize: dict | None = None) -> tuple[PlacedObject, AssetGeometry]:
        geom = measure_asset(obj.asset, open_joints)
        extra = [measure_asset(obj.asset, states).boxes for states in extra_states]
        if open_joints:
            extra.append(measure_asset(obj.asset).boxes)
        name = self.object_name(obj)
        placed = self.place(name, obj, geom, preferred, key_site=site, extra_boxes=extra, randomize=randomize)
        placed.comment = "VERIFY the layout (pipette sim render): placed by pipette new-task within reach"
        self.remember(obj.role, name)
        for joint, value in open_joints:
            self.joint_states.append({"joint": f"{name}/{joint}", "value": _r(value, 1)})
            self.comments[f"scene.joint_states.{len(self.joint_states) - 1}"] = "opened so the robot can reach inside; VERIFY"
        return placed, geom

    def put_on_source(self, item: DraftObjectSpec, item_geom: AssetGeometry, name: str, source: DraftObjectSpec) -> PlacedObject:
        ws = self.layout.workspace
        src_geom0 = measure_asset(source.asset)
        if not src_geom0.free:
            site = self.source_site(source, src_geom0)
            open_joints = self.opened_states(source, src_geom0, site)
            placed_src, src_geom = self.place_static(source, (ws.center_x + 0.05, -ws.lane_y), site, open_joints)
        else:
            site = self.source_site(source, src_geom0)
            src_geom = src_geom0
            placed_src = self.place(self.object_name(source), source, src_geom, (ws.center_x, -ws.lane_y))
            self.remember("source", placed_src.name)
            placed_src.comment = "VERIFY the layout: placed by pipette new-task"
        local = src_geom.sites[site]
        slot = site.startswith("slot_")
        euler = (0.0, 0.0, 0.0) if slot else item_geom.rest_euler_deg
        standing = measure_asset(item.asset) if not slot else None
        origin_h = 0.0 if slot else (standing.origin_height if standing else 0.0)
        if not slot:
            self.check_fits_surface(item, item_geom, source, src_geom, site)
        cx, cy = (0.0, 0.0) if slot else _bbox_center(item_geom)
        pos = (_r(placed_src.pos[0] + local[0] - cx), _r(placed_src.pos[1] + local[1] - cy),
               _r(placed_src.pos[2] + local[2] + origin_h + 0.001, 4))
        placed = PlacedObject(name, item.asset, pos, euler, None,
                              f"starts {'in' if slot else 'on'} {placed_src.name}/{site}; VERIFY it settles there")
        self.placed[name] = placed
        boxes = item_geom.boxes if not slot else measure_asset(item.asset).boxes
        self.layout.add_obstacle(boxes, pos)
        self.remember("item", name)
        return placed

    def source_site(self, source: DraftObjectSpec, geom: AssetGeometry) -> str:
        slots = sorted((s for s in geom.sites if s.startswith("slot_")), key=lambda s: int(s.split("_")[1]))
        if slots:
            return slots[0]
        site = self.receiving_site(source, geom, None)
        if site is None:
            raise DraftError(f"impossible request: {source.asset} has no surface or slot an object can start on")
        return site

    def check_fits_surface(self, item: DraftObjectSpec, item_geom: AssetGeometry, dest: DraftObjectSpec,
                           dest_geom: AssetGeometry, site: str) -> float:
        """Radius of the disc the item's origin must end in on ``site``; errors when it cannot fit."""
        sem = dest_geom.semantics
        size_key = SURFACE_SIZE.get(site) if site != "center" or "inner_size" in sem else None
        size = sem.get(size_key) if size_key else None
        if site == "inside_bottom":
            size = [sem.get("outer_diameter", 0.05) - 0.004] * 2
        if size is None:
            hx, hy = dest_geom.half_xy
            size = [2 * hx, 2 * hy]
        half = 0.5 * min(float(size[0]), float(size[1]))
        extent = sorted(float(v) for v in (item_geom.high[:2] - item_geom.low[:2]))
        room_axes = sorted(float(v) for v in size[:2])
        if site == "opening":
            room = half - 0.5 * extent[0]
        elif site in RECEPTACLES:
            room = min(0.5 * (r - e) for r, e in zip(room_axes, extent, strict=True)) + 0.0015  # a slot holds it with play
        else:
            room = min(0.5 * (r - e) for r, e in zip(room_axes, extent, strict=True))
        if room < 0.0:
            raise DraftError(
                f"impossible request: {item.asset} ({extent[1] * 1000:.0f} x {extent[0] * 1000:.0f} mm) does not fit "
                f"{dest.asset}'s {site.replace('_', ' ')} ({room_axes[1] * 1000:.0f} x {room_axes[0] * 1000:.0f} mm); "
                "choose a smaller object or a larger destination"
            )
        capacity = sem.get("capacity_kg")
        mass = float(self.vocab.assets[item.asset].semantics.get("mass", 0.0))
        if capacity is not None and mass > float(capacity):
            raise DraftError(f"impossible request: {item.asset} weighs {mass:.2f} kg, over the {capacity} kg capacity of {dest.asset}")
        if site in RECEPTACLES:
            return max(0.01, min(0.5 * half, room))
        return max(0.005, min(0.5 * half, room))

    def _compose_place(self):
        return self._compose_moving(insert=False)

    def _compose_insert(self):
        return self._compose_moving(insert=True)

    def _compose_transfer(self):
        return self._compose_moving(insert=None)

    def _compose_moving(self, insert: bool | None):
        item = self.draft.one("item")
        self.require_free(item, "move {it}")
        dest = self.draft.one("destination")
        source = self.draft.one("source")
        ws = self.layout.workspace
        item_geom = measure_asset(item.asset)
        dest_name = None
        success: dict[str, Any]
        if dest is not None:
            if dest.asset == item.asset:
                raise DraftError(f"contradictory request: {item.asset} cannot be put into itself")
            dest_geom0 = measure_asset(dest.asset)
            site = self._dest_site(item, dest, dest_geom0)
            if dest_geom0.free:
                placed_dest = self.place(self.object_name(dest), dest, dest_geom0, (ws.center_x + 0.05, ws.lane_y))
                placed_dest.comment = "VERIFY the layout: placed by pipette new-task"
                self.remember("destination", placed_dest.name)
                dest_geom = dest_geom0
            else:
                open_joints = self.opened_states(dest, dest_geom0, site)
                placed_dest, dest_geom = self.place_static(dest, (ws.center_x + 0.05, ws.lane_y), site, open_joints)
        name = self.object_name(item)
        if source is not None:
            self.put_on_source(item, item_geom, name, source)
        else:
            placed = self.place(name, item, item_geom, (ws.center_x - 0.05, -ws.lane_y), randomize=self.free_randomize(item_geom))
            placed.comment = "VERIFY reachable: layout by pipette new-task"
            self.remember("item", name)
        if dest is not None:
            success = self._arrival(item, item_geom, name, dest, dest_geom, placed_dest, site)
        else:
            success = self._removal(item, item_geom, name, source)
        targets = [name] + [self.roles[r] for r in ("destination", "source") if r in self.roles]
        return success, targets

    def _dest_site(self, item, dest, geom: AssetGeometry) -> str:
        slots = [s for s in geom.sites if s.startswith("slot_")]
        if slots:
            self._check_holes(item, dest, geom)
            return "slot_grid"
        site = self.receiving_site(dest, geom, item)
        if site is None or site == "opening" and geom.semantics.get("opening_height") is None:
            raise DraftError(f"impossible request: {dest.asset} has no surface, slot or opening to put {item.asset} in or on")
        if "lid_seat" in geom.sites and site != "lid_seat":
            raise DraftError(f"impossible request: only its lid goes on {dest.asset}; to open or close it say 'open the {dest.asset.replace('_', ' ')}'")
        return site

    def _check_holes(self, item, dest, geom: AssetGeometry) -> None:
        hole = geom.semantics.get("hole")
        sem = self.vocab.assets[item.asset].semantics
        diameter = sem.get("outer_diameter") or sem.get("diameter") or sem.get("base_diameter")
        if hole is not None and diameter is not None and float(diameter) + 0.0002 > float(hole):
            fitting = sorted(a for a, i in self.vocab.assets.items()
                             if "hole" in i.semantics and float(i.semantics["hole"]) >= float(diameter) + 0.0002)
            hint = f"; holders that fit: {', '.join(fitting)}" if fitting else ""
            raise DraftError(
                f"impossible request: {item.asset} is {float(diameter) * 1000:.1f} mm wide, the holes of {dest.asset} "
                f"are {float(hole) * 1000:.1f} mm{hint}"
            )

    def _arrival(self, item, item_geom, name, dest, dest_geom, placed_dest, site) -> dict[str, Any]:
        th = self.th
        upright = bool(item_geom.semantics.get("upright", True))
        hold = th.hold_s if th.hold_s is not None else 1.0
        timeout = th.timeout_s or round(TIMEOUT_S * max(1.0, TIMEOUT_REACH / robot_spec(self.robot).reach))
        dname = placed_dest.name
        if site == "slot_grid":
            slots = np.array([v for k, v in dest_geom.sites.items() if k.startswith("slot_")])
            pitch = float(dest_geom.semantics.get("pitch", 0.02))
            lo, hi = slots.min(axis=0), slots.max(axis=0)
            px, py = placed_dest.pos[0], placed_dest.pos[1]
            slot_z = float(slots[:, 2].mean())
            success = {"type": "region_hold", "object": name,
                       "x": {"min": _r(px + lo[0] - pitch / 2), "max": _r(px + hi[0] + pitch / 2)},
                       "y": {"min": _r(py + lo[1] - pitch / 2), "max": _r(py + hi[1] + pitch / 2)}}
            height = float(dest_geom.high[2])
            if slot_z > 0.05:  # hanging holders (pipette stands): the item is off the bench
                zmin = BENCH_Z + item_geom.origin_height + 0.025
                success["x"] = {"min": _r(px + dest_geom.low[0] - 0.03), "max": _r(px + dest_geom.high[0] + 0.03)}
                success["y"] = {"min": _r(py + dest_geom.low[1] - 0.03), "max": _r(py + dest_geom.high[1] + 0.03)}
                success["z"] = {"min": _r(zmin)}
                self.comments["success.z"] = f"VERIFY: hung, its origin is {25} mm above where it lies on the bench"
            else:
                success["z"] = {"min": _r(BENCH_Z + slot_z - 0.01), "max": _r(BENCH_Z + slot_z + 0.4 * height + 0.01)}
                self.comments["success.z"] = (f"VERIFY: standing in a slot (floor {slot_z * 1000:.0f} mm), below 40 % of the "
                                              f"{height * 1000:.0f} mm holder, so lying on top does not count")
            self.comments["success.x"] = f"VERIFY: the slot grid of {dname} plus half a {pitch * 1000:.0f} mm pitch"
        else:
            radius = th.xy_tolerance_m or _r(self.check_fits_surface(item, item_geom, dest, dest_geom, site), 4)
            surface = float(dest_geom.sites[site][2]) + BENCH_Z
            ref, lift = _reference_point(name, item_geom)
            success = {"type": "region_hold", "object": ref,
                       "within": {"center": f"{dname}/{site}", "radius": radius}}
            self.comments["success.within"] = ("from the description" if th.xy_tolerance_m else
                                                      f"VERIFY: at most half of the {site.replace('_', ' ')}'s half-width, "
                                                      "and the object's footprint stays on it")
            if site == "opening":
                success["z"] = {"max": _r(surface)}
                self.comments["success.z"] = "inside: below the opening"
            else:
                top = surface + lift + 0.03
                success["z"] = {"min": _r(surface - 0.01), "max": _r(top)}
                if ref != name:
                    self.comments["success.object"] = "a lying object's middle (its grasp site), not its end"
                self.comments["success.z"] = f"VERIFY: resting on the surface at z = {surface:.3f} m (bench 0.55)"
        tilt = th.max_tilt_deg or (15.0 if upright and site != "slot_grid" else None)
        if tilt:
            success["max_tilt_deg"] = tilt
            self.comments["success.max_tilt_deg"] = "an upright object must arrive upright" if not th.max_tilt_deg else "from the description"
        success["hold_s"] = hold
        success["timeout_s"] = timeout
        return success

    def _removal(self, item, item_geom, name, source) -> dict[str, Any]:
        th = self.th
        src_geom = measure_asset(source.asset)
        site = self.source_site(source, src_geom)
        rise = float(src_geom.sites[site][2])
        upright = bool(item_geom.semantics.get("upright", True))
        hold = th.hold_s if th.hold_s is not None else 1.0
        timeout = th.timeout_s or 15
        if rise >= 0.03:
            success: dict[str, Any] = {"type": "displacement", "object": name, "delta": {"z": {"max": _r(-(rise - 0.01))}},
                                       "hold_s": hold}
            self.comments["success.delta.z"] = f"off the {site.replace('_', ' ')} ({rise * 1000:.0f} mm above the bench) and down on the bench"
        else:
            hx, hy = src_geom.half_xy
            d = _r(max(hx, hy) + max(item_geom.half_xy) + 0.02)
            away = [{"type": "displacement", "object": name, "delta": {axis: bound}, "hold_s": hold}
                    for axis, bound in (("x", {"max": -d}), ("y", {"min": d}), ("y", {"max": -d}))]
            success = {"type": "any", "of": away}
            self.comments["success.of"] = f"VERIFY: moved {d * 1000:.0f} mm (the source's half-size plus the object's) toward the robot or sideways"
        if upright and (th.max_tilt_deg or rise >= 0.03):
            tilt = th.max_tilt_deg or 15.0
            if success["type"] == "displacement":
                success["max_tilt_deg"] = tilt
        success["timeout_s"] = timeout
        return success

    def _compose_position(self):
        item = self.draft.one("item")
        self.require_free(item, "carry {it}")
        target = self.draft.one("target")
        ws = self.layout.workspace
        tgeom = measure_asset(target.asset)
        site = next((s for s in ("center", "plate_center", "pan_center", "platform_center", "inside_bottom", "well_a1", "neck", "cap_top", "cup_center") if s in tgeom.sites), None)
        if tgeom.free:
            placed_t = self.place(self.object_name(target), target, tgeom, (ws.center_x + 0.05, ws.lane_y))
            placed_t.comment = "VERIFY the layout: placed by pipette new-task"
            self.remember("target", placed_t.name)
        else:
            placed_t, tgeom = self.place_static(target, (ws.center_x + 0.05, ws.lane_y), site)
        igeom = measure_asset(item.asset)
        name = self.object_name(item)
        placed = self.place(name, item, igeom, (ws.center_x - 0.05, -ws.lane_y), randomize=self.free_randomize(igeom))
        placed.comment = "VERIFY reachable: layout by pipette new-task"
        point = f"{name}/tip" if "tip" in igeom.sites else name
        tip_z = placed.pos[2] + (igeom.sites["tip"][2] if "tip" in igeom.sites else 0.0)
        hx, hy = tgeom.half_xy
        radius = self.th.xy_tolerance_m or _r(max(0.02, min(hx, hy)))
        top = placed_t.pos[2] + float(tgeom.high[2])
        min_z = _r(max(top + 0.03, tip_z + 0.03))
        success = {"type": "near_target", "object": point,
                   "target": f"{placed_t.name}/{site}" if site else placed_t.name,
                   "max_xy_distance": radius, "min_z": min_z,
                   "hold_s": self.th.hold_s if self.th.hold_s is not None else 0.5, "timeout_s": self.th.timeout_s or 12}
        self.comments["success.max_xy_distance"] = "from the description" if self.th.xy_tolerance_m else \
            f"VERIFY: within the target's half-width ({min(hx, hy) * 1000:.0f} mm)"
        self.comments["success.min_z"] = (f"VERIFY: 3 cm above the target's top ({top:.3f} m) and above where the "
                                          f"{'tip' if 'tip' in igeom.sites else 'object'} starts")
        return success, [name, placed_t.name]

    # ------------------------------------------------------------------ finish
    def finish(self, success: dict[str, Any], targets: list[str]) -> TaskPlan:
        from pipette_cli.sim.robots import home_joints

        intent = self.draft.intent
        task_id = self.explicit_id or f"{self.namespace}/{self.short_id()}-v1"
        objects = list(self.placed.values())
        xs = [o.pos[0] for o in objects]
        ys = [o.pos[1] for o in objects]
        cx, cy = _r(float(np.mean(xs)), 2), _r(float(np.mean(ys)), 2)
        cameras = {
            "top": {"pos": (_r(cx + 0.5, 2), cy, 1.6), "look_at": (cx, cy, 0.6), "fovy_deg": 55},
            "main": {"pos": (_r(cx + 0.75, 2), _r(cy - 0.75, 2), 1.1), "look_at": (cx, cy, 0.65), "fovy_deg": 45},
            "wrist": {"mount": "end_effector", **robot_spec(self.robot).wrist_camera.model_dump()},
        }
        tags = ["generated", intent]
        if any(self.vocab.assets[o.asset].category == "instruments" for o in objects):
            tags.append("instrument")
        if self.robot != DEFAULT_ROBOT:
            tags.append(next(iter(robot_spec(self.robot).aliases), self.robot))
        self.notes.insert(0, ("scene.objects", "VERIFY the layout: computed by pipette new-task to be reachable and "
                                               "collision-free at reset; render it with pipette sim render."))
        self.notes.insert(1, ("success", "VERIFY the thresholds (derived from the assets' geometry, see the comments) "
                                         "against a scripted or teleoperated demonstration."))
        if self.robot != DEFAULT_ROBOT:
            self.notes.append(("cameras.wrist", f"VERIFY the wrist camera mount on the {self.robot}."))
        return TaskPlan(
            task_id=task_id, name=self.human_name(), family=intent, category=CATEGORY[intent], tags=tags,
            instruction=self.draft.instruction, description="", robot=self.robot,
            initial_joints=[_r(v, 4) for v in home_joints(self.robot)], objects=objects, joint_states=self.joint_states,
            mechanisms=self.mechanisms, targets=list(dict.fromkeys(targets)), success=success, comments=self.comments,
            notes=self.notes, cameras=cameras, draft=self.draft,
        )

    def short_id(self) -> str:
        d = self.draft
        c = {o.role: _camel(o.asset) for o in d.objects}
        item = c.get("item")
        part = (d.one("instrument").part or "").split("_")[0].capitalize() if d.one("instrument") else ""
        return {
            "pick": lambda: f"PickUp{item}" + (f"From{c['source']}" if "source" in c else ""),
            "place": lambda: f"Place{item}On{c['destination']}",
            "insert": lambda: f"Insert{item}Into{c['destination']}",
            "transfer": lambda: f"Move{item}From{c['source']}To{c['destination']}" if "destination" in c else f"Remove{item}From{c['source']}",
            "position": lambda: f"Position{item}Over{c['target']}",
            "open": lambda: f"Open{c['instrument']}{part if part != 'Button' else ''}",
            "close": lambda: f"Close{c['instrument']}{part if part != 'Button' else ''}",
            "press": lambda: f"Press{c['instrument']}Button",
        }[d.intent]()

    def human_name(self) -> str:
        d = self.draft
        n = {o.role: self.vocab.assets[o.asset].human_name() for o in d.objects}
        return {
            "pick": lambda: f"Pick up the {n['item']}",
            "place": lambda: f"Place the {n['item']} on the {n['destination']}",
            "insert": lambda: f"Insert the {n['item']} into the {n['destination']}",
            "transfer": lambda: (f"Move the {n['item']} from the {n['source']} to the {n['destination']}" if "destination" in n
                                 else f"Remove the {n['item']} from the {n['source']}"),
            "position": lambda: f"Position the {n['item']} over the {n['target']}",
            "open": lambda: f"Open the {n['instrument']}",
            "close": lambda: f"Close the {n['instrument']}",
            "press": lambda: f"Press the {n['instrument']} button",
        }[d.intent]()


def _bbox_center(geom: AssetGeometry) -> tuple[float, float]:
    c = 0.5 * (geom.low[:2] + geom.high[:2])
    return float(c[0]), float(c[1])


def _reference_point(name: str, geom: AssetGeometry) -> tuple[str, float]:
    """The point whose position is tested, and its height above the surface at rest.

    Upright objects: their origin (bottom centre). Lying ones (a conical tube, a pipette):
    their ``grasp`` site near the middle, so the object is judged by where its body is.
    """
    if not geom.semantics.get("upright", True) and "grasp" in geom.sites:
        return f"{name}/grasp", geom.origin_height + float(geom.sites["grasp"][2])
    return name, geom.origin_height


def compose(draft: TaskDraftSpec, vocab: Vocabulary, *, namespace: str = "generated", task_id: str | None = None,
            remarks: tuple[str, ...] = ()) -> TaskPlan:
    """Check ``draft`` against the library and turn it into a :class:`TaskPlan`.

    Raises:
        DraftError: unknown assets, impossible or contradictory requests, no room within reach.
    """
    return Composer(draft, vocab, namespace=namespace, task_id=task_id, remarks=remarks).compose()
