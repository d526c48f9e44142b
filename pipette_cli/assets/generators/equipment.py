"""Equipment: bench, tables, racks, tip boxes, trays, bins, stands, a biosafety-cabinet sash.

Equipment is static: its ``base`` body is fixed to whatever it stands on (a ``FixedJoint`` to
the world in the file; ``MjSpec.attach`` welds it to the parent frame). Racks are hollow grids
a tube can stand in; slot sites mark where a held object's origin goes.
"""

from __future__ import annotations

import math
from functools import partial

from pipette_cli.assets import geometry as g
from pipette_cli.assets import parts as p
from pipette_cli.assets.generators import register
from pipette_cli.assets.model import AssetDef, Body, Joint, Material
from pipette_cli.specs.base import BENCH_TOP_Z

CATEGORY = "equipment"
RACK_BLUE = Material("rack_blue", (0.25, 0.50, 0.85), roughness=0.5)
RACK_GREEN = Material("rack_green", (0.30, 0.70, 0.45), roughness=0.5)
WOOD = Material("wood", (0.72, 0.55, 0.38), roughness=0.7)


def _asset(asset_id: str, description: str, bodies: list[Body], **kw) -> AssetDef:
    return AssetDef(asset_id, CATEGORY, description, bodies, static=True, **kw)


def lab_bench() -> AssetDef:
    base = Body("base", 80.0)
    top_z, t = BENCH_TOP_Z, 0.03
    p.solid_box(base, "top", (1.6, 1.0, t), (0, 0, top_z - t / 2), p.BENCH_TOP)
    for i, (x, y) in enumerate(((-0.75, -0.45), (0.75, -0.45), (-0.75, 0.45), (0.75, 0.45))):
        p.solid_box(base, f"leg_{i}", (0.05, 0.05, top_z - t), (x, y, (top_z - t) / 2), p.PAINTED_METAL)
    p.solid_box(base, "shelf", (1.45, 0.85, 0.02), (0, 0, 0.12), p.PAINTED_METAL)
    p.solid_box(base, "back_rail", (1.45, 0.03, 0.08), (0, 0.46, top_z - t - 0.04), p.PAINTED_METAL)
    p.site(base, "top_center", (0, 0, top_z))
    return _asset("lab_bench", f"Laboratory bench, 1.6 x 1.0 m epoxy top at {BENCH_TOP_Z} m, steel frame with lower shelf.", [base],
                  extra={"top_height": top_z, "top_size": (1.6, 1.0)})


def balance_table() -> AssetDef:
    base = Body("base", 45.0)
    p.solid_box(base, "frame", (0.55, 0.45, 0.07), (0, 0, 0.035), p.PAINTED_METAL, 0.01)
    for i, (x, y) in enumerate(((-0.22, -0.17), (0.22, -0.17), (-0.22, 0.17), (0.22, 0.17))):
        p.solid_cylinder(base, f"damper_{i}", 0.02, 0.015, (x, y, 0.0775), p.RUBBER)
    p.solid_box(base, "stone_slab", (0.50, 0.40, 0.035), (0, 0, 0.1025), Material("granite", (0.35, 0.35, 0.37), roughness=0.4), 0.005)
    p.site(base, "top_center", (0, 0, 0.12))
    return _asset("balance_table", "Anti-vibration weighing table riser: steel frame, dampers and a granite slab; top 0.12 m above its base.",
                  [base], extra={"top_height": 0.12, "top_size": (0.50, 0.40)})


register("lab_bench", CATEGORY, lab_bench)
register("balance_table", CATEGORY, balance_table)


def pipette_stand_linear() -> AssetDef:
    base = Body("base", 0.9)
    p.solid_box(base, "foot", (0.12, 0.26, 0.012), (0, 0, 0.006), p.WHITE_PLASTIC, 0.01)
    p.solid_box(base, "post", (0.02, 0.24, 0.17), (0.045, 0, 0.097), p.WHITE_PLASTIC)
    arm_top, arm_t, pitch = 0.17, 0.012, 0.055
    arm_len = 0.07
    slot_x = 0.045 - 0.01 - arm_len + 0.02
    ys = [pitch * (k - 1.5) for k in range(4)]
    # arm: a back bar plus prongs between slots (slots are 0.016 wide, open to the front)
    p.solid_box(base, "arm_back", (arm_len - 0.032, 0.24, arm_t), (0.035 - (arm_len - 0.032) / 2, 0, arm_top - arm_t / 2), p.GREY_PLASTIC)
    edges = [-0.12] + [y for y0 in ys for y in (y0 - 0.008, y0 + 0.008)] + [0.12]
    for k in range(0, len(edges), 2):
        lo, hi = edges[k], edges[k + 1]
        p.solid_box(base, f"prong_{k // 2}", (0.034, hi - lo, arm_t), (slot_x - 0.0, (lo + hi) / 2, arm_top - arm_t / 2), p.GREY_PLASTIC)
    for k, y in enumerate(ys):
        p.site(base, f"slot_{k}", (slot_x, y, arm_top))
    return _asset("pipette_stand_linear",
                  "Linear stand holding four single-channel pipettes upright; a pipette hangs by its grip in a slot open to the front (-x).",
                  [base], extra={"slot_count": 4.0, "slot_width": 0.016, "slot_height": arm_top,
                                 # the side a held pipette slides in from (its own frame)
                                 "slot_opening": (-1.0, 0.0, 0.0)})


def pipette_stand_carousel() -> AssetDef:
    base = Body("base", 1.6)
    p.solid_cylinder(base, "foot", 0.11, 0.015, (0, 0, 0.0075), p.WHITE_PLASTIC, 40)
    p.solid_cylinder(base, "pole", 0.012, 0.20, (0, 0, 0.115), p.GREY_PLASTIC)
    arm_top = 0.19
    ring = [(0.04, arm_top - 0.012), (0.085, arm_top - 0.012), (0.085, arm_top), (0.04, arm_top)]
    p.visual(base, "carousel", g.revolve(ring + [ring[0]], 36), p.WHITE_PLASTIC)
    p.ring_colliders(base, "carousel_col", 0.04, 0.085, arm_top - 0.012, arm_top, 12)
    for k in range(6):
        a = 2 * math.pi * k / 6
        p.site(base, f"slot_{k}", (0.095 * math.cos(a), 0.095 * math.sin(a), arm_top))
    return _asset("pipette_stand_carousel", "Carousel stand for six pipettes.", [base], extra={"slot_count": 6.0, "slot_height": arm_top})


register("pipette_stand_linear", CATEGORY, pipette_stand_linear)
register("pipette_stand_carousel", CATEGORY, pipette_stand_carousel)


def tube_rack(asset_id: str, description: str, nx: int, ny: int, pitch: float, hole: float, height: float, mass: float,
              material: Material) -> AssetDef:
    """A two-tier rack: a floor with a low seat grid that keeps each tube's foot in its place, a top
    grid with holes, and end walls. Tubes stand on the floor."""
    base = Body("base", mass)
    sx, sy, floor, top_t = nx * pitch + 0.01, ny * pitch + 0.01, 0.004, 0.004
    seat = min(0.008, height / 4)
    p.solid_box(base, "floor", (sx, sy, floor), (0, 0, floor / 2), material)
    p.grid_bars(base, "seat", nx, ny, (pitch, pitch), (hole, hole), floor, floor + seat)
    for side, x in (("xn", -sx / 2 + 0.003), ("xp", sx / 2 - 0.003)):
        p.solid_box(base, f"end_{side}", (0.006, sy, height - floor), (x, 0, floor + (height - floor) / 2), material)
    bars = []
    p.grid_bars(base, "grid", nx, ny, (pitch, pitch), (hole, hole), height - top_t, height)
    for c in base.colliders:
        if c.name.startswith(("grid_", "seat_")):
            bars.append(g.box(tuple(2 * s for s in c.size), c.pos))
    p.visual(base, "grid", g.merge(bars), material)
    for k, (x, y) in enumerate(p.grid_positions(nx, ny, (pitch, pitch))):
        p.site(base, f"slot_{k}", (x, y, floor), 0.003)
    return _asset(asset_id, description, [base], extra={"slots": float(nx * ny), "pitch": pitch, "hole": hole, "floor_height": floor})


_RACKS = {
    "microtube_rack_24": ("Rack for 24 x 1.5/2 mL microtubes (6 x 4).", 6, 4, 0.016, 0.0115, 0.030, 0.08, RACK_BLUE),
    "conical_tube_rack_15ml": ("Rack for 18 x 15 mL conical tubes (6 x 3).", 6, 3, 0.024, 0.0185, 0.070, 0.20, RACK_GREEN),
    "conical_tube_rack_50ml": ("Rack for 8 x 50 mL conical tubes (4 x 2).", 4, 2, 0.036, 0.031, 0.070, 0.22, RACK_BLUE),
    "test_tube_rack_16mm": ("Rack for 12 x 16 mm test tubes (6 x 2).", 6, 2, 0.024, 0.018, 0.060, 0.15, Material("rack_white", (0.92, 0.92, 0.90), roughness=0.5)),
    "pcr_rack_96": ("96-position rack for 0.2 mL PCR tubes (12 x 8).", 12, 8, 0.009, 0.0064, 0.016, 0.05, Material("rack_orange", (0.95, 0.55, 0.15), opacity=0.85, roughness=0.4)),
    "cryo_box_81": ("Cardboard cryogenic storage box with 9 x 9 divider for 2 mL cryovials.", 9, 9, 0.0145, 0.0128, 0.050, 0.12, Material("cryo_card", (0.85, 0.80, 0.70), roughness=0.8)),
}
for _id, (_d, _nx, _ny, _pitch, _hole, _h, _m, _mat) in _RACKS.items():
    register(_id, CATEGORY, partial(tube_rack, _id, _d, _nx, _ny, _pitch, _hole, _h, _m, _mat))


def tip_box(asset_id: str, description: str, tip_len: float, tip_r: float, height: float, colour: Material) -> AssetDef:
    base = Body("base", 0.10 + 96 * 0.0005)
    sx, sy = 0.122, 0.082
    p.solid_box(base, "box", (sx, sy, height - 0.004), (0, 0, (height - 0.004) / 2), colour, 0.004)
    p.solid_box(base, "tip_plate", (sx - 0.004, sy - 0.004, 0.004), (0, 0, height - 0.002), p.WHITE_PLASTIC)
    centres = p.grid_positions(12, 8, (0.009, 0.009))
    cone = g.revolve([(0, 0), (tip_r * 0.2, 0), (tip_r, tip_len), (0, tip_len)], 10)
    exposed = min(tip_len, 0.02)
    p.visual(base, "tips", g.merge([cone.moved((x, y, height - tip_len + exposed)) for x, y in centres]),
             Material(f"{colour.name}_tips", (0.92, 0.93, 0.95), opacity=0.6, roughness=0.3))
    p.box_collider(base, "tips_col", (0.108, 0.072, exposed), (0, 0, height + exposed / 2))
    p.site(base, "tip_a1", (centres[0][0], centres[0][1], height + exposed))
    return _asset(asset_id, description, [base], extra={"tips": 96.0, "pitch": 0.009})


register("tip_box_1000ul", CATEGORY, partial(tip_box, "tip_box_1000ul", "Rack of 96 x 1000 uL tips.", 0.071, 0.0042, 0.060, RACK_BLUE))
register("tip_box_200ul", CATEGORY, partial(tip_box, "tip_box_200ul", "Rack of 96 x 200 uL tips.", 0.051, 0.0030, 0.045, Material("rack_yellow", (0.95, 0.80, 0.20), roughness=0.5)))
register("tip_box_10ul", CATEGORY, partial(tip_box, "tip_box_10ul", "Rack of 96 x 10 uL tips.", 0.032, 0.0022, 0.035, Material("rack_clear", (0.75, 0.78, 0.82), opacity=0.8, roughness=0.3)))


def tray(asset_id: str, description: str, size: tuple[float, float, float], mass: float, material: Material, dividers: int = 0) -> AssetDef:
    base = Body("base", mass)
    p.open_box(base, "tray", size, 0.004, 0.004, material, dividers=dividers)
    p.site(base, "center", (0, 0, 0.004))
    return _asset(asset_id, description, [base], extra={"inner_size": (size[0] - 0.008, size[1] - 0.008), "wall_height": size[2]})


register("lab_tray_small", CATEGORY, partial(tray, "lab_tray_small", "Small polypropylene lab tray.", (0.30, 0.22, 0.05), 0.25, p.WHITE_PLASTIC))
register("lab_tray_large", CATEGORY, partial(tray, "lab_tray_large", "Large polypropylene lab tray.", (0.45, 0.35, 0.07), 0.55, p.GREY_PLASTIC))
register("tip_waste_box", CATEGORY, partial(tray, "tip_waste_box", "Benchtop tip disposal box (open top).", (0.12, 0.12, 0.14), 0.15, p.ORANGE_PLASTIC))
register("bench_mat", CATEGORY, partial(tray, "bench_mat", "Silicone bench mat with a raised rim.", (0.50, 0.40, 0.008), 0.6, p.GREEN_PLASTIC))
register("sharps_container", CATEGORY, partial(tray, "sharps_container", "Yellow sharps container, open lid.", (0.20, 0.14, 0.18), 0.35, p.YELLOW_PLASTIC))
register("slide_box", CATEGORY, partial(tray, "slide_box", "Open slide storage box, 25 positions.", (0.085, 0.085, 0.035), 0.08, p.DARK_PLASTIC, dividers=6))


def ice_bucket() -> AssetDef:
    base = Body("base", 0.7)
    r, h, wall = 0.11, 0.13, 0.018
    p.visual(base, "bucket", g.revolve(p.vessel_profile([(r - 0.005, 0), (r, 0.01), (r + 0.005, h)], wall, 0.02), 40), Material("bucket_blue", (0.25, 0.45, 0.80), roughness=0.6))
    ice_z = 0.075
    p.visual(base, "ice", g.cylinder(r - wall, ice_z - 0.02, (0, 0, 0.02 + (ice_z - 0.02) / 2), 40), Material("crushed_ice", (0.93, 0.96, 0.99), opacity=0.9, roughness=0.8))
    p.cylinder_collider(base, "ice_col", r - wall + 0.001, ice_z, (0, 0, ice_z / 2))
    p.ring_colliders(base, "wall_col", r - wall + 0.002, r + 0.005, 0.0, h, 16)
    p.site(base, "center", (0, 0, ice_z))
    return _asset("ice_bucket", "Insulated ice bucket (4 L) with crushed ice; tubes can stand in the ice.", [base], extra={"ice_height": ice_z})


register("ice_bucket", CATEGORY, ice_bucket)


def biohazard_bin() -> AssetDef:
    base = Body("base", 1.2)
    r, h = 0.14, 0.40
    p.visual(base, "bin", g.revolve(p.vessel_profile([(r - 0.01, 0), (r, 0.02), (r + 0.01, h)], 0.004, 0.008), 36), p.RED_PLASTIC)
    p.visual(base, "bag", g.revolve([(0, h - 0.02), (r + 0.003, h - 0.02), (r + 0.013, h + 0.01), (0, h + 0.01)], 36).moved((0, 0, 0)), Material("bag_orange", (0.95, 0.45, 0.15), opacity=0.7))
    p.cylinder_collider(base, "floor_col", r, 0.008, (0, 0, 0.004))
    p.ring_colliders(base, "wall_col", r - 0.004, r + 0.01, 0.0, h, 14)
    p.site(base, "opening", (0, 0, h))
    return _asset("biohazard_bin", "Round biohazard waste bin with autoclave bag.", [base], extra={"opening_height": h})


register("biohazard_bin", CATEGORY, biohazard_bin)


def reagent_shelf() -> AssetDef:
    base = Body("base", 6.0)
    w, d = 0.80, 0.25
    for i, z in enumerate((0.02, 0.20, 0.38)):
        p.solid_box(base, f"shelf_{i}", (d, w, 0.018), (0, 0, z - 0.009 + 0.009), WOOD)
    for side, y in (("l", -w / 2 + 0.009), ("r", w / 2 - 0.009)):
        p.solid_box(base, f"side_{side}", (d, 0.018, 0.40), (0, y, 0.20), WOOD)
    p.solid_box(base, "back", (0.01, w, 0.40), (d / 2 - 0.005, 0, 0.20), WOOD)
    for i, z in enumerate((0.029, 0.209)):
        p.site(base, f"shelf_{i}_center", (-0.02, 0, z + 0.009 - 0.009 + 0.009))
    return _asset("reagent_shelf", "Two-tier benchtop reagent shelf.", [base], extra={"shelf_heights": (0.029, 0.209)})


register("reagent_shelf", CATEGORY, reagent_shelf)


def ring_stand() -> AssetDef:
    base = Body("base", 2.5)
    p.solid_box(base, "foot", (0.20, 0.13, 0.012), (0, 0, 0.006), p.PAINTED_METAL, 0.01)
    p.solid_cylinder(base, "rod", 0.006, 0.50, (0.06, 0, 0.262), p.STEEL)
    p.solid_box(base, "boss_head", (0.03, 0.03, 0.03), (0.06, 0, 0.30), p.ALUMINIUM)
    p.solid_box(base, "arm", (0.10, 0.008, 0.008), (0.0, 0, 0.30), p.STEEL)
    ring = [(0.035, 0.296), (0.040, 0.296), (0.040, 0.304), (0.035, 0.304)]
    p.visual(base, "ring", g.revolve(ring + [ring[0]], 32).moved((-0.07, 0, 0)), p.STEEL)
    p.ring_colliders(base, "ring_col", 0.035, 0.040, 0.296, 0.304, 12, center=(-0.07, 0.0))
    p.site(base, "ring_center", (-0.07, 0, 0.304))
    return _asset("ring_stand", "Retort stand with boss head and support ring (funnel/flask holder).", [base], extra={"ring_height": 0.304})


register("ring_stand", CATEGORY, ring_stand)


def petri_dish_rack() -> AssetDef:
    base = Body("base", 0.5)
    p.solid_box(base, "floor", (0.11, 0.11, 0.006), (0, 0, 0.003), p.STEEL)
    for i, (x, y) in enumerate(((-0.05, -0.05), (0.05, -0.05), (-0.05, 0.05), (0.05, 0.05))):
        p.solid_cylinder(base, f"post_{i}", 0.003, 0.16, (x, y, 0.086), p.STEEL)
    for k in range(3):
        z = 0.006 + 0.05 * k
        p.site(base, f"slot_{k}", (0, 0, z))
    return _asset("petri_dish_rack", "Wire carrier for stacking 90 mm Petri dishes.", [base], extra={"slot_pitch": 0.05})


register("petri_dish_rack", CATEGORY, petri_dish_rack)


def drying_rack() -> AssetDef:
    base = Body("base", 1.5)
    p.solid_box(base, "board", (0.03, 0.45, 0.50), (0.0, 0, 0.25), p.WHITE_PLASTIC, 0.005)
    p.solid_box(base, "drip_tray", (0.12, 0.45, 0.02), (-0.045, 0, 0.01), p.WHITE_PLASTIC)
    k = 0
    for _row, z in enumerate((0.12, 0.22, 0.32, 0.42)):
        for col in range(6):
            y = -0.19 + col * 0.076
            mesh = g.cylinder(0.004, 0.08, (0, 0, 0), 10).moved((-0.05, y, z + 0.02), g.rotation("y", -70))
            p.visual(base, f"peg_{k}", mesh, p.WHITE_PLASTIC)
            k += 1
    p.site(base, "peg_0", (-0.08, -0.19, 0.15))
    return _asset("drying_rack", "Wall-type glassware drying rack with 24 pegs over a drip tray.", [base])


register("drying_rack", CATEGORY, drying_rack)


def floating_rack() -> AssetDef:
    base = Body("base", 0.04)
    p.grid_bars(base, "grid", 4, 4, (0.018, 0.018), (0.012, 0.012), 0.0, 0.022)
    bars = [g.box(tuple(2 * s for s in c.size), c.pos) for c in base.colliders]
    p.visual(base, "grid", g.merge(bars), Material("foam_yellow", (0.98, 0.85, 0.30), roughness=0.9))
    for k, (x, y) in enumerate(p.grid_positions(4, 4, (0.018, 0.018))):
        p.site(base, f"slot_{k}", (x, y, 0.022), 0.003)
    return _asset("floating_tube_rack", "Foam floating rack for 16 microtubes (water bath).", [base], extra={"slots": 16.0})


register("floating_tube_rack", CATEGORY, floating_rack)


def bsc_sash() -> AssetDef:
    base = Body("base", 25.0)
    w, h = 1.2, 0.75
    p.solid_box(base, "work_surface", (0.60, w, 0.02), (0.30, 0, 0.01), p.STEEL)
    for side, y in (("l", -w / 2 - 0.03), ("r", w / 2 + 0.03)):
        p.solid_box(base, f"side_{side}", (0.62, 0.06, h), (0.30, y, h / 2), p.PAINTED_METAL)
    p.solid_box(base, "header", (0.20, w + 0.12, 0.20), (0.04, 0, h + 0.10), p.PAINTED_METAL)
    p.solid_box(base, "back_wall", (0.02, w, h), (0.60, 0, h / 2), p.STEEL)
    p.solid_box(base, "front_grille", (0.06, w, 0.03), (-0.02, 0, 0.035), p.STEEL)
    sash = Body("sash", 9.0, pos=(-0.04, 0, 0.25))
    p.solid_box(sash, "glass", (0.008, w - 0.01, 0.60), (0, 0, 0.30), p.GLASS)
    p.solid_box(sash, "handle_bar", (0.03, w * 0.6, 0.02), (-0.02, 0, 0.02), p.ALUMINIUM)
    p.site(sash, "sash_handle", (-0.035, 0, 0.02))
    p.site(base, "work_center", (0.30, 0, 0.02))
    joint = Joint("sash_slide", "prismatic", "base", "sash", anchor=(-0.04, 0, 0.25), axis="z", lower=-0.05, upper=0.35, damping=40.0, friction=60.0)
    return _asset("biosafety_cabinet_sash", "Class II biosafety cabinet front: work surface, side walls and a vertical sliding glass sash.",
                  [base, sash], joints=[joint], extra={"opening_width": w, "sash_travel": 0.40})


register("biosafety_cabinet_sash", CATEGORY, bsc_sash)
