"""Instruments with moving parts: centrifuges, incubator, water bath, spectrophotometer, balance...

Conventions shared with the task registry: the robot stands at -x looking toward +x, so
fronts (doors, buttons, displays) face -x; hinges of top lids are at the back (+x). The
base is static; moving parts are child bodies with limited joints. Driven mechanisms carry
an ``MjcActuator`` position servo plus the equivalent ``UsdPhysics`` drive.
"""

from __future__ import annotations

import math
from functools import partial

from pipette_cli.assets import geometry as g
from pipette_cli.assets import parts as p
from pipette_cli.assets.generators import register
from pipette_cli.assets.model import AssetDef, Body, Joint, Material, PositionDrive

CATEGORY = "instruments"
CASE = Material("instrument_case", (0.90, 0.91, 0.92), roughness=0.4)
ACCENT = Material("instrument_accent", (0.20, 0.42, 0.70), roughness=0.4)
SMOKED = Material("smoked_window", (0.15, 0.18, 0.22), opacity=0.55, roughness=0.1)


def _asset(asset_id: str, description: str, bodies: list[Body], **kw) -> AssetDef:
    return AssetDef(asset_id, CATEGORY, description, bodies, static=kw.pop("static", True), **kw)


def _button_x(body: Body, name: str, pos: tuple[float, float, float], radius: float, material: Material) -> None:
    """A round push button on a front (-x) face, protruding 4 mm, with a site at its face."""
    p.solid_cylinder_x(body, name, radius, 0.008, (pos[0] - 0.0, pos[1], pos[2]), material)
    p.site(body, name, (pos[0] - 0.004, pos[1], pos[2]))


def centrifuge(asset_id: str, description: str, depth: float, width: float, height: float, base_mass: float, lid_mass: float,
               rotor_r: float, kp: float = 200.0, kv: float = 20.0, hinge_friction: float = 0.0, *, rotor_h: float = 0.03,
               wells: int = 8, well_r: float = 0.0065, well_depth: float = 0.015, tube_ml: float = 1.5) -> AssetDef:
    """Top-loading centrifuge: a bowl in a case, a rotor with ``wells`` vertical tube wells (sites
    ``well_0..``, at their floor), a lid hinged at the back, a red lid-release button and a green
    start button on the front console."""
    base = Body("base", base_mass)
    panel = 0.035
    x0, x1 = -depth / 2 + panel, depth / 2
    cx = (x0 + x1) / 2
    floor_h, wall = height * 0.38, 0.035
    p.solid_box(base, "case_lower", (x1 - x0, width, floor_h), (cx, 0, floor_h / 2), CASE, 0.02)
    wall_h = height - floor_h
    zc = floor_h + wall_h / 2
    p.solid_box(base, "wall_front", (wall, width, wall_h), (x0 + wall / 2, 0, zc), CASE)
    p.solid_box(base, "wall_back", (wall, width, wall_h), (x1 - wall / 2, 0, zc), CASE)
    p.solid_box(base, "wall_left", (x1 - x0 - 2 * wall, wall, wall_h), (cx, -width / 2 + wall / 2, zc), CASE)
    p.solid_box(base, "wall_right", (x1 - x0 - 2 * wall, wall, wall_h), (cx, width / 2 - wall / 2, zc), CASE)
    p.visual(base, "bowl", g.box((x1 - x0 - 2 * wall, width - 2 * wall, 0.002), (cx, 0, floor_h + 0.001)), p.STEEL)
    # the rotor: a plate under the wells, a hub between them and a wall round each well (a tube stands in it)
    top, ring = floor_h + rotor_h, 0.7 * rotor_r
    well_floor = top - well_depth
    p.visual(base, "rotor", g.cylinder(rotor_r, rotor_h, (cx, 0, floor_h + rotor_h / 2), 36), p.ALUMINIUM)
    p.cylinder_collider(base, "rotor_plate_col", rotor_r, well_floor - floor_h, (cx, 0, (floor_h + well_floor) / 2))
    hub = ring - well_r - 0.003
    p.cylinder_collider(base, "rotor_hub_col", hub, well_depth, (cx, 0, well_floor + well_depth / 2))
    centres = [(cx + ring * math.cos(a), ring * math.sin(a)) for a in (2 * math.pi * (k + 0.5) / wells for k in range(wells))]
    for k, (x, y) in enumerate(centres):
        p.ring_colliders(base, f"well_{k}_wall", well_r, well_r + 0.003, well_floor, top, 8, (x, y))
        p.site(base, f"well_{k}", (x, y, well_floor), 0.003)
    holes = g.merge([g.cylinder(well_r, 0.001, (x, y, top + 0.0005), 16) for x, y in centres])
    p.visual(base, "rotor_holes", holes, p.DARK_PLASTIC)
    console_h = height * 0.55
    p.solid_box(base, "console", (panel, width, console_h), (-depth / 2 + panel / 2, 0, console_h / 2), CASE, 0.005)
    p.visual(base, "display", g.box((0.002, width * 0.3, console_h * 0.3), (-depth / 2 - 0.001, -width * 0.15, console_h * 0.6)), p.SCREEN)
    _button_x(base, "button", (-depth / 2 - 0.004, width * 0.25, console_h * 0.6), 0.011, p.RED_PLASTIC)
    _button_x(base, "start_button", (-depth / 2 - 0.004, -width * 0.38, console_h * 0.6), 0.009, p.GREEN_PLASTIC)
    p.site(base, "rotor_center", (cx, 0, top))
    lid_t = 0.03
    hinge = (x1, 0.0, height)
    lid = Body("lid", lid_mass, pos=hinge)
    length = x1 - x0 + 0.002
    p.solid_box(lid, "lid_shell", (length, width, lid_t), (-length / 2, 0, lid_t / 2), ACCENT, 0.02)
    p.visual(lid, "lid_window", g.box((length * 0.45, width * 0.5, 0.002), (-length * 0.55, 0, lid_t + 0.001), 0.02), SMOKED)
    p.site(lid, "lid_handle", (-length, 0, lid_t / 2))
    # friction holds a part-open lid against gravity, like the gas strut of a real centrifuge
    joint = Joint("lid_hinge", "revolute", "base", "lid", anchor=hinge, axis="-y", lower=-100.0, upper=0.0, damping=0.5,
                  friction=hinge_friction, armature=0.01)
    # kv * timestep must stay well below the lid's inertia about the hinge (explicit Euler)
    drive = PositionDrive("lid_drive", "lid_hinge", kp=kp, kv=kv, max_force=1000.0, ctrl_range=(math.radians(-100), 0.0))
    extra = {"lid_open_angle_deg": -40.0, "lid_closed_angle_deg": 0.0, "button_trigger_radius": 0.02,
             "rotor_wells": float(wells), "well_diameter": 2 * well_r, "well_depth": well_depth, "tube_ml": tube_ml}
    return _asset(asset_id, description, [base, lid], joints=[joint], drives=[drive], extra=extra)


register("centrifuge_benchtop", CATEGORY, partial(
    centrifuge, "centrifuge_benchtop",
    "Benchtop centrifuge: lid hinged at the back (lid_hinge, 0 closed, opens negative to -100 deg) held by a position servo (lid_drive); "
    "rotor with 4 wells for 50 mL tubes (well_0..3); red lid-release button and green start button on the front console.",
    0.52, 0.42, 0.30, 32.0, 1.6, 0.14, hinge_friction=3.2, wells=4, well_r=0.0155, well_depth=0.025, tube_ml=50.0))
register("microcentrifuge", CATEGORY, partial(
    centrifuge, "microcentrifuge",
    "Microcentrifuge: hinged lid with servo (lid_hinge, opens negative), rotor with 8 vertical wells for 1.5/2 mL tubes "
    "(well_0..7, 25 mm deep) whose caps stay under the lid; red lid-release button and green start button on the front.",
    0.30, 0.25, 0.13, 6.5, 0.35, 0.09, 20.0, 1.0, rotor_h=0.051, well_depth=0.025))


def incubator() -> AssetDef:
    base = Body("base", 38.0)
    d, w, h, t = 0.50, 0.50, 0.72, 0.04
    x0, x1 = -d / 2, d / 2
    p.solid_box(base, "floor", (d, w, 0.06), (0, 0, 0.03), CASE)
    p.solid_box(base, "roof", (d, w, t), (0, 0, h - t / 2), CASE)
    p.solid_box(base, "back", (t, w, h - 0.06 - t), (x1 - t / 2, 0, (h + 0.06 - t) / 2), CASE)
    for side, y in (("left", -w / 2 + t / 2), ("right", w / 2 - t / 2)):
        p.solid_box(base, f"side_{side}", (d - t, t, h - 0.06 - t), (-t / 2, y, (h + 0.06 - t) / 2), CASE)
    p.visual(base, "chamber_liner", g.box((0.002, w - 2 * t, h - 0.06 - t), (x1 - t - 0.001, 0, (h + 0.06 - t) / 2)), p.STEEL)
    shelves = (0.20, 0.50)  # 0.30 m apart: a robot's wrist fits above a dish on the lower shelf
    for k, top in enumerate(shelves):
        p.solid_box(base, f"shelf_{k}", (d - t - 0.03, w - 2 * t - 0.004, 0.006), (-t / 2 - 0.005, 0, top - 0.003), p.STEEL)
        p.site(base, f"shelf_{k}_center", (-0.03, 0, top))
    p.visual(base, "nameplate", g.box((0.002, 0.16, 0.03), (x0 - 0.001, 0.10, h - 0.02)), ACCENT)
    door = Body("door", 4.5, pos=(x0, -w / 2, 0.0))
    p.solid_box(door, "door_panel", (0.03, w, h - 0.01), (-0.015, w / 2, h / 2), CASE, 0.01)
    p.visual(door, "door_display", g.box((0.002, 0.12, 0.06), (-0.031, w * 0.35, h * 0.8)), p.SCREEN)
    p.solid_box(door, "handle_bar", (0.02, 0.02, 0.20), (-0.06, w - 0.05, h / 2), p.ALUMINIUM)
    for k, dz in enumerate((-0.08, 0.08)):
        p.solid_box(door, f"handle_post_{k}", (0.03, 0.015, 0.015), (-0.04, w - 0.05, h / 2 + dz), p.ALUMINIUM)
    p.site(door, "door_handle", (-0.07, w - 0.05, h / 2))
    joint = Joint("door_hinge", "revolute", "base", "door", anchor=(x0, -w / 2, 0.0), axis="z", lower=0.0, upper=110.0,
                  damping=1.0, friction=0.4, armature=0.02)
    extra = {"shelf_heights": shelves, "shelf_size": (d - t - 0.03, w - 2 * t - 0.004), "opening_size": (w - 2 * t, h - 0.06 - t)}
    return _asset("incubator_benchtop",
                  "Benchtop CO2 incubator: front door hinged at its left edge (door_hinge, 0 closed, opens positive to 110 deg), two steel shelves for dishes.",
                  [base, door], joints=[joint], extra=extra)


register("incubator_benchtop", CATEGORY, incubator)

BATH = {"depth": 0.30, "width": 0.35, "height": 0.22, "wall": 0.02, "lip": 0.015}


def water_bath() -> AssetDef:
    d, w, h, t = BATH["depth"], BATH["width"], BATH["height"], BATH["wall"]
    base = Body("base", 9.0)
    p.open_box(base, "tank", (d, w, h), t, 0.03, p.STEEL)
    p.visual(base, "water", g.box((d - 2 * t, w - 2 * t, 0.12), (0, 0, 0.09)), p.WATER)
    p.solid_box(base, "control_panel", (0.03, 0.22, 0.10), (-d / 2 - 0.015, 0, 0.07), CASE, 0.005)
    p.visual(base, "panel_display", g.box((0.002, 0.06, 0.025), (-d / 2 - 0.031, -0.05, 0.08)), p.SCREEN)
    p.solid_cylinder_x(base, "knob", 0.012, 0.015, (-d / 2 - 0.037, 0.06, 0.08), p.DARK_PLASTIC)
    p.site(base, "lid_seat", (0, 0, h - BATH["lip"]))
    p.site(base, "water_surface", (0, 0, 0.15))
    return _asset("water_bath", "Digital water bath, 6 L stainless tank; its lift-off lid is the separate asset water_bath_lid (place it at site lid_seat).",
                  [base], extra={"inner_size": (d - 2 * t, w - 2 * t), "rim_height": h, "lid_seat_height": h - BATH["lip"]})


def water_bath_lid() -> AssetDef:
    d, w, t, lip = BATH["depth"], BATH["width"], BATH["wall"], BATH["lip"]
    body = Body("body", 0.8)
    plate_t = 0.006
    p.solid_box(body, "plate", (d + 0.01, w + 0.01, plate_t), (0, 0, lip + plate_t / 2), p.STEEL, 0.01)
    inner_x, inner_y, lw = d - 2 * t - 0.004, w - 2 * t - 0.004, 0.004
    for name, size, pos in (("lip_xn", (lw, inner_y, lip), (-inner_x / 2 + lw / 2, 0, lip / 2)), ("lip_xp", (lw, inner_y, lip), (inner_x / 2 - lw / 2, 0, lip / 2)),
                            ("lip_yn", (inner_x, lw, lip), (0, -inner_y / 2 + lw / 2, lip / 2)), ("lip_yp", (inner_x, lw, lip), (0, inner_y / 2 - lw / 2, lip / 2))):
        p.solid_box(body, name, size, pos, p.STEEL)
    top = lip + plate_t
    for k, y in enumerate((-0.05, 0.05)):
        p.solid_box(body, f"handle_post_{k}", (0.012, 0.012, 0.03), (0, y, top + 0.015), p.DARK_PLASTIC)
    p.solid_box(body, "handle_bar", (0.02, 0.13, 0.012), (0, 0, top + 0.036), p.DARK_PLASTIC, 0.004)
    p.site(body, "lid_handle", (0, 0, top + 0.036))  # the bar's middle: the pads take its whole height
    return AssetDef("water_bath_lid", CATEGORY, "Lift-off stainless lid of water_bath with a top handle; its lip sits inside the tank rim.",
                    [body], graspable=True, static=False, extra={"plate_size": (d + 0.01, w + 0.01), "lip_height": lip})


register("water_bath", CATEGORY, water_bath)
register("water_bath_lid", CATEGORY, water_bath_lid)


def spectrophotometer() -> AssetDef:
    base = Body("base", 8.0)
    d, w, h = 0.36, 0.30, 0.11
    p.solid_box(base, "case_lower", (d, w, 0.05), (0, 0, 0.025), CASE, 0.015)
    # upper layer around an open sample compartment (x 0..0.12, y 0.03..0.12)
    cx0, cx1, cy0, cy1 = 0.0, 0.12, 0.03, 0.12
    for name, (xa, xb, ya, yb) in {
        "upper_front": (-d / 2, cx0, -w / 2, w / 2), "upper_back": (cx1, d / 2, -w / 2, w / 2),
        "upper_left": (cx0, cx1, -w / 2, cy0), "upper_right": (cx0, cx1, cy1, w / 2),
    }.items():
        p.solid_box(base, name, (xb - xa, yb - ya, h - 0.05), ((xa + xb) / 2, (ya + yb) / 2, (h + 0.05) / 2), CASE)
    slot = ((cx0 + cx1) / 2, (cy0 + cy1) / 2)
    hole, wall, hold_h = 0.0135, 0.005, 0.025
    for name, size, off in (("holder_xn", (wall, hole + 2 * wall, hold_h), (-(hole + wall) / 2, 0)), ("holder_xp", (wall, hole + 2 * wall, hold_h), ((hole + wall) / 2, 0)),
                            ("holder_yn", (hole, wall, hold_h), (0, -(hole + wall) / 2)), ("holder_yp", (hole, wall, hold_h), (0, (hole + wall) / 2))):
        p.solid_box(base, name, size, (slot[0] + off[0], slot[1] + off[1], 0.05 + hold_h / 2), p.DARK_PLASTIC)
    p.site(base, "cuvette_slot", (slot[0], slot[1], 0.05))
    screen = g.box((0.11, 0.15, 0.012), (0, 0, 0)).moved((-0.11, -0.05, h + 0.02), g.rotation("y", -25))
    p.visual(base, "display", screen, p.SCREEN)
    p.box_collider(base, "display_col", (0.10, 0.15, 0.03), (-0.11, -0.05, h + 0.015))
    p.visual(base, "keypad", g.box((0.06, 0.09, 0.004), (-0.14, 0.08, h + 0.002)), p.GREY_PLASTIC)
    _button_x(base, "start_button", (-d / 2 - 0.004, 0.08, 0.03), 0.008, p.GREEN_PLASTIC)
    hinge = (cx1 + 0.01, slot[1], h)
    lid = Body("lid", 0.15, pos=hinge)
    length = cx1 + 0.01 - cx0 + 0.01
    p.solid_box(lid, "lid_shell", (length, cy1 - cy0 + 0.02, 0.014), (-length / 2, 0, 0.007), p.DARK_PLASTIC, 0.006)
    p.site(lid, "lid_handle", (-length, 0, 0.007))
    joint = Joint("lid_hinge", "revolute", "base", "lid", anchor=hinge, axis="y", lower=0.0, upper=110.0, damping=0.05, friction=0.15)
    return _asset("spectrophotometer",
                  "UV-Vis spectrophotometer with a single-cuvette compartment; its lid is hinged at the back (lid_hinge, 0 closed, "
                  "opens positive to 110 deg); a start button on the front.",
                  [base, lid], joints=[joint], extra={"lid_open_angle_deg": 110.0, "cuvette_size": (0.0125, 0.0125)})


register("spectrophotometer", CATEGORY, spectrophotometer)


def electronic_balance() -> AssetDef:
    base = Body("base", 4.2)
    d, w, h = 0.32, 0.22, 0.07
    p.solid_box(base, "case", (d, w, h), (0, 0, h / 2), CASE, 0.02)
    for k, (x, y) in enumerate(((-0.13, -0.09), (0.13, -0.09), (-0.13, 0.09), (0.13, 0.09))):
        p.visual(base, f"foot_{k}", g.cylinder(0.01, 0.004, (x, y, -0.0), 12).moved((0, 0, 0.002)), p.RUBBER)
    display = g.box((0.05, 0.16, 0.03), (0, 0, 0)).moved((-0.135, 0, h + 0.01), g.rotation("y", -30))
    p.visual(base, "display_housing", display, CASE)
    p.visual(base, "display", g.box((0.002, 0.09, 0.016), (-0.153, 0, h + 0.012)), p.SCREEN)
    p.box_collider(base, "display_col", (0.05, 0.16, 0.02), (-0.135, 0, h + 0.01))
    _button_x(base, "tare_button", (-d / 2 - 0.004, 0.06, 0.035), 0.008, p.BLUE_PLASTIC)
    pan_x, pan_r, pan_top = 0.03, 0.065, 0.09
    p.solid_cylinder(base, "pan_support", 0.012, pan_top - 0.006 - h, (pan_x, 0, (h + pan_top - 0.006) / 2), p.STEEL)
    pan = Body("pan", 0.25, pos=(pan_x, 0, pan_top - 0.006))
    p.solid_cylinder(pan, "pan_plate", pan_r, 0.006, (0, 0, 0.003), p.STEEL, 48)
    p.site(pan, "pan_center", (0, 0, 0.006))
    joint = Joint("pan_mount", "fixed", "base", "pan", anchor=(pan_x, 0, pan_top - 0.006))
    return _asset("electronic_balance", "Precision electronic balance (620 g x 1 mg) with a round 130 mm stainless weighing pan and a tare button on its front.",
                  [base, pan], joints=[joint],
                  extra={"pan_size": (2 * pan_r, 2 * pan_r), "pan_shape": "round", "pan_height": pan_top, "capacity_kg": 0.62, "readability_kg": 1e-6})


register("electronic_balance", CATEGORY, electronic_balance)


def orbital_shaker() -> AssetDef:
    base = Body("base", 14.0)
    d, w, h = 0.38, 0.34, 0.09
    p.solid_box(base, "case", (d, w, h), (0, 0, h / 2), CASE, 0.02)
    p.visual(base, "display", g.box((0.002, 0.07, 0.025), (-d / 2 - 0.001, -0.06, 0.05)), p.SCREEN)
    p.solid_cylinder_x(base, "speed_knob", 0.013, 0.016, (-d / 2 - 0.008, 0.07, 0.05), p.DARK_PLASTIC)
    p.solid_cylinder(base, "drive_column", 0.03, 0.012, (0, 0, h + 0.006), p.DARK_PLASTIC)
    size, plate_t, rim = 0.30, 0.012, 0.012
    platform = Body("platform", 2.0, pos=(0, 0, h + 0.012))
    p.solid_box(platform, "plate", (size, size, plate_t), (0, 0, plate_t / 2), p.ALUMINIUM, 0.01)
    p.solid_box(platform, "mat", (size - 0.02, size - 0.02, 0.002), (0, 0, plate_t + 0.001), p.RUBBER)
    for name, sz, pos in (("rim_xn", (0.008, size, rim), (-size / 2 + 0.004, 0, plate_t + rim / 2)), ("rim_xp", (0.008, size, rim), (size / 2 - 0.004, 0, plate_t + rim / 2)),
                          ("rim_yn", (size - 0.016, 0.008, rim), (0, -size / 2 + 0.004, plate_t + rim / 2)), ("rim_yp", (size - 0.016, 0.008, rim), (0, size / 2 - 0.004, plate_t + rim / 2))):
        p.solid_box(platform, name, sz, pos, p.GREY_PLASTIC)
    p.site(platform, "platform_center", (0, 0, plate_t + 0.002))
    joint = Joint("platform_mount", "fixed", "base", "platform", anchor=(0, 0, h + 0.012))
    top = h + 0.012 + plate_t + 0.002
    return _asset("orbital_shaker", "Orbital shaker with a 30 x 30 cm rubber-matted platform and low rims (platform welded; orbit is a runtime effect).",
                  [base, platform], joints=[joint],
                  extra={"platform_size": (size - 0.016, size - 0.016), "platform_height": top, "orbit_diameter": 0.019, "speed_rpm_max": 500.0})


register("orbital_shaker", CATEGORY, orbital_shaker)


def vortex_mixer() -> AssetDef:
    base = Body("base", 3.6)
    outline = [(0.0, 0.0), (0.075, 0.0), (0.072, 0.06), (0.0, 0.06)]
    p.visual(base, "case", g.revolve(outline, 6).moved((0, 0, 0), g.rotation("z", 30)), Material("vortex_blue", (0.30, 0.50, 0.80), roughness=0.4))
    p.cylinder_collider(base, "case_col", 0.064, 0.06, (0, 0, 0.03))
    p.solid_cylinder_x(base, "speed_knob", 0.012, 0.014, (-0.068, 0.0, 0.03), p.DARK_PLASTIC)
    head = Body("head", 0.15, pos=(0.0, 0, 0.06))
    cup = [(0.0, 0.0), (0.025, 0.0), (0.025, 0.018), (0.012, 0.018), (0.006, 0.010), (0.0, 0.010)]
    p.visual(head, "cup", g.revolve(cup, 28), p.RUBBER)
    p.cylinder_collider(head, "cup_col", 0.025, 0.010, (0, 0, 0.005))
    p.ring_colliders(head, "cup_rim_col", 0.012, 0.025, 0.010, 0.018, 8)
    p.site(head, "cup_center", (0, 0, 0.010))
    joint = Joint("head_mount", "fixed", "base", "head", anchor=(0, 0, 0.06))
    return _asset("vortex_mixer", "Vortex mixer with a rubber cup head (touch mode); a tube is pressed into cup_center.", [base, head], joints=[joint],
                  extra={"cup_height": 0.07})


register("vortex_mixer", CATEGORY, vortex_mixer)


def thermal_cycler() -> AssetDef:
    """A 96-well block of real wells (crossing bars over a floor plate; sites ``well_a1`` .. ``well_h12``
    at their floor), a heated lid on a motor (``lid_drive``) and two front buttons: ``lid_button``
    (motorised lid) and ``start_button`` (run)."""
    base = Body("base", 10.0)
    d, w, h = 0.40, 0.26, 0.20
    p.solid_box(base, "case_lower", (d, w, 0.12), (0, 0, 0.06), CASE, 0.02)
    p.solid_box(base, "case_back", (0.16, w, h - 0.12), (d / 2 - 0.08, 0, (h + 0.12) / 2), CASE)
    block_x, floor, top = -0.03, 0.126, 0.14  # 14 mm deep wells: a 0.2 mL tube's cap stays under the heated lid
    p.visual(base, "block", g.box((0.125, 0.085, top - 0.12), (block_x, 0, (top + 0.12) / 2)), p.ALUMINIUM)
    p.box_collider(base, "block_floor_col", (0.125, 0.085, floor - 0.12), (block_x, 0, (floor + 0.12) / 2))
    pitch, hole = 0.009, 0.0066
    p.grid_bars(base, "block_grid", 12, 8, (pitch, pitch), (hole, hole), floor, top, (block_x, 0))
    span = (12 * pitch + pitch - hole, 8 * pitch + pitch - hole)
    for name, size, pos in (("xn", ((0.125 - span[0]) / 2, 0.085), (block_x - (0.125 + span[0]) / 4, 0)),
                            ("xp", ((0.125 - span[0]) / 2, 0.085), (block_x + (0.125 + span[0]) / 4, 0)),
                            ("yn", (span[0], (0.085 - span[1]) / 2), (block_x, -(0.085 + span[1]) / 4)),
                            ("yp", (span[0], (0.085 - span[1]) / 2), (block_x, (0.085 + span[1]) / 4))):
        p.box_collider(base, f"block_rim_{name}_col", (*size, top - floor), (*pos, (top + floor) / 2))
    wells = p.grid_positions(12, 8, (pitch, pitch), (block_x, 0))
    p.visual(base, "wells", g.merge([g.box((hole, hole, 0.001), (x, y, top + 0.0005)) for x, y in wells]), p.DARK_PLASTIC)
    for k, (x, y) in enumerate(wells):  # row a at the front (-x), column 1 on the robot's right (-y)
        row, col = divmod(k, 12)
        p.site(base, f"well_{'abcdefgh'[row]}{col + 1}", (x, y, floor), 0.002)
    p.visual(base, "screen", g.box((0.002, 0.16, 0.07), (-d / 2 - 0.001, 0, 0.06)), p.SCREEN)
    _button_x(base, "lid_button", (-d / 2 - 0.004, 0.105, 0.06), 0.009, p.GREY_PLASTIC)
    _button_x(base, "start_button", (-d / 2 - 0.004, -0.105, 0.06), 0.009, p.GREEN_PLASTIC)
    p.site(base, "block_center", (block_x, 0, top))
    hinge = (d / 2 - 0.16, 0, h - 0.02)
    lid = Body("lid", 1.2, pos=hinge)
    lid_len = d - 0.16
    p.solid_box(lid, "heated_lid", (lid_len, w - 0.01, 0.05), (-lid_len / 2, 0, -0.005), ACCENT, 0.015)
    p.solid_box(lid, "lid_grip", (0.02, 0.12, 0.015), (-lid_len - 0.005, 0, 0.0), p.DARK_PLASTIC)
    p.site(lid, "lid_handle", (-lid_len - 0.015, 0, 0.0))
    joint = Joint("lid_hinge", "revolute", "base", "lid", anchor=hinge, axis="y", lower=0.0, upper=100.0, damping=0.3, friction=0.8)
    drive = PositionDrive("lid_drive", "lid_hinge", kp=60.0, kv=6.0, max_force=40.0, ctrl_range=(0.0, math.radians(100)))
    return _asset("thermal_cycler", "96-well thermal cycler (PCR machine): a block of 96 wells for 0.2 mL tubes (well_a1..well_h12), "
                  "a heated lid hinged at the back (lid_hinge, opens positive) on a motor (lid_drive) worked by the lid button, "
                  "and a start button.",
                  [base, lid], joints=[joint], drives=[drive],
                  extra={"block_size": (0.125, 0.085), "well_pitch": pitch, "well_depth": top - floor,
                         "lid_open_angle_deg": 80.0, "lid_closed_angle_deg": 0.0})


register("thermal_cycler", CATEGORY, thermal_cycler)


def hot_plate_stirrer() -> AssetDef:
    base = Body("base", 4.5)
    d, w = 0.28, 0.20
    p.solid_box(base, "case", (d, w, 0.09), (0, 0, 0.045), CASE, 0.02)
    p.solid_box(base, "top_plate", (0.18, 0.18, 0.012), (0.04, 0, 0.096), Material("ceramic", (0.96, 0.96, 0.95), roughness=0.3), 0.01)
    p.site(base, "plate_center", (0.04, 0, 0.102))
    bodies, joints = [base], []
    for name, y in (("heat_knob", -0.05), ("speed_knob", 0.05)):
        knob = Body(name, 0.03, pos=(-d / 2, y, 0.045))
        p.solid_cylinder_x(knob, f"{name}_cap", 0.016, 0.018, (-0.009, 0, 0), p.DARK_PLASTIC)
        p.solid_box(knob, f"{name}_pointer", (0.004, 0.004, 0.014), (-0.019, 0, 0.006), p.WHITE_PLASTIC)
        p.site(knob, name, (-0.019, 0, 0))
        bodies.append(knob)
        joints.append(Joint(f"{name}_joint", "revolute", "base", name, anchor=(-d / 2, y, 0.045), axis="-x", lower=0.0, upper=300.0,
                            damping=0.002, friction=0.01, armature=1e-4))
    return _asset("hot_plate_stirrer", "Hot plate magnetic stirrer with ceramic top and two rotary knobs (heat_knob_joint, speed_knob_joint, 0-300 deg).",
                  bodies, joints=joints, extra={"plate_size": (0.18, 0.18), "plate_height": 0.102})


register("hot_plate_stirrer", CATEGORY, hot_plate_stirrer)


def microplate_reader() -> AssetDef:
    base = Body("base", 16.0)
    d, w, h = 0.42, 0.36, 0.22
    p.solid_box(base, "case_lower", (d, w, 0.05), (0, 0, 0.025), CASE, 0.02)
    p.solid_box(base, "case_upper", (d, w, h - 0.09), (0, 0, 0.09 + (h - 0.09) / 2), CASE, 0.02)
    p.solid_box(base, "case_back", (d - 0.2, w, 0.04), (0.1, 0, 0.07), CASE)
    for side, y in (("l", -w / 2 + 0.02), ("r", w / 2 - 0.02)):
        p.solid_box(base, f"case_side_{side}", (0.2, 0.04, 0.04), (-d / 2 + 0.1, y, 0.07), CASE)
    p.visual(base, "status_bar", g.box((0.002, 0.2, 0.01), (-d / 2 - 0.001, 0, 0.18)), ACCENT)
    _button_x(base, "drawer_button", (-d / 2 - 0.004, 0.12, 0.14), 0.009, p.GREY_PLASTIC)
    _button_x(base, "start_button", (-d / 2 - 0.004, -0.12, 0.14), 0.009, p.GREEN_PLASTIC)
    drawer = Body("drawer", 0.6, pos=(-d / 2, 0, 0.05))
    p.solid_box(drawer, "carrier", (0.16, 0.12, 0.006), (0.08, 0, 0.003), p.DARK_PLASTIC)
    p.solid_box(drawer, "front", (0.01, 0.28, 0.04), (-0.005, 0, 0.02), CASE)
    for name, size, pos in (("lip_xn", (0.004, 0.09, 0.006), (0.006, 0, 0.009)), ("lip_xp", (0.004, 0.09, 0.006), (0.14, 0, 0.009)),
                            ("lip_yn", (0.13, 0.004, 0.006), (0.073, -0.0455, 0.009)), ("lip_yp", (0.13, 0.004, 0.006), (0.073, 0.0455, 0.009))):
        p.solid_box(drawer, name, size, pos, p.DARK_PLASTIC)
    p.site(drawer, "drawer_center", (0.073, 0, 0.006))
    p.solid_box(drawer, "handle_grip", (0.025, 0.015, 0.034), (-0.0225, 0, 0.02), p.DARK_PLASTIC)  # a finger grip to pull it by
    p.site(drawer, "drawer_handle", (-0.0225, 0, 0.02))
    joint = Joint("drawer_slide", "prismatic", "base", "drawer", anchor=(-d / 2, 0, 0.05), axis="-x", lower=0.0, upper=0.16, damping=5.0)
    drive = PositionDrive("drawer_drive", "drawer_slide", kp=400.0, kv=40.0, max_force=40.0, ctrl_range=(0.0, 0.16))
    return _asset("microplate_reader", "Absorbance microplate reader with a motorised plate-carrier drawer (drawer_slide, opens positive "
                  "toward -x, 0-0.16 m; drawer_drive) worked by the drawer button, a grip on the drawer's front, and a start button.",
                  [base, drawer], joints=[joint], drives=[drive], extra={"drawer_open": 0.16, "plate_pocket": (0.13, 0.087)})


register("microplate_reader", CATEGORY, microplate_reader)
