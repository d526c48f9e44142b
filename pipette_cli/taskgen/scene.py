"""Where everything stands at reset: instruments within reach with the sites the steps use, their
lids and doors in the state the first step needs, items on the bench or in/on what they are taken
from. Geometry comes from the compiled assets (:mod:`.measure`); the grid search from :mod:`.layout`.

An item that does not stay put on a flat bench by itself (a conical tube tips over, a pipette tip
rolls: :func:`~.measure.stands_alone`) and is not taken from anywhere named starts in a rack of the
library whose holes fit it, added to the scene.

Joint states follow the steps: a lid the task opens starts closed, one it closes starts open (a
latched lid at the angle its release pops it to when its friction holds it there: the arm reaches
over it; others near their open limit), and a lid, door or drawer in the way of a placement starts
open unless a step opens it first. A step that needs a part open after an earlier step closed it
is refused.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pipette_cli.language.assets import load_vocabulary
from pipette_cli.taskgen.layout import BESIDE_GAP, Footprint, Layout, PlacedObject
from pipette_cli.taskgen.measure import AssetGeometry, JointInfo, holds_open, measure_asset, r, stands_alone
from pipette_cli.taskgen.motors import release_angle
from pipette_cli.taskgen.plan import BUTTON_SITES, INSTRUMENT_ACTIONS, PlanError, PlanStepSpec
from pipette_cli.taskgen.resolve import choose_pair, holders_that_fit
from pipette_cli.taskgen.validate import CheckedPlan, lid_beside, lid_points, separate_lid

PART_JOINTS = {"lid": ("lid_hinge",), "door": ("door_hinge",), "drawer": ("drawer_slide",), "sash": ("sash_slide",)}
HANDLES = ("lid_handle", "door_handle", "drawer_handle", "sash_handle")
SURFACE_SITES: tuple[str, ...] = ("pan_center", "platform_center", "plate_center", "shelf_0_center", "top_center")
SURFACE_SITES += ("drawer_center", "block_center", "cuvette_slot", "rotor_center", "cup_center", "work_center")
SURFACE_SITES += ("ring_center", "inside_bottom", "center", "opening")
FLAT_SITES = ("pan_center", "platform_center", "plate_center", "top_center", "drawer_center", "work_center")
"""Surface sites (and every ``shelf_*_center``) that hold an object only if it stands by itself; the
others (a rotor, a block, a cup, a ring, an inside bottom) hold it in a well or against a wall."""
RELATION_START = {"left_of": (0.0, -0.5), "right_of": (0.0, 0.5), "behind": (-0.12, 0.0), "in_front_of": (0.2, 0.0)}
"""Where a relation's reference starts (x from the workspace's middle, m; y in lanes): room beside it."""
BESIDE_CLEAR = 0.2
"""Metres past a relation reference's half-diagonal the other objects start (outside its region)."""
RELEASE_FAR = 0.98
"""Share of its limit a latched lid is popped open to when its friction does not hold it at the
asset's release angle (protocols/SpinMicrotube-v1 opens the microcentrifuge to -98 of -100 deg)."""
OPEN_FRACTION = 0.95
"""An opened lid or door starts at this fraction of its open limit."""
START_XY = 0.02
"""Metres an instrument (and a lid beside it) is randomised by along x and y at reset."""
LID_GAP = BESIDE_GAP + 2 * START_XY
"""Metres between an instrument and its lift-off lid beside it, however both are randomised."""


def open_value(joint: JointInfo) -> float:
    return OPEN_FRACTION * joint.open_limit


def movable_joints(geom: AssetGeometry) -> list[JointInfo]:
    return [j for j in geom.joints.values() if not j.name.endswith("knob_joint")]


def hatch_joint(geom: AssetGeometry, part: str | None, human: str) -> JointInfo:
    """The joint a step on ``part`` moves (the only movable joint when no part is named)."""
    if part in PART_JOINTS:
        options = [geom.joints[n] for n in PART_JOINTS[part] if n in geom.joints]
        if options:
            return options[0]
        raise PlanError(f"impossible request: the {human} has no {part}")
    movable = movable_joints(geom)
    if len(movable) == 1:
        return movable[0]
    if not movable:
        raise PlanError(f"impossible request: the {human} has no lid, door, drawer or sash to move")
    raise PlanError(f"the {human} has several moving parts ({', '.join(j.name for j in movable)}); say which")


def receiving_site(geom: AssetGeometry, part: str | None, item_asset: str | None = None) -> str | None:
    """The site an object goes to on ``geom``: a named shelf/pan/platform, a lid seat, else the
    first surface site the asset has, or its slot grid (``slot_grid``)."""
    sites = geom.sites
    if any(s.startswith("slot_") for s in sites):
        return "slot_grid"
    if part and part.startswith("shelf_") and f"{part}_center" in sites:
        return f"{part}_center"
    if part in ("pan", "platform", "plate", "block", "cup", "rotor"):
        named = [s for s in sites if s.startswith(part)]
        if named:
            return named[0]
    if item_asset is not None and "lid_seat" in sites and "lid" in item_asset:
        return "lid_seat"
    return next((s for s in SURFACE_SITES if s in sites), None)


def covered(geom: AssetGeometry, site: str) -> bool:
    """Whether a part of the asset lies above ``site`` (a shelf under a roof): things go in level."""
    x, y, z = geom.sites[site]
    b = geom.boxes
    return bool(np.any((b[:, 0] < x) & (b[:, 3] > x) & (b[:, 1] < y) & (b[:, 4] > y) & (b[:, 2] > z + 0.03)))


@dataclass
class SceneLayout:
    """The placed objects, joint states, mechanisms and notes of one task."""

    placed: dict[str, PlacedObject] = field(default_factory=dict)
    joint_states: list[tuple[str, float, str]] = field(default_factory=list)  # (object/joint, value, comment)
    start_site: dict[str, tuple[str, str]] = field(default_factory=dict)  # item -> (holder, site) it starts at
    slots_used: dict[str, list[str]] = field(default_factory=dict)
    lids: dict[str, str] = field(default_factory=dict)  # instrument -> object name of its lift-off lid
    beside: dict[str, tuple[tuple[float, float], tuple[float, float]]] = field(default_factory=dict)
    """item -> (free spot, direction) beside the reference of its relation ("next to the beaker")."""


class SceneBuilder:
    """Lays out the objects of a checked plan (see the module docstring)."""

    def __init__(self, checked: CheckedPlan) -> None:
        self.checked = checked
        self.robot = checked.robot.name
        self.layout = Layout(self.robot)
        self.ws = self.layout.workspace
        self.out = SceneLayout()
        self.geoms: dict[str, AssetGeometry] = {}
        self.clear_of: tuple[tuple[float, float], float] | None = None
        self.added: dict[str, str] = {}
        """Objects the layout adds to the plan's (a rack for a tube that cannot stand): name -> asset."""

    # ------------------------------------------------------------------ helpers
    def human(self, name: str) -> str:
        if name in self.added:  # a rack the layout added
            return load_vocabulary().assets[self.added[name]].human_name()
        return self.checked.objects[name].info.human_name()

    def geom(self, name: str) -> AssetGeometry:
        return measure_asset(self.checked.asset(name))

    def _steps_on(self, name: str) -> list[PlanStepSpec]:
        return [s for s in self.checked.steps if name in (s.object, s.target, s.source)]

    # ------------------------------------------------------------------ joints
    def joint_plan(self) -> dict[tuple[str, str], float]:
        """Initial value of every joint the steps move or need open, checking the order makes sense."""
        start: dict[tuple[str, str], float] = {}
        state: dict[tuple[str, str], str] = {}
        for i, step in enumerate(self.checked.steps):
            if step.action in ("open", "close"):
                geom = self.geom(step.object)
                if not geom.joints and separate_lid(geom):
                    continue
                joint = hatch_joint(geom, step.part, self.human(step.object))
                key = (step.object, joint.name)
                if key not in start:
                    start[key] = 0.0 if step.action == "open" else self.open_to_close(step.object, geom, joint)
                state[key] = "open" if step.action == "open" else "closed"
            elif step.action == "press":
                geom = self.geom(step.object)
                joint = hatch_joint(geom, "lid", self.human(step.object))
                start.setdefault((step.object, joint.name), 0.0)
                state[(step.object, joint.name)] = "released"
            elif step.action == "run":
                opened = [j for (o, j), now in state.items() if o == step.object and now != "closed"]
                if opened:
                    raise PlanError(
                        f"step {i + 1} (run the {self.human(step.object)}) needs it shut, but its "
                        f"{opened[0].split('_')[0]} is open then; close it first ('..., close the lid and start it')"
                    )
            for holder in (step.target, step.source):
                if holder is None or step.action in INSTRUMENT_ACTIONS:
                    continue
                geom = self.geom(holder)
                site = receiving_site(
                    geom, step.part if holder == step.target else None, self.checked.asset(step.object)
                )
                if site in (None, "lid_seat", "opening"):
                    continue
                for joint in movable_joints(geom):
                    if joint.name == "sash_slide":
                        continue
                    key = (holder, joint.name)
                    if state.get(key) == "closed":
                        raise PlanError(
                            f"step {i + 1} ({step.action} {step.object}) needs the {self.human(holder)} open, "
                            f"but an earlier step closes it; open it first"
                        )
                    if key not in start:
                        start[key] = open_value(joint)
                        state[key] = "open"
        return start

    # ------------------------------------------------------------------ layout
    def build(self) -> SceneLayout:
        checked = self.checked
        joints = self.joint_plan()
        order = self._order()
        lanes = [self.ws.lane_y, -self.ws.lane_y - 0.02, 0.0]
        statics = [n for n in order if not self.geom(n).free]
        for k, name in enumerate(statics):
            self._place_static(name, joints, lanes[k % len(lanes)], alone=len(statics) == 1 and len(order) == 1)
        for step in self.checked.steps:
            if step.relation is not None:
                self._reserve_beside(step.object, step.required_target(), step.relation)
        for name in order:
            if name in self.out.placed or not self.geom(name).free:
                continue
            first = next((s for s in self._steps_on(name) if s.object == name), None)
            if first is not None and first.source is not None:
                self._place_on_source(name, first.source, joints)
            elif first is not None and first.action not in INSTRUMENT_ACTIONS:
                rack = self._rack_for(name)
                if rack is not None:
                    self._place_on_source(name, rack, joints)
        free = [n for n in order if n not in self.out.placed]
        for k, name in enumerate(free):
            role = checked.objects[name].spec.role
            y = -self.ws.lane_y if role != "distractor" else 0.0
            x = self.ws.center_x - 0.06 if role != "distractor" else self.ws.center_x + 0.12
            if role in ("destination", "target", "source"):
                x, y = self.ws.center_x + 0.05, self.ws.lane_y
            x, y = self._relation_start(name) or (x, y)
            self._place_free(name, (x, y - 0.1 * k * (1 if y <= 0 else -1)))
        for (name, joint), value in joints.items():
            comment = (
                "shut at reset (0)"
                if value == 0.0
                else f"open at reset: {OPEN_FRACTION:.0%} of its limit; VERIFY it stays open by itself"
                if value == open_value(self.geom(name).joints[joint])
                else "open at reset where its release button leaves it (lid_open_angle_deg)"
            )
            self.out.joint_states.append((f"{name}/{joint}", r(value, 3), comment))
        return self.out

    def _reserve_beside(self, item: str, ref: str, relation: str) -> None:
        """Place the reference of a relation (if not yet) and keep a free spot beside it for ``item``."""
        if ref not in self.out.placed:  # off the holder the item starts in (inside the region: trivial)
            start = self._relation_start(ref) or (self.ws.center_x, 0.0)
            self._place_free(ref, start, away=self._holder_clear(item, ref) or self.clear_of)
        placed = self.out.placed[ref]
        placed.randomize = None  # the region beside it is fixed in the bench frame
        boxes = self.geoms.get(ref, self.geom(ref)).boxes + np.array([*placed.pos, *placed.pos])
        found = self.layout.beside(measure_asset(self.checked.asset(item)).boxes, boxes, relation, self.ws.bench_z)
        if found is None:
            raise PlanError(
                f"impossible layout: no free spot on the bench within reach {relation.replace('_', ' ')} the "
                f"{self.human(ref)}; "
                "try another side or fewer objects"
            )
        self.out.beside[item] = found
        ref_boxes = self.geoms.get(ref, self.geom(ref)).boxes
        reach = float(np.hypot(*(0.5 * (ref_boxes[:, 3:5].max(axis=0) - ref_boxes[:, :2].min(axis=0)))))
        self.clear_of = ((placed.pos[0], placed.pos[1]), reach + BESIDE_CLEAR)

    def _holder_clear(self, item: str, ref: str) -> tuple[tuple[float, float], float] | None:
        """``(place, distance)`` the reference of a relation keeps from the holder ``item`` starts in."""
        first = next((s for s in self._steps_on(item) if s.object == item), None)
        holder = first.source if first is not None else None
        if holder is None or holder not in self.out.placed:
            return None
        pos = self.out.placed[holder].pos
        reach = float(np.hypot(*self.geom(ref).half_xy) + np.hypot(*self.geom(holder).half_xy))
        return (pos[0], pos[1]), reach + BESIDE_CLEAR

    def _relation_start(self, name: str) -> tuple[float, float] | None:
        """Where the reference of a relation ("left of the beaker") starts: room on that side within reach."""
        side = next((s.relation for s in self.checked.steps if s.target == name and s.relation), None)
        if side is None:
            return None
        x, y = RELATION_START.get(side, (0.0, 0.0))
        return self.ws.center_x + x, y * self.ws.lane_y

    def _order(self) -> list[str]:
        """Instruments and holders first (the most constrained), then items, then distractors."""
        names = list(self.checked.objects)
        rank = {"instrument": 0, "destination": 1, "source": 1, "target": 2, "item": 3, "distractor": 4}
        return sorted(names, key=lambda n: (rank[self.checked.objects[n].spec.role], names.index(n)))

    def _keys(self, name: str, geom: AssetGeometry) -> tuple[list[tuple[float, float]], bool]:
        """Key points of a static object: the sites its steps work at (a handle where it is when shut);
        and whether a button is pressed."""
        keys: list[tuple[float, float]] = []
        pressed = False
        closed = measure_asset(self.checked.asset(name))
        for step in self._steps_on(name):
            if step.action == "open" and step.object == name and self._released(name):
                keys.append(geom.sites["button"][:2])  # a latched lid: its release button is pressed
                pressed = True
            elif step.action in ("open", "close") and step.object == name:
                keys += [closed.sites[h][:2] for h in HANDLES if h in closed.sites]  # where the hand takes it shut
                keys += lid_points(geom, opening=step.action == "open")
            elif step.action == "press":
                keys.append(geom.sites["button"][:2])
                pressed = True
            elif step.action in BUTTON_SITES:  # its start or tare button
                keys.append(geom.sites[BUTTON_SITES[step.action]][:2])
                pressed = True
            else:
                site = receiving_site(geom, step.part if name == step.target else None, self.checked.asset(step.object))
                if site == "slot_grid":
                    slots = np.array([v for k, v in geom.sites.items() if k.startswith("slot_")])
                    keys.append(tuple(slots[:, :2].mean(axis=0)))
                elif site is not None:
                    keys.append(geom.sites[site][:2])
        return keys, pressed

    def open_to_close(self, name: str, geom: AssetGeometry, joint: JointInfo) -> float:
        """Where a part a step closes starts: a latched lid at the angle its release pops it to, when
        its friction holds it there (the arm reaches over it; near its limit a back-hinged lid stands
        past upright, out of reach behind the hinge), else near its open limit."""
        release = self.release(name, geom, joint)
        return release if release is not None else open_value(joint)

    def release(self, name: str, geom: AssetGeometry, joint: JointInfo) -> float | None:
        """The angle a latched lid pops open to when its release button is pressed
        (:func:`~.motors.release_angle`), or near its limit (:data:`RELEASE_FAR`), where its friction
        holds it open; else ``None`` (the lid is worked by hand)."""
        angle = release_angle(geom, joint)
        if angle is None:
            return None
        for candidate in (angle, r(RELEASE_FAR * joint.open_limit)):  # near its limit, as protocols do
            if holds_open(self.checked.asset(name), joint.name, candidate):
                return candidate
        return None

    def _released(self, name: str) -> bool:
        """Whether ``name`` has a latched lid its release button opens (:meth:`release`)."""
        geom = self.geom(name)
        return "lid_hinge" in geom.joints and self.release(name, geom, geom.joints["lid_hinge"]) is not None

    def _place_static(self, name: str, joints: dict[tuple[str, str], float], lane: float, alone: bool) -> None:
        asset = self.checked.asset(name)
        states = [(j, v) for (o, j), v in joints.items() if o == name]
        geom = measure_asset(asset, tuple(states))
        shut = measure_asset(asset).boxes  # as it is when a button is pressed: instruments run shut
        boxes = [geom.boxes, shut]
        for joint in movable_joints(geom):  # every state the task visits: closed and open
            if any(j == joint.name for j, _ in states):
                boxes.append(measure_asset(asset, ((joint.name, open_value(joint)),)).boxes)
        keys, pressed = self._keys(name, geom)
        preferred = self._relation_start(name) or (
            self.ws.center_x - (0.08 if alone else -0.05),
            0.0 if alone else lane,
        )
        lid = separate_lid(geom) if not geom.joints else None
        hatch = [s.action for s in self.checked.steps if s.object == name and s.action in ("open", "close")]
        if lid and hatch:
            lid_geom = measure_asset(lid)
            seat = geom.sites.get("lid_seat", (0.0, 0.0, float(geom.high[2])))
            boxes.append(lid_geom.boxes + np.array([0.0, 0.0, seat[2], 0.0, 0.0, seat[2]]))  # on its seat
            if hatch[0] == "close":  # the lid starts beside it, on the robot's right: room and reach for both
                beside = lid_beside(geom, lid_geom, LID_GAP)
                boxes.append(lid_geom.boxes + np.array([*beside, 0.0, *beside, 0.0]))
                keys.append(beside)
        fp = Footprint(np.vstack(boxes), keys, preferred, 0.02, pressed, start_boxes=geom.boxes, press_boxes=shut)
        spot = self.layout.place(fp, self.ws.bench_z)
        if spot is None:
            raise self._no_room(name)
        self.out.placed[name] = PlacedObject(
            name,
            asset,
            (spot[0], spot[1], self.ws.bench_z),
            randomize={"xy": (START_XY, START_XY)},
            comment="VERIFY the layout (pipette sim render): placed within reach by pipette new-task",
        )
        self.geoms[name] = geom
        if lid:
            self._place_lid(name, geom, lid)

    def _place_lid(self, name: str, geom: AssetGeometry, lid: str) -> None:
        """A lift-off lid: on its seat when a step opens it, beside the instrument when one closes it."""
        steps = [s for s in self.checked.steps if s.object == name and s.action in ("open", "close")]
        if not steps:
            return
        lid_name = "lid" if "lid" not in self.checked.objects else f"{name}_lid"
        self.out.lids[name] = lid_name
        lid_geom = measure_asset(lid)
        if steps[0].action == "open":
            seat = geom.sites["lid_seat"]
            base = self.out.placed[name].pos
            pos = (r(base[0] + seat[0]), r(base[1] + seat[1]), r(base[2] + seat[2], 4))
            self.out.placed[name].randomize = None
            self.out.placed[lid_name] = PlacedObject(
                lid_name, lid, pos, comment=f"on {name}/lid_seat; VERIFY it rests on the rim"
            )
            return
        base, (dx, dy) = self.out.placed[name].pos, lid_beside(geom, lid_geom, LID_GAP)  # room kept for it
        self.out.placed[lid_name] = PlacedObject(
            lid_name,
            lid,
            (r(base[0] + dx), r(base[1] + dy), r(self.ws.bench_z + lid_geom.origin_height + 0.001, 4)),
            randomize={"xy": (START_XY, START_XY), "yaw_deg": 5},
            comment="lid beside it; VERIFY reachable",
        )

    def _rack_for(self, name: str) -> str | None:
        """A rack for an item that cannot stand on the bench by itself (not the scene's own where
        another fits), added to the scene (its name), or ``None`` when it stands or none fits."""
        asset = self.checked.asset(name)
        if stands_alone(asset):
            return None
        vocab = load_vocabulary()
        racks = [
            a for a in holders_that_fit(vocab, asset) if any(k.startswith("slot_") for k in measure_asset(a).sites)
        ]
        if not racks:
            return None
        used = {self.checked.asset(n) for n in self.checked.objects} | set(self.added.values())
        _, rack = choose_pair(vocab, [asset], [a for a in racks if a not in used] or racks)  # "the rack" stays one
        rack_name = f"{name}_rack"
        self.added[rack_name] = rack
        reason = f"the {self.human(name)} cannot stand on the bench by itself: it starts here"
        self._place_free(rack_name, (self.ws.center_x, -self.ws.lane_y), asset=rack, comment=reason)
        return rack_name

    def _place_free(
        self,
        name: str,
        preferred: tuple[float, float],
        asset: str | None = None,
        comment: str = "VERIFY reachable: placed by pipette new-task",
        away: tuple[tuple[float, float], float] | None = None,
    ) -> None:
        """Place ``name`` near ``preferred``, off ``away`` (a relation's region by default)."""
        asset = asset or self.checked.asset(name)
        geom = measure_asset(asset)
        amp = 0.02 if self.ws.max_reach < 0.6 else 0.03
        hx, hy = geom.half_xy
        round_ = geom.semantics.get("upright", True) and abs(hx - hy) < 0.2 * max(hx, hy)
        randomize: dict[str, Any] = {"xy": (amp, amp), "yaw_deg": 180 if round_ else 15}
        key = [geom.sites["grasp"][:2]] if "grasp" in geom.sites else [(0.0, 0.0)]
        footprint = Footprint(geom.boxes, key, preferred, margin=amp)
        spot = self.layout.place(footprint, self.ws.bench_z, away=away or self.clear_of)
        if spot is None:
            raise self._no_room(name)
        z = r(self.ws.bench_z + geom.origin_height + 0.001, 4)
        self.out.placed[name] = PlacedObject(
            name,
            asset,
            (spot[0], spot[1], z),
            geom.rest_euler_deg,
            randomize,
            comment,
        )
        self.geoms[name] = geom

    def _place_on_source(self, name: str, source: str, joints: dict[tuple[str, str], float]) -> None:
        """Start ``name`` in or on ``source`` (a rack slot, a shelf, a pan)."""
        if source not in self.out.placed:
            self._place_free(source, (self.ws.center_x, -self.ws.lane_y))
        holder = self.out.placed[source]
        holder.randomize = None  # what starts on it must stay where it was put
        states = tuple((j, v) for (o, j), v in joints.items() if o == source)
        sgeom = measure_asset(holder.asset, states)
        site = receiving_site(sgeom, None, self.checked.asset(name))
        if site is None or site == "opening":
            raise PlanError(
                f"impossible request: the {self.human(source)} has no surface or slot the "
                f"{self.human(name)} can start on"
            )
        item = measure_asset(self.checked.asset(name))
        if site == "slot_grid":
            site = self.pick_slot(source, sgeom)
            local = sgeom.sites[site]
            pos = (r(holder.pos[0] + local[0]), r(holder.pos[1] + local[1]), r(holder.pos[2] + local[2] + 0.001, 4))
            euler = (0.0, 0.0, 0.0)  # standing in its hole, whatever pose it rests in on a bench
            boxes = measure_asset(self.checked.asset(name), standing=True).boxes
        else:
            local = sgeom.sites[site]
            cx, cy = (0.5 * (item.low[:2] + item.high[:2])).tolist()
            pos = (
                r(holder.pos[0] + local[0] - cx),
                r(holder.pos[1] + local[1] - cy),
                r(holder.pos[2] + local[2] + item.origin_height + 0.001, 4),
            )
            euler, boxes = item.rest_euler_deg, item.boxes
        self.out.placed[name] = PlacedObject(
            name, self.checked.asset(name), pos, euler, None, f"starts in/on {source}/{site}; VERIFY it settles there"
        )
        self.out.start_site[name] = (source, site)
        self.layout.add_obstacle(boxes, pos)

    def pick_slot(self, holder: str, geom: AssetGeometry) -> str:
        """A free slot of a rack near the middle of its grid."""
        slots = {k: np.asarray(v) for k, v in geom.sites.items() if k.startswith("slot_")}
        used = self.out.slots_used.setdefault(holder, [])
        middle = np.mean(list(slots.values()), axis=0)
        free = sorted(
            (k for k in slots if k not in used), key=lambda k: (float(np.linalg.norm(slots[k][:2] - middle[:2])), k)
        )
        if not free:
            raise PlanError(f"the {self.human(holder)} has no free slot left")
        used.append(free[0])
        return free[0]

    def _no_room(self, name: str) -> PlanError:
        return PlanError(
            f"impossible layout: found no place for the {self.human(name)} on the bench within the {self.robot}'s"
            f" comfortable reach ({self.ws.min_reach:.2f}-{self.ws.max_reach:.2f} m) clear of the robot "
            "and the other objects; try fewer objects or another robot ('with the UR5e')",
            robot_limit=True,
        )
