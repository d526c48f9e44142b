"""Consumables: tubes, vials, dishes, plates, reservoirs, glassware, bottles, cuvettes, tips.

All are free rigid bodies (the scene gives them a free joint). Real sizes and masses are
from common catalogue values (empty vessels unless a fill is named).
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

from pipette_cli.assets import geometry as g
from pipette_cli.assets import parts as p
from pipette_cli.assets.generators import generator, register
from pipette_cli.assets.model import AssetDef, Body, Material

CATEGORY = "consumables"
LYING = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)  # 90 deg about x: on its side


def _asset(asset_id: str, description: str, body: Body, **kw) -> AssetDef:
    return AssetDef(asset_id, CATEGORY, description, [body], graspable=kw.pop("graspable", True), **kw)


# ----------------------------------------------------------------------------- tubes


def _tube_outer(radius: float, length: float, bottom: str, cone: float) -> list[tuple[float, float]]:
    if bottom == "conical":
        return [(0.18 * radius, 0.0), (radius, cone), (radius, length)]
    if bottom == "round":
        arc = [(radius * math.sin(math.radians(a)), radius * (1 - math.cos(math.radians(a)))) for a in (25, 45, 65, 80)]
        return [(0.35 * radius, 0.0), *arc, (radius, radius), (radius, length)]
    return [(0.96 * radius, 0.0), (radius, 0.001), (radius, length)]


def tube(
    asset_id: str,
    description: str,
    *,
    radius: float,
    length: float,
    mass: float,
    volume_ml: float,
    bottom: str = "conical",
    cone: float = 0.0,
    cap: str | None = None,
    cap_open: bool = False,
    skirt: bool = False,
    material: Material = p.CLEAR_PLASTIC,
    wall: float = 0.0008,
) -> AssetDef:
    """A tube: conical (centrifuge), round (test tube, 2 mL) or flat bottom, optional cap/skirt."""
    body = Body("body", mass)
    outer = _tube_outer(radius, length, bottom, cone)
    p.visual(body, "tube", g.revolve(p.vessel_profile(outer, wall, max(wall, 0.0015)), 28), material)
    stands = bottom != "conical" or skirt
    if bottom == "round":
        foot = 0.4 * radius
        p.cylinder_collider(body, "foot_col", 0.85 * radius, foot, (0, 0, foot / 2))
        p.cylinder_collider(body, "wall_col", radius, length - foot, (0, 0, (length + foot) / 2))
    elif bottom == "conical" and not skirt:
        p.revolved_colliders(body, "cone_col", outer[:2], 2)
        p.cylinder_collider(body, "wall_col", radius, length - cone, (0, 0, (length + cone) / 2))
    else:
        p.cylinder_collider(body, "wall_col", radius, length, (0, 0, length / 2))
    if skirt:
        ring = g.revolve([(0, 0), (radius, 0), (radius, cone * 0.9), (radius - 0.001, cone * 0.9), (radius - 0.001, 0.001), (0, 0.001)], 28)
        p.visual(body, "skirt", ring, material)
    top = length
    if cap:
        cap_mat = p.CAP_COLOURS[cap]
        cap_r, cap_h = radius * 1.14, max(0.003, min(0.014, radius * 0.9))
        if cap_open:
            hinge = g.cylinder(cap_r, cap_h * 0.5, (0, 0, 0), 24).moved((-radius - cap_r - 0.001, 0, length + 0.2 * cap_r), g.rotation("y", -80))
            p.visual(body, "cap", hinge, cap_mat)
            p.visual(body, "cap_strap", g.box((0.004, 0.004, 0.0015), (-radius - 0.001, 0, length)), cap_mat)
        else:
            p.solid_cylinder(body, "cap", cap_r, cap_h, (0, 0, length + cap_h / 2 - 0.3 * cap_h), cap_mat)
            top = length + 0.7 * cap_h
    p.site(body, "grasp", (0, 0, 0.55 * length))
    p.site(body, "top", (0, 0, top))
    p.site(body, "bottom", (0, 0, 0))
    extra = {"volume_ml": volume_ml, "outer_diameter": 2 * radius, "length": top, "has_cap": bool(cap) and not cap_open}
    return _asset(asset_id, description, body, upright=stands, rest_quat=(1.0, 0, 0, 0) if stands else LYING, extra=extra)


def pcr_strip(asset_id: str) -> AssetDef:
    body = Body("body", 0.0009)
    pitch, r, length, cone = 0.009, 0.003, 0.0205, 0.009
    outer = _tube_outer(r, length, "conical", cone)
    meshes = [g.revolve(p.vessel_profile(outer, 0.0005, 0.0012), 16).moved((x, 0, 0)) for x in [pitch * (k - 3.5) for k in range(8)]]
    p.visual(body, "tubes", g.merge(meshes), p.CLEAR_PLASTIC)
    p.solid_box(body, "caps", (8 * pitch - 0.002, 0.0075, 0.003), (0, 0, length + 0.0015), p.CLEAR_PLASTIC)
    for k in range(8):
        p.cylinder_collider(body, f"tube_{k}_col", r, length - cone, (pitch * (k - 3.5), 0, (length + cone) / 2))
    p.site(body, "grasp", (0, 0, length))
    return _asset(asset_id, "Strip of eight 0.2 mL PCR tubes with attached flat caps.", body, upright=False, rest_quat=LYING,
                  extra={"volume_ml": 0.2, "tubes": 8.0, "pitch": pitch})


_TUBES: dict[str, dict[str, Any]] = {
    "microtube_1_5ml": dict(radius=0.0054, length=0.0385, cone=0.017, mass=0.0011, volume_ml=1.5, cap="white", description="1.5 mL microcentrifuge tube, conical bottom, snap cap closed."),
    "microtube_1_5ml_open": dict(radius=0.0054, length=0.0385, cone=0.017, mass=0.0011, volume_ml=1.5, cap="white", cap_open=True, description="1.5 mL microcentrifuge tube with its snap cap open."),
    "microtube_2ml": dict(radius=0.0054, length=0.040, bottom="round", mass=0.0012, volume_ml=2.0, cap="blue", description="2 mL round-bottom microcentrifuge tube, cap closed."),
    "microtube_2ml_open": dict(radius=0.0054, length=0.040, bottom="round", mass=0.0012, volume_ml=2.0, cap="blue", cap_open=True, description="2 mL round-bottom tube with its cap open."),
    "conical_tube_15ml": dict(radius=0.0085, length=0.108, cone=0.022, mass=0.0068, volume_ml=15, cap="blue", description="15 mL conical centrifuge tube with screw cap."),
    "conical_tube_15ml_nocap": dict(radius=0.0085, length=0.108, cone=0.022, mass=0.0058, volume_ml=15, description="15 mL conical centrifuge tube without its cap."),
    "conical_tube_50ml": dict(radius=0.0145, length=0.103, cone=0.020, mass=0.0135, volume_ml=50, cap="blue", description="50 mL conical centrifuge tube with screw cap."),
    "conical_tube_50ml_nocap": dict(radius=0.0145, length=0.103, cone=0.020, mass=0.0115, volume_ml=50, description="50 mL conical centrifuge tube without its cap."),
    "conical_tube_50ml_skirted": dict(radius=0.0145, length=0.103, cone=0.020, mass=0.0145, volume_ml=50, cap="orange", skirt=True, description="Self-standing 50 mL conical tube with skirted base and screw cap."),
    "test_tube_16x150": dict(radius=0.008, length=0.150, bottom="round", mass=0.012, volume_ml=20, material=p.GLASS, wall=0.0009, description="Borosilicate glass test tube, 16 mm x 150 mm, round bottom."),
    "test_tube_13x100": dict(radius=0.0065, length=0.100, bottom="round", mass=0.0055, volume_ml=8, material=p.GLASS, wall=0.0008, description="Borosilicate glass test tube, 13 mm x 100 mm."),
    "test_tube_25x150": dict(radius=0.0125, length=0.150, bottom="round", mass=0.030, volume_ml=55, material=p.GLASS, wall=0.0012, description="Borosilicate glass test tube, 25 mm x 150 mm."),
    "cryovial_2ml": dict(radius=0.006, length=0.041, bottom="flat", mass=0.0021, volume_ml=2, cap="purple", description="2 mL self-standing cryogenic vial with external-thread cap."),
    "cryovial_5ml": dict(radius=0.0065, length=0.082, bottom="flat", mass=0.0036, volume_ml=5, cap="yellow", description="5 mL self-standing cryogenic vial."),
    "pcr_tube_0_2ml": dict(radius=0.003, length=0.0205, cone=0.009, mass=0.00012, volume_ml=0.2, cap="white", description="0.2 mL thin-walled PCR tube with flat cap."),
}
for _id, _kw in _TUBES.items():
    _kw = dict(_kw)
    register(_id, CATEGORY, partial(tube, _id, _kw.pop("description"), **_kw))
register("pcr_strip_8", CATEGORY, partial(pcr_strip, "pcr_strip_8"))


# ----------------------------------------------------------------------------- dishes and plates


def petri_dish(asset_id: str, diameter: float, height: float, mass: float) -> AssetDef:
    r = diameter / 2
    body = Body("body", mass)
    base_h, lid_r, lid_h, w = height * 0.93, r + 0.0012, height * 0.6, 0.0008
    p.visual(body, "base", g.revolve(p.vessel_profile([(r - 0.001, 0), (r, 0.0008), (r, base_h)], w, w), 48), p.CLEAR_PLASTIC)
    lid = [(0, height - w), (lid_r - w, height - w), (lid_r - w, height - lid_h), (lid_r, height - lid_h), (lid_r, height), (0, height)]
    p.visual(body, "lid", g.revolve(lid, 48), p.CLEAR_PLASTIC)
    p.visual(body, "agar", g.cylinder(r - w - 0.0002, base_h * 0.45, (0, 0, w + base_h * 0.225), 48), p.AGAR)
    p.cylinder_collider(body, "dish_col", lid_r, height, (0, 0, height / 2))
    p.site(body, "center", (0, 0, height / 2))
    p.site(body, "grasp", (0, 0, height / 2))
    desc = f"Polystyrene Petri dish, {round(diameter * 1000)} mm, with lid and agar (dish and lid are one body)."
    return _asset(asset_id, desc, body, extra={"diameter": 2 * lid_r, "height": height})


for _d, _h, _m in ((35, 0.010, 0.006), (60, 0.015, 0.016), (90, 0.015, 0.035), (100, 0.015, 0.042), (150, 0.020, 0.095)):
    _id = f"petri_dish_{_d}mm"
    register(_id, CATEGORY, partial(petri_dish, _id, _d / 1000, _h, _m))

SBS = (0.12776, 0.08548)


def well_plate(asset_id: str, description: str, rows: int, cols: int, height: float, well_d: float, mass: float,
               square: bool = False, material: Material = p.CLEAR_PLASTIC, well_ul: float = 0.0) -> AssetDef:
    body = Body("body", mass)
    p.visual(body, "plate", g.box((SBS[0], SBS[1], height), (0, 0, height / 2), 0.004), material)
    p.box_collider(body, "plate_col", (SBS[0], SBS[1], height), (0, 0, height / 2))
    pitch = {2: 0.039, 3: 0.026, 4: 0.0195, 6: 0.013, 8: 0.009, 16: 0.0045}[rows]
    centres = [(-(cols - 1) / 2 * pitch + i * pitch, (rows - 1) / 2 * pitch - j * pitch) for j in range(rows) for i in range(cols)]
    segs = 8 if rows >= 16 else 16
    well = g.box((well_d, well_d, 0.0006), (0, 0, 0)) if square else g.cylinder(well_d / 2, 0.0006, (0, 0, 0), segs)
    wells = g.merge([well.moved((x, y, height + 0.0001)) for x, y in centres])
    p.visual(body, "wells", wells, Material("well_rim", (0.70, 0.74, 0.78), opacity=0.7, roughness=0.2))
    p.site(body, "center", (0, 0, height))
    p.site(body, "grasp", (0, 0, height / 2))
    p.site(body, "well_a1", (centres[0][0], centres[0][1], height))
    extra = {"rows": float(rows), "cols": float(cols), "pitch": pitch, "well_volume_ul": well_ul, "footprint": SBS}
    return _asset(asset_id, description, body, extra=extra)


_PLATES = {
    "well_plate_6": (2, 3, 0.020, 0.035, 0.060, False, 16800.0, "6-well cell-culture plate, SBS footprint."),
    "well_plate_12": (3, 4, 0.020, 0.022, 0.058, False, 6900.0, "12-well cell-culture plate, SBS footprint."),
    "well_plate_24": (4, 6, 0.020, 0.0156, 0.056, False, 3400.0, "24-well cell-culture plate, SBS footprint."),
    "well_plate_48": (6, 8, 0.020, 0.011, 0.055, False, 1600.0, "48-well cell-culture plate, SBS footprint."),
    "well_plate_96": (8, 12, 0.0144, 0.0069, 0.045, False, 360.0, "96-well flat-bottom microplate, SBS footprint."),
    "well_plate_384": (16, 24, 0.0144, 0.0037, 0.050, True, 112.0, "384-well microplate with square wells."),
    "deep_well_plate_96": (8, 12, 0.044, 0.0082, 0.075, True, 2000.0, "96 deep-well plate, 2 mL square wells."),
}
for _id, (_r, _c, _h, _wd, _m, _sq, _ul, _desc) in _PLATES.items():
    register(_id, CATEGORY, partial(well_plate, _id, _desc, _r, _c, _h, _wd, _m, _sq, well_ul=_ul))
register("pcr_plate_96", CATEGORY, partial(well_plate, "pcr_plate_96", "96-well skirted PCR plate.", 8, 12, 0.016, 0.0055, 0.016,
                                           material=Material("pcr_white", (0.95, 0.95, 0.93), roughness=0.4), well_ul=200.0))


def reservoir(asset_id: str, description: str, size: tuple[float, float, float], channels: int, mass: float) -> AssetDef:
    body = Body("body", mass)
    p.open_box(body, "trough", size, 0.0015, 0.002, Material("reservoir", (0.88, 0.90, 0.93), opacity=0.7, roughness=0.3),
               dividers=channels - 1 if channels > 1 else 0)
    p.site(body, "center", (0, 0, 0.002))
    p.site(body, "grasp", (0, size[1] / 2, size[2] * 0.6))
    return _asset(asset_id, description, body, extra={"channels": float(channels), "inner_size": size})


register("reagent_reservoir_25ml", CATEGORY, partial(reservoir, "reagent_reservoir_25ml", "25 mL reagent reservoir for multichannel pipettes.", (0.120, 0.062, 0.030), 1, 0.014))
register("reservoir_12_channel", CATEGORY, partial(reservoir, "reservoir_12_channel", "12-channel reagent reservoir, SBS footprint.", (0.1276, 0.0855, 0.044), 12, 0.042))


# ----------------------------------------------------------------------------- glassware and bottles


def beaker(asset_id: str, volume_ml: float, radius: float, height: float, mass: float) -> AssetDef:
    body = Body("body", mass)
    outer = [(radius - 0.002, 0.0), (radius, 0.003), (radius, height), (radius + 0.0015, height)]
    p.visual(body, "glass", g.revolve(p.vessel_profile(outer, 0.0018, 0.003), 40), p.GLASS)
    marks = g.merge([g.box((0.0004, 0.004, 0.0006), (radius + 0.0001, 0, height * f)) for f in (0.3, 0.45, 0.6, 0.75)])
    p.visual(body, "graduations", marks, p.WHITE_PLASTIC)
    p.cylinder_collider(body, "floor_col", radius, 0.003, (0, 0, 0.0015))
    p.ring_colliders(body, "wall_col", radius - 0.0018, radius + 0.0005, 0.0, height, 14)
    p.site(body, "grasp", (0, 0, 0.5 * height))
    p.site(body, "inside_bottom", (0, 0, 0.003))
    desc = f"{volume_ml:g} mL low-form borosilicate glass beaker (hollow; a tube can stand inside)."
    return _asset(asset_id, desc, body, extra={"volume_ml": volume_ml, "outer_diameter": 2 * radius, "height": height})


for _v, _rad, _h, _m in ((50, 0.021, 0.060, 0.032), (100, 0.025, 0.070, 0.050), (250, 0.0345, 0.095, 0.090), (500, 0.043, 0.120, 0.170), (1000, 0.0535, 0.145, 0.300)):
    register(f"beaker_{_v}ml", CATEGORY, partial(beaker, f"beaker_{_v}ml", float(_v), _rad, _h, _m))


def erlenmeyer(asset_id: str, volume_ml: float, base_r: float, height: float, neck_r: float, neck_h: float, mass: float) -> AssetDef:
    body = Body("body", mass)
    outer = [(base_r * 0.95, 0.0), (base_r, 0.004), (base_r * 0.98, 0.012), (neck_r, height - neck_h), (neck_r, height - 0.003),
             (neck_r + 0.0015, height - 0.002), (neck_r + 0.0015, height)]
    p.visual(body, "glass", g.revolve(p.vessel_profile(outer, 0.0018, 0.003), 40), p.GLASS)
    p.revolved_colliders(body, "body_col", outer[:4], 5)
    p.cylinder_collider(body, "neck_col", neck_r + 0.0005, neck_h, (0, 0, height - neck_h / 2))
    p.site(body, "grasp", (0, 0, height - neck_h / 2))
    p.site(body, "neck", (0, 0, height))
    desc = f"{volume_ml:g} mL borosilicate Erlenmeyer flask (revolved, hollow glass)."
    return _asset(asset_id, desc, body, extra={"volume_ml": volume_ml, "base_diameter": 2 * base_r, "height": height, "neck_diameter": 2 * neck_r})


for _v, _br, _h, _nr, _nh, _m in ((125, 0.032, 0.118, 0.0115, 0.025, 0.075), (250, 0.0415, 0.140, 0.0170, 0.030, 0.125),
                                  (500, 0.0525, 0.180, 0.0170, 0.035, 0.210), (1000, 0.0655, 0.225, 0.0210, 0.040, 0.360)):
    register(f"erlenmeyer_flask_{_v}ml", CATEGORY, partial(erlenmeyer, f"erlenmeyer_flask_{_v}ml", float(_v), _br, _h, _nr, _nh, _m))


def volumetric_flask(asset_id: str, volume_ml: float, bulb_r: float, neck_r: float, height: float, mass: float) -> AssetDef:
    body = Body("body", mass)
    zc = 0.9 * bulb_r
    phi0, phi1 = math.acos(zc / bulb_r), math.pi - math.asin(neck_r / bulb_r)
    arc = [(bulb_r * math.sin(f), zc - bulb_r * math.cos(f)) for f in (phi0 + (phi1 - phi0) * k / 10 for k in range(11))]
    outer = [*arc, (neck_r, height)]
    p.visual(body, "glass", g.revolve(p.vessel_profile(outer, 0.0015, 0.003), 40), p.GLASS)
    stopper_h = 0.016
    p.solid_cylinder(body, "stopper", neck_r + 0.002, stopper_h, (0, 0, height + stopper_h / 2 - 0.004), p.BLUE_PLASTIC)
    p.visual(body, "fill_mark", g.cylinder(neck_r + 0.0002, 0.0008, (0, 0, height * 0.75)), p.WHITE_PLASTIC)
    p.revolved_colliders(body, "bulb_col", arc, 5)
    p.cylinder_collider(body, "neck_col", neck_r, height - arc[-1][1], (0, 0, (height + arc[-1][1]) / 2))
    p.site(body, "grasp", (0, 0, height * 0.7))
    p.site(body, "neck", (0, 0, height))
    desc = f"{volume_ml:g} mL class A volumetric flask with stopper."
    return _asset(asset_id, desc, body, extra={"volume_ml": volume_ml, "height": height + stopper_h - 0.004})


for _v, _br, _nr, _h, _m in ((100, 0.032, 0.0065, 0.170, 0.070), (250, 0.042, 0.0080, 0.220, 0.120), (1000, 0.066, 0.0105, 0.300, 0.330)):
    register(f"volumetric_flask_{_v}ml", CATEGORY, partial(volumetric_flask, f"volumetric_flask_{_v}ml", float(_v), _br, _nr, _h, _m))


def media_bottle(asset_id: str, volume_ml: float, radius: float, body_h: float, neck_r: float, total_h: float, mass: float, fill: float) -> AssetDef:
    body = Body("body", mass)
    cap_h = 0.022 if neck_r > 0.015 else 0.018
    neck_top = total_h - cap_h + 0.004
    outer = [(radius - 0.002, 0.0), (radius, 0.004), (radius, body_h), (radius * 0.75, body_h + 0.4 * (neck_top - body_h) * 0.5),
             (neck_r, body_h + 0.55 * (neck_top - body_h)), (neck_r, neck_top)]
    p.visual(body, "glass", g.revolve(p.vessel_profile(outer, 0.0025, 0.004), 40), p.GLASS)
    if fill:
        p.visual(body, "medium", g.cylinder(radius - 0.003, body_h * fill, (0, 0, 0.004 + body_h * fill / 2), 40), p.MEDIUM)
    p.revolved_colliders(body, "body_col", outer[:5], 4)
    p.cylinder_collider(body, "neck_col", neck_r, neck_top - outer[4][1], (0, 0, (neck_top + outer[4][1]) / 2))
    p.solid_cylinder(body, "cap", neck_r + 0.004, cap_h, (0, 0, total_h - cap_h / 2), p.BLUE_PLASTIC, 32)
    p.site(body, "grasp", (0, 0, body_h * 0.5))
    p.site(body, "cap_top", (0, 0, total_h))
    desc = f"{volume_ml:g} mL borosilicate media bottle with GL45 blue screw cap" + (", partly filled with medium." if fill else ".")
    return _asset(asset_id, desc, body, extra={"volume_ml": volume_ml, "outer_diameter": 2 * radius, "height": total_h})


for _v, _rad, _bh, _nr, _th, _m, _f in ((100, 0.028, 0.070, 0.0165, 0.105, 0.180, 0.0), (250, 0.035, 0.098, 0.0215, 0.143, 0.300, 0.5),
                                      (500, 0.043, 0.128, 0.0215, 0.181, 0.420, 0.6), (1000, 0.0505, 0.170, 0.0215, 0.230, 0.640, 0.0)):
    register(f"media_bottle_{_v}ml", CATEGORY, partial(media_bottle, f"media_bottle_{_v}ml", float(_v), _rad, _bh, _nr, _th, _m, _f))


def graduated_cylinder(asset_id: str, volume_ml: float, radius: float, height: float, base_r: float, mass: float) -> AssetDef:
    body = Body("body", mass)
    base_h = 0.010
    hexagon = g.revolve([(0, 0), (base_r, 0), (base_r, base_h), (0, base_h)], 6)
    p.visual(body, "base", hexagon, p.BLUE_PLASTIC)
    outer = [(radius, base_h), (radius, height), (radius + 0.002, height)]
    p.visual(body, "tube", g.revolve(p.vessel_profile(outer, 0.0015, base_h + 0.002), 32).moved((0, 0, 0)), p.CLEAR_PLASTIC)
    p.cylinder_collider(body, "base_col", base_r * 0.86, base_h, (0, 0, base_h / 2))
    p.cylinder_collider(body, "tube_col", radius, height - base_h, (0, 0, (height + base_h) / 2))
    p.site(body, "grasp", (0, 0, height * 0.6))
    return _asset(asset_id, f"{volume_ml:g} mL polypropylene graduated cylinder with hexagonal base.", body,
                  extra={"volume_ml": volume_ml, "height": height})


register("graduated_cylinder_100ml", CATEGORY, partial(graduated_cylinder, "graduated_cylinder_100ml", 100.0, 0.0145, 0.250, 0.038, 0.070))
register("graduated_cylinder_250ml", CATEGORY, partial(graduated_cylinder, "graduated_cylinder_250ml", 250.0, 0.0200, 0.320, 0.050, 0.130))


# ----------------------------------------------------------------------------- small flat things


def cuvette(asset_id: str, description: str, material: Material, fill: bool) -> AssetDef:
    body = Body("body", 0.0032)
    p.solid_box(body, "cuvette", (0.0125, 0.0125, 0.045), (0, 0, 0.0225), material, 0.0005)
    if fill:
        p.visual(body, "sample", g.box((0.0098, 0.0098, 0.02), (0, 0, 0.014)), p.MEDIUM)
    p.site(body, "grasp", (0, 0, 0.035))
    return _asset(asset_id, description, body, extra={"path_length": 0.010, "outer_size": (0.0125, 0.0125, 0.045)})


register("cuvette_standard", CATEGORY, partial(cuvette, "cuvette_standard", "Disposable PS cuvette, 10 mm path, 4.5 mL.", p.CLEAR_PLASTIC, True))
register("cuvette_quartz", CATEGORY, partial(cuvette, "cuvette_quartz", "Quartz cuvette, 10 mm path (empty).", p.GLASS, False))


def flat_piece(asset_id: str, description: str, size: tuple[float, float, float], mass: float, material: Material, label: bool) -> AssetDef:
    body = Body("body", mass)
    p.solid_box(body, "plate", size, (0, 0, size[2] / 2), material)
    if label:
        p.visual(body, "frosted_end", g.box((0.018, size[1], 0.0002), (-size[0] / 2 + 0.009, 0, size[2] + 0.0001)), p.WHITE_PLASTIC)
    p.site(body, "center", (0, 0, size[2]))
    return _asset(asset_id, description, body, extra={"size": size})


register("microscope_slide", CATEGORY, partial(flat_piece, "microscope_slide", "Glass microscope slide 75 x 25 x 1 mm, frosted end.", (0.075, 0.025, 0.001), 0.005, p.GLASS, True))
register("coverslip_22mm", CATEGORY, partial(flat_piece, "coverslip_22mm", "Glass coverslip 22 x 22 mm (modelled 0.3 mm thick).", (0.022, 0.022, 0.0003), 0.0004, p.GLASS, False))


def pipette_tip(asset_id: str, volume_ul: float, length: float, top_r: float, tip_r: float, mass: float, material: Material) -> AssetDef:
    body = Body("body", mass, condim=6)  # a cone on its side: rolling friction, or it circles on the bench for ever
    collar = length * 0.18
    outer = [(tip_r, 0.0), (top_r * 0.75, length - collar), (top_r, length - collar + 0.002), (top_r, length)]
    p.visual(body, "tip", g.revolve(p.vessel_profile(outer, 0.0004, 0.003), 20), material)
    p.revolved_colliders(body, "tip_col", outer, 3)
    p.site(body, "top", (0, 0, length))
    p.site(body, "end", (0, 0, 0))
    return _asset(asset_id, f"{volume_ul:g} uL disposable pipette tip.", body, upright=False, rest_quat=LYING,
                  extra={"volume_ul": volume_ul, "length": length})


register("pipette_tip_1000ul", CATEGORY, partial(pipette_tip, "pipette_tip_1000ul", 1000.0, 0.071, 0.0042, 0.0005, 0.0009, Material("tip_blue", (0.45, 0.65, 0.95), opacity=0.7, roughness=0.3)))
register("pipette_tip_200ul", CATEGORY, partial(pipette_tip, "pipette_tip_200ul", 200.0, 0.051, 0.0030, 0.0004, 0.0004, Material("tip_yellow", (0.98, 0.88, 0.35), opacity=0.7, roughness=0.3)))
register("pipette_tip_10ul", CATEGORY, partial(pipette_tip, "pipette_tip_10ul", 10.0, 0.032, 0.0022, 0.0003, 0.00015, p.CLEAR_PLASTIC))


def culture_flask(asset_id: str, description: str, size: tuple[float, float, float], neck_r: float, mass: float) -> AssetDef:
    body = Body("body", mass)
    sx, sy, sz = size
    p.solid_box(body, "flask", size, (0, 0, sz / 2), p.CLEAR_PLASTIC, 0.006)
    p.visual(body, "medium", g.box((sx * 0.9, sy * 0.88, 0.004), (0, 0, 0.0035), 0.005), p.MEDIUM)
    neck_len, cap_len = 0.018, 0.016
    p.solid_cylinder_x(body, "neck", neck_r, neck_len, (-sx / 2 - neck_len / 2 + 0.002, 0, sz / 2), p.CLEAR_PLASTIC)
    p.solid_cylinder_x(body, "cap", neck_r + 0.003, cap_len, (-sx / 2 - neck_len - cap_len / 2 + 0.003, 0, sz / 2), p.BLUE_PLASTIC)
    p.site(body, "grasp", (0, 0, sz / 2))
    p.site(body, "cap", (-sx / 2 - neck_len - cap_len + 0.003, 0, sz / 2))
    return _asset(asset_id, description, body, extra={"body_size": size})


register("cell_culture_flask_t25", CATEGORY, partial(culture_flask, "cell_culture_flask_t25", "T25 cell-culture flask with vented cap, lying flat.", (0.095, 0.058, 0.026), 0.010, 0.022))
register("cell_culture_flask_t75", CATEGORY, partial(culture_flask, "cell_culture_flask_t75", "T75 cell-culture flask with vented cap, lying flat.", (0.150, 0.090, 0.038), 0.0125, 0.055))


@generator("wash_bottle_500ml", CATEGORY)
def wash_bottle() -> AssetDef:
    body = Body("body", 0.075)
    outer = [(0.036, 0.0), (0.038, 0.004), (0.038, 0.150), (0.020, 0.168), (0.014, 0.172), (0.014, 0.180)]
    p.visual(body, "bottle", g.revolve(p.vessel_profile(outer, 0.0012, 0.003), 36), Material("ldpe", (0.95, 0.95, 0.97), opacity=0.75, roughness=0.5))
    p.visual(body, "water", g.cylinder(0.036, 0.09, (0, 0, 0.048), 36), p.WATER)
    p.revolved_colliders(body, "bottle_col", outer[:5], 4)
    p.solid_cylinder(body, "cap", 0.016, 0.018, (0, 0, 0.187), p.RED_PLASTIC)
    nozzle = g.cylinder(0.0022, 0.085, (0, 0, 0), 10).moved((-0.03, 0, 0.215), g.rotation("y", -55))
    p.visual(body, "nozzle", nozzle, p.WHITE_PLASTIC)
    p.site(body, "grasp", (0, 0, 0.08))
    return _asset("wash_bottle_500ml", "500 mL LDPE wash bottle with angled nozzle, half full of water.", body,
                  extra={"volume_ml": 500.0})


def weighing_boat(asset_id: str, top: float, bottom: float, height: float, mass: float) -> AssetDef:
    body = Body("body", mass)
    k = math.sqrt(2)
    outer = [(bottom / 2 * k, 0.0), (top / 2 * k, height)]
    shell = g.revolve(p.vessel_profile(outer, 0.0008, 0.0006), 4).moved((0, 0, 0), g.rotation("z", 45))
    p.visual(body, "boat", shell, Material("antistatic_white", (0.96, 0.96, 0.94), roughness=0.6))
    p.box_collider(body, "floor_col", (bottom, bottom, 0.0008), (0, 0, 0.0004))
    mid, h = (top + bottom) / 4, height
    for name, pos, size in (("xn", (-mid, 0, h / 2), (0.001, top * 0.9, h)), ("xp", (mid, 0, h / 2), (0.001, top * 0.9, h)),
                            ("yn", (0, -mid, h / 2), (top * 0.9, 0.001, h)), ("yp", (0, mid, h / 2), (top * 0.9, 0.001, h))):
        p.box_collider(body, f"wall_{name}_col", size, pos)
    p.site(body, "center", (0, 0, 0.0008))
    return _asset(asset_id, f"Anti-static weighing boat, {round(top * 1000)} mm square.", body, extra={"top_size": top})


register("weighing_boat_medium", CATEGORY, partial(weighing_boat, "weighing_boat_medium", 0.089, 0.060, 0.025, 0.0025))


@generator("syringe_10ml", CATEGORY)
def syringe() -> AssetDef:
    body = Body("body", 0.011)
    r, length = 0.0078, 0.080
    p.solid_cylinder_x(body, "barrel", r, length, (0, 0, r), p.CLEAR_PLASTIC)
    p.solid_cylinder_x(body, "luer_tip", 0.002, 0.012, (-length / 2 - 0.006, 0, r), p.CLEAR_PLASTIC)
    p.solid_box(body, "flange", (0.003, 0.030, 2 * r), (length / 2 + 0.0015, 0, r), p.CLEAR_PLASTIC)
    p.visual(body, "plunger", g.box((0.030, 0.004, 0.009), (length / 2 + 0.016, 0, r)), p.WHITE_PLASTIC)
    p.solid_cylinder_x(body, "thumb", r, 0.002, (length / 2 + 0.032, 0, r), p.WHITE_PLASTIC)
    p.visual(body, "stopper", g.cylinder(r - 0.0008, 0.006, (0, 0, 0), 16).moved((length / 2 - 0.02, 0, r), g.rotation("y", 90)), p.RUBBER)
    p.site(body, "grasp", (0, 0, r))
    p.site(body, "tip", (-length / 2 - 0.012, 0, r))
    return _asset("syringe_10ml", "10 mL Luer-slip syringe lying on its side.", body, extra={"volume_ml": 10.0})


def supply_box(asset_id: str, description: str, size: tuple[float, float, float], mass: float, material: Material, tissue: bool) -> AssetDef:
    body = Body("body", mass)
    p.solid_box(body, "box", size, (0, 0, size[2] / 2), material, 0.002)
    p.visual(body, "opening", g.box((size[0] * 0.5, size[1] * 0.25, 0.001), (0, 0, size[2] + 0.0003), 0.01), p.WHITE_PLASTIC if tissue else p.DARK_PLASTIC)
    if tissue:
        p.visual(body, "tissue", g.box((0.05, 0.004, 0.03), (0, 0, size[2] + 0.012)), p.FOAM)
    p.site(body, "grasp", (0, 0, size[2] / 2))
    return _asset(asset_id, description, body, extra={"size": size})


register("wipes_box", CATEGORY, partial(supply_box, "wipes_box", "Box of delicate task wipes, one wipe pulled up.", (0.215, 0.115, 0.065), 0.12, Material("wipes_card", (0.90, 0.92, 0.95), roughness=0.7), True))
register("glove_box_nitrile", CATEGORY, partial(supply_box, "glove_box_nitrile", "Box of 100 nitrile gloves, size M.", (0.240, 0.125, 0.062), 0.55, Material("glove_card", (0.35, 0.30, 0.65), roughness=0.7), False))


@generator("lab_tape_roll", CATEGORY)
def tape_roll() -> AssetDef:
    body = Body("body", 0.03)
    ring = [(0.0125, 0.0), (0.024, 0.0), (0.024, 0.019), (0.0125, 0.019)]
    p.visual(body, "tape", g.revolve(ring + [ring[0]], 36), YELLOW_TAPE)
    p.ring_colliders(body, "ring_col", 0.0125, 0.024, 0.0, 0.019, 10)
    p.site(body, "grasp", (0.018, 0, 0.0095))
    return _asset("lab_tape_roll", "Roll of yellow labelling tape, lying flat.", body, extra={"outer_diameter": 0.048})


YELLOW_TAPE = Material("labelling_tape", (0.98, 0.85, 0.20), roughness=0.6)
