"""Tools: air-displacement pipettes, serological pipettes, tweezers, spatulas, loops...

Hand pipettes are authored upright (tip at the origin, as they hang in a stand) and lie on
their side at rest (``rest_quat``); the flat tools are authored lying on the bench.
"""

from __future__ import annotations

import math
from functools import partial

from pipette_cli.assets import geometry as g
from pipette_cli.assets import parts as p
from pipette_cli.assets.generators import register
from pipette_cli.assets.model import AssetDef, Body, Collider, Material

CATEGORY = "tools"
ON_SIDE = (math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0)  # 90 deg about y: lying along x
HANDLE = Material("pipette_body", (0.90, 0.90, 0.88), roughness=0.35)


def _asset(asset_id: str, description: str, body: Body, **kw) -> AssetDef:
    return AssetDef(asset_id, CATEGORY, description, [body], graspable=True, **kw)


def hand_pipette(asset_id: str, description: str, *, volume_ul: float, channels: int, button: Material, mass: float,
                 shaft_len: float) -> AssetDef:
    """An air-displacement pipette standing on its tip cone: shaft, grip, finger hook, plunger."""
    body = Body("body", mass)
    if channels == 1:
        cone = [(0.0012, 0.0), (0.0035, shaft_len * 0.55), (0.0055, shaft_len)]
        p.visual(body, "tip_cone", g.revolve([(0, 0), *cone, (0, shaft_len)], 20), p.GREY_PLASTIC)
        p.revolved_colliders(body, "shaft_col", cone, 2)
        p.visual(body, "ejector", g.revolve([(0, shaft_len * 0.7), (0.0075, shaft_len * 0.7), (0.0075, shaft_len + 0.004), (0, shaft_len + 0.004)], 20), HANDLE)
        base = shaft_len
    else:
        width = 0.009 * (channels - 1) + 0.012
        p.solid_box(body, "manifold", (0.016, width, 0.05), (0, 0, 0.035), p.GREY_PLASTIC, 0.003)
        noses = g.merge([g.revolve([(0, 0), (0.0012, 0.0), (0.003, 0.012), (0, 0.012)], 12).moved((0, 0.009 * (k - (channels - 1) / 2), -0.002 + 0.002)) for k in range(channels)])
        p.visual(body, "tip_cones", noses, p.GREY_PLASTIC)
        p.box_collider(body, "cones_col", (0.006, width - 0.006, 0.012), (0, 0, 0.006))
        p.solid_cylinder(body, "neck", 0.009, 0.04, (0, 0, 0.078), HANDLE)
        base = 0.098
    grip_h = 0.10
    grip = [(0.0, base), (0.010, base), (0.0145, base + 0.02), (0.0155, base + grip_h * 0.6), (0.013, base + grip_h), (0.0, base + grip_h)]
    p.visual(body, "grip", g.revolve(grip, 28), HANDLE)
    p.revolved_colliders(body, "grip_col", grip[1:5], 3)
    p.visual(body, "display", g.box((0.002, 0.012, 0.022), (-0.0152, 0, base + 0.065)), p.SCREEN)
    p.solid_box(body, "finger_hook", (0.028, 0.012, 0.010), (0.022, 0, base + grip_h - 0.012), HANDLE, 0.004)
    top = base + grip_h
    p.solid_cylinder(body, "plunger_rod", 0.0035, 0.022, (0, 0, top + 0.011), p.GREY_PLASTIC)
    p.solid_cylinder(body, "plunger_button", 0.0085, 0.010, (0, 0, top + 0.027), button)
    p.solid_box(body, "ejector_button", (0.008, 0.010, 0.020), (-0.012, 0, top + 0.004), p.GREY_PLASTIC)
    p.site(body, "tip", (0, 0, 0))
    p.site(body, "grasp", (0, 0, base + grip_h * 0.5))
    p.site(body, "plunger", (0, 0, top + 0.032))
    extra = {"volume_ul": volume_ul, "channels": float(channels), "length": top + 0.032, "hang_height": base}
    return _asset(asset_id, description, body, upright=False, rest_quat=ON_SIDE, extra=extra)


_PIPETTES = {
    "pipette_single_channel": ("Single-channel air-displacement pipette, 100-1000 uL (P1000).", 1000.0, 1, p.BLUE_PLASTIC, 0.090, 0.112),
    "pipette_single_channel_p200": ("Single-channel air-displacement pipette, 20-200 uL (P200).", 200.0, 1, p.YELLOW_PLASTIC, 0.085, 0.105),
    "pipette_single_channel_p20": ("Single-channel air-displacement pipette, 2-20 uL (P20).", 20.0, 1, p.RED_PLASTIC, 0.080, 0.100),
    "pipette_multichannel_8": ("8-channel pipette, 20-200 uL.", 200.0, 8, p.YELLOW_PLASTIC, 0.160, 0.0),
    "pipette_multichannel_12": ("12-channel pipette, 20-200 uL.", 200.0, 12, p.YELLOW_PLASTIC, 0.190, 0.0),
}
for _id, (_d, _v, _c, _b, _m, _s) in _PIPETTES.items():
    register(_id, CATEGORY, partial(hand_pipette, _id, _d, volume_ul=_v, channels=_c, button=_b, mass=_m, shaft_len=_s))


def lying_rod(asset_id: str, description: str, parts: list[tuple[str, float, float, Material]], mass: float, extra=None) -> AssetDef:
    """A tool lying along x made of coaxial cylinders ``(name, radius, length, material)``, left to right."""
    body = Body("body", mass)
    axis_z = max(r for _, r, _, _ in parts)
    total = sum(length for _, _, length, _ in parts)
    x = -total / 2
    for name, r, length, mat in parts:
        p.visual(body, name, g.cylinder(r, length, (0, 0, 0), 20).moved((x + length / 2, 0, axis_z), g.rotation("y", 90)), mat)
        half = math.sqrt(0.5)

        body.colliders.append(Collider(f"{name}_col", "cylinder", (r, length / 2), (x + length / 2, 0, axis_z), (half, 0, half, 0)))
        x += length
    # a flat key so round tools do not roll away
    p.solid_box(body, "anti_roll_key", (0.012, 0.004, 2 * axis_z), (-total / 2 + 0.01, 0, axis_z), parts[0][3])
    p.site(body, "grasp", (0, 0, axis_z))
    p.site(body, "tip", (total / 2, 0, axis_z))
    return _asset(asset_id, description, body, extra={"length": total, **(extra or {})})


register("serological_pipette_10ml", CATEGORY, partial(lying_rod, "serological_pipette_10ml", "10 mL sterile serological pipette (plastic) with cotton plug.",
         [("plug_end", 0.0045, 0.03, p.ORANGE_PLASTIC), ("barrel", 0.0045, 0.25, p.CLEAR_PLASTIC), ("taper", 0.0025, 0.03, p.CLEAR_PLASTIC)], 0.009, {"volume_ml": 10.0}))
register("serological_pipette_25ml", CATEGORY, partial(lying_rod, "serological_pipette_25ml", "25 mL sterile serological pipette (plastic).",
         [("plug_end", 0.0065, 0.03, p.RED_PLASTIC), ("barrel", 0.0065, 0.27, p.CLEAR_PLASTIC), ("taper", 0.0035, 0.03, p.CLEAR_PLASTIC)], 0.018, {"volume_ml": 25.0}))
register("glass_stirring_rod", CATEGORY, partial(lying_rod, "glass_stirring_rod", "Glass stirring rod, 6 mm x 200 mm.", [("rod", 0.003, 0.2, p.GLASS)], 0.012))
register("marker_pen", CATEGORY, partial(lying_rod, "marker_pen", "Fine-tip permanent lab marker with cap.",
         [("cap", 0.0065, 0.05, p.DARK_PLASTIC), ("barrel", 0.0058, 0.085, p.WHITE_PLASTIC), ("nib", 0.002, 0.008, p.DARK_PLASTIC)], 0.012))
register("inoculation_loop", CATEGORY, partial(lying_rod, "inoculation_loop", "Disposable 10 uL inoculation loop.",
         [("handle", 0.0022, 0.17, p.BLUE_PLASTIC), ("stem", 0.0008, 0.03, p.BLUE_PLASTIC), ("loop", 0.0022, 0.002, p.BLUE_PLASTIC)], 0.0015))


def flat_tool(asset_id: str, description: str, pieces: list[tuple[str, tuple[float, float, float], tuple[float, float, float], Material]],
              mass: float, grasp: tuple[float, float, float]) -> AssetDef:
    """A tool lying flat, built from boxes ``(name, size, centre, material)``."""
    body = Body("body", mass)
    for name, size, centre, mat in pieces:
        p.solid_box(body, name, size, centre, mat, min(size[0], size[1]) * 0.3)
    p.site(body, "grasp", grasp)
    return _asset(asset_id, description, body)


def _tweezers() -> AssetDef:
    body = Body("body", 0.012)
    for side in (-1, 1):
        arm = g.box((0.12, 0.004, 0.0012), (0, 0, 0)).moved((0, side * 0.005, 0.0006), g.rotation("z", -side * 2.5))
        p.visual(body, f"arm_{'l' if side < 0 else 'r'}", arm, p.STEEL)
        p.box_collider(body, f"arm_{'l' if side < 0 else 'r'}_col", (0.12, 0.004, 0.0012), (0, side * 0.005, 0.0006),
                       (math.cos(math.radians(-side * 1.25)), 0, 0, math.sin(math.radians(-side * 1.25))))
    p.solid_box(body, "joint_block", (0.012, 0.016, 0.003), (-0.058, 0, 0.0015), p.STEEL)
    p.site(body, "grasp", (-0.02, 0, 0.0015))
    p.site(body, "tip", (0.06, 0, 0.0006))
    return _asset("tweezers", "Stainless-steel fine-tip tweezers, 120 mm.", body, extra={"length": 0.125})


register("tweezers", CATEGORY, _tweezers)
register("spatula", CATEGORY, partial(flat_tool, "spatula", "Stainless-steel micro spatula with flat and spoon ends, 180 mm.",
         [("blade", (0.045, 0.009, 0.0015), (0.0675, 0, 0.00075), p.STEEL), ("shank", (0.10, 0.004, 0.0025), (0.0, 0, 0.00125), p.STEEL),
          ("spoon_end", (0.035, 0.007, 0.0015), (-0.0675, 0, 0.00075), p.STEEL)], 0.015, (0, 0, 0.002)))
register("cell_scraper", CATEGORY, partial(flat_tool, "cell_scraper", "Sterile cell scraper, 25 cm handle, 1.8 cm blade.",
         [("handle", (0.22, 0.008, 0.006), (-0.01, 0, 0.003), p.BLUE_PLASTIC), ("blade", (0.012, 0.018, 0.004), (0.105, 0, 0.002), p.WHITE_PLASTIC)], 0.008, (-0.05, 0, 0.006)))


def _pipette_controller() -> AssetDef:
    body = Body("body", 0.22)
    p.solid_box(body, "handle", (0.035, 0.030, 0.11), (0.0, 0, 0.055), p.BLUE_PLASTIC, 0.012)
    p.solid_box(body, "head", (0.13, 0.040, 0.045), (-0.035, 0, 0.125), p.WHITE_PLASTIC, 0.015)
    p.solid_cylinder(body, "nose", 0.009, 0.035, (-0.085, 0, 0.085), p.GREY_PLASTIC)
    p.solid_box(body, "trigger_up", (0.012, 0.014, 0.018), (-0.022, 0, 0.092), p.DARK_PLASTIC)
    p.site(body, "grasp", (0, 0, 0.06))
    p.site(body, "nose", (-0.085, 0, 0.068))
    return _asset("pipette_controller", "Battery pipette controller (pipet-aid) for serological pipettes; rests on its side.",
                  body, upright=False, rest_quat=(math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0), extra={"height": 0.1475})


register("pipette_controller", CATEGORY, _pipette_controller)
