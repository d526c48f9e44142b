"""Reusable parts for the generators: a material palette and visual+collider helpers.

Each helper adds both what is seen (a mesh) and what collides (primitives) to a body, so a
generator reads as a list of physical parts rather than of USD prims.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pipette_cli.assets import geometry as g
from pipette_cli.assets.model import Body, Collider, Material, Site, Visual

GLASS = Material("glass", (0.80, 0.92, 0.95), opacity=0.35, roughness=0.05)
CLEAR_PLASTIC = Material("clear_plastic", (0.92, 0.94, 0.96), opacity=0.45, roughness=0.15)
AMBER_GLASS = Material("amber_glass", (0.55, 0.30, 0.08), opacity=0.6, roughness=0.05)
WHITE_PLASTIC = Material("white_plastic", (0.93, 0.93, 0.91), roughness=0.4)
GREY_PLASTIC = Material("grey_plastic", (0.55, 0.57, 0.60), roughness=0.5)
DARK_PLASTIC = Material("dark_plastic", (0.16, 0.17, 0.19), roughness=0.5)
BLUE_PLASTIC = Material("blue_plastic", (0.15, 0.35, 0.75), roughness=0.4)
RED_PLASTIC = Material("red_plastic", (0.78, 0.15, 0.12), roughness=0.4)
YELLOW_PLASTIC = Material("yellow_plastic", (0.95, 0.78, 0.15), roughness=0.4)
GREEN_PLASTIC = Material("green_plastic", (0.20, 0.62, 0.30), roughness=0.4)
ORANGE_PLASTIC = Material("orange_plastic", (0.95, 0.50, 0.10), roughness=0.4)
PURPLE_PLASTIC = Material("purple_plastic", (0.50, 0.30, 0.70), roughness=0.4)
STEEL = Material("steel", (0.72, 0.74, 0.76), roughness=0.25, metallic=0.9)
ALUMINIUM = Material("aluminium", (0.80, 0.81, 0.83), roughness=0.35, metallic=0.8)
BENCH_TOP = Material("bench_top", (0.20, 0.22, 0.24), roughness=0.7)
PAINTED_METAL = Material("painted_metal", (0.88, 0.89, 0.88), roughness=0.45)
SCREEN = Material("screen", (0.10, 0.25, 0.30), roughness=0.1)
RUBBER = Material("rubber", (0.12, 0.12, 0.12), roughness=0.9)
FOAM = Material("foam", (0.92, 0.93, 0.95), roughness=0.9)
WATER = Material("water", (0.55, 0.75, 0.90), opacity=0.5, roughness=0.05)
AGAR = Material("agar", (0.93, 0.80, 0.55), opacity=0.8, roughness=0.3)
MEDIUM = Material("culture_medium", (0.90, 0.45, 0.45), opacity=0.6, roughness=0.1)
CORK = Material("cork", (0.65, 0.50, 0.35), roughness=0.9)

CAP_COLOURS = {
    "blue": BLUE_PLASTIC,
    "red": RED_PLASTIC,
    "yellow": YELLOW_PLASTIC,
    "green": GREEN_PLASTIC,
    "orange": ORANGE_PLASTIC,
    "white": WHITE_PLASTIC,
    "purple": PURPLE_PLASTIC,
}


def _xyz(v: Sequence[float]) -> tuple[float, float, float]:
    x, y, z = (float(c) for c in v)
    return x, y, z


def visual(body: Body, name: str, mesh: g.Mesh, material: Material) -> None:
    body.visuals.append(Visual(name, mesh, material))


def box_collider(body: Body, name: str, size: Sequence[float], center: Sequence[float], quat=None) -> None:
    half = tuple(s / 2 for s in size)
    body.colliders.append(Collider(name, "box", half, _xyz(center), quat or (1.0, 0.0, 0.0, 0.0)))


def cylinder_collider(body: Body, name: str, radius: float, height: float, center: Sequence[float]) -> None:
    body.colliders.append(Collider(name, "cylinder", (radius, height / 2), _xyz(center)))


def solid_box(
    body: Body, name: str, size: Sequence[float], center: Sequence[float], material: Material, radius: float = 0.0
) -> None:
    """A box seen and collided as one (round vertical edges are visual only)."""
    visual(body, name, g.box(size, center, radius), material)
    box_collider(body, f"{name}_col", size, center)


def solid_cylinder(
    body: Body, name: str, radius: float, height: float, center: Sequence[float], material: Material, segments: int = 24
) -> None:
    visual(body, name, g.cylinder(radius, height, center, segments), material)
    cylinder_collider(body, f"{name}_col", radius, height, center)


def ring_colliders(
    body: Body, name: str, r_in: float, r_out: float, z0: float, z1: float, count: int = 12, center=(0.0, 0.0)
) -> None:
    """Wall of a round container as ``count`` tangential boxes (a tube can stand inside)."""
    r_mid = (r_in + r_out) / 2
    width = 2 * r_out * math.tan(math.pi / count)
    for k in range(count):
        a = 2 * math.pi * k / count
        quat = (math.cos(a / 2), 0.0, 0.0, math.sin(a / 2))
        pos = (center[0] + r_mid * math.cos(a), center[1] + r_mid * math.sin(a), (z0 + z1) / 2)
        box_collider(body, f"{name}_{k}", (r_out - r_in, width, z1 - z0), pos, quat)


def vessel_profile(outer: Sequence[tuple[float, float]], wall: float, bottom: float) -> list[tuple[float, float]]:
    """Closed revolve profile of a thin-walled open vessel.

    ``outer`` runs from the base edge ``(r0, 0)`` up to the rim ``(r_rim, height)``; the inside
    surface is the outside moved in by ``wall``, down to a floor at ``bottom``.
    """
    inner = [(max(r - wall, 0.0005), z) for r, z in outer if z > bottom + 1e-6]
    floor_r = max(outer[0][0] - wall, 0.0005)
    return [(0.0, 0.0), *outer, *reversed(inner), (floor_r, bottom), (0.0, bottom)]


def grid_bars(
    body: Body,
    name: str,
    nx: int,
    ny: int,
    pitch: tuple[float, float],
    hole: tuple[float, float],
    z0: float,
    z1: float,
    center=(0.0, 0.0),
) -> None:
    """A plate with an ``nx`` x ``ny`` grid of rectangular holes, as crossing bars (colliders)."""
    px, py = pitch
    span_x, span_y = nx * px, ny * py
    bar_x = px - hole[0]
    bar_y = py - hole[1]
    zc, h = (z0 + z1) / 2, z1 - z0
    for i in range(nx + 1):
        x = center[0] - span_x / 2 + i * px
        box_collider(body, f"{name}_x{i}", (bar_x, span_y + bar_y, h), (x, center[1], zc))
    for j in range(ny + 1):
        y = center[1] - span_y / 2 + j * py
        box_collider(body, f"{name}_y{j}", (span_x + bar_x, bar_y, h), (center[0], y, zc))


def grid_positions(nx: int, ny: int, pitch: tuple[float, float], center=(0.0, 0.0)) -> list[tuple[float, float]]:
    """Hole centres of a grid, row by row (x fastest)."""
    return [
        (center[0] + (i - (nx - 1) / 2) * pitch[0], center[1] + (j - (ny - 1) / 2) * pitch[1])
        for j in range(ny)
        for i in range(nx)
    ]


def solid_cylinder_x(
    body: Body, name: str, radius: float, length: float, center: Sequence[float], material: Material, segments: int = 20
) -> None:
    """A cylinder lying along X (seen and collided)."""
    visual(body, name, g.cylinder(radius, length, (0, 0, 0), segments).moved(center, g.rotation("y", 90)), material)
    half = math.sqrt(0.5)
    body.colliders.append(
        Collider(f"{name}_col", "cylinder", (radius, length / 2), _xyz(center), (half, 0.0, half, 0.0))
    )


def revolved_colliders(
    body: Body, name: str, outer: Sequence[tuple[float, float]], slices: int, z0: float | None = None
) -> None:
    """Approximate a solid of revolution (outer profile, z increasing) by stacked cylinders."""
    rs = [p[0] for p in outer]
    zs = [p[1] for p in outer]
    lo = zs[0] if z0 is None else z0
    edges = [lo + (zs[-1] - lo) * k / slices for k in range(slices + 1)]
    for k in range(slices):
        a, b = edges[k], edges[k + 1]
        samples = [a + (b - a) * t for t in (0.25, 0.5, 0.75)]
        r = float(sum(_interp(z, zs, rs) for z in samples) / 3)
        cylinder_collider(body, f"{name}_{k}", max(r, 0.0005), b - a, (0.0, 0.0, (a + b) / 2))


def _interp(z: float, zs: Sequence[float], rs: Sequence[float]) -> float:
    for i in range(len(zs) - 1):
        if zs[i] <= z <= zs[i + 1]:
            span = zs[i + 1] - zs[i]
            t = 0.0 if span <= 0 else (z - zs[i]) / span
            return rs[i] + t * (rs[i + 1] - rs[i])
    return rs[-1] if z > zs[-1] else rs[0]


def open_box(
    body: Body,
    name: str,
    size: Sequence[float],
    wall: float,
    floor: float,
    material: Material,
    center: Sequence[float] = (0.0, 0.0),
    z0: float = 0.0,
    dividers: int = 0,
) -> None:
    """An open-topped rectangular box (tray, trough, bin) made of a floor and four walls."""
    sx, sy, sz = size
    cx, cy = center
    solid_box(body, f"{name}_floor", (sx, sy, floor), (cx, cy, z0 + floor / 2), material)
    h = sz - floor
    zc = z0 + floor + h / 2
    solid_box(body, f"{name}_wall_xn", (wall, sy, h), (cx - sx / 2 + wall / 2, cy, zc), material)
    solid_box(body, f"{name}_wall_xp", (wall, sy, h), (cx + sx / 2 - wall / 2, cy, zc), material)
    solid_box(body, f"{name}_wall_yn", (sx - 2 * wall, wall, h), (cx, cy - sy / 2 + wall / 2, zc), material)
    solid_box(body, f"{name}_wall_yp", (sx - 2 * wall, wall, h), (cx, cy + sy / 2 - wall / 2, zc), material)
    for k in range(dividers):
        x = cx - sx / 2 + sx * (k + 1) / (dividers + 1)
        solid_box(
            body, f"{name}_divider_{k}", (wall * 0.7, sy - 2 * wall, h * 0.9), (x, cy, z0 + floor + h * 0.45), material
        )


def site(body: Body, name: str, pos: Sequence[float], radius: float = 0.005) -> None:
    body.sites.append(Site(name, tuple(float(v) for v in pos), radius))  # type: ignore[arg-type]
