"""Offscreen thumbnails of assets and a labelled contact sheet (``pipette assets render``).

Each asset is attached alone above a floor, framed from the front-left (the robot's side is
-x) and rendered with MuJoCo's renderer; collision shapes and sites are hidden. Needs an
offscreen GL context: set ``MUJOCO_GL=egl`` (or ``osmesa``) on a headless machine.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image, ImageDraw

from pipette_cli.assets.library import CATEGORIES, AssetEntry
from pipette_cli.assets.loader import attach_asset
from pipette_cli.errors import AssetError

TILE = (220, 200)  # width, height of one thumbnail in pixels
LABEL_H = 18


def _scene_for(entry: AssetEntry):
    scene = mujoco.MjSpec()
    scene.visual.global_.offwidth = 1024
    scene.visual.global_.offheight = 1024
    scene.visual.headlight.ambient = [0.45, 0.45, 0.45]
    scene.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    scene.visual.quality.shadowsize = 4096
    scene.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.98, 0.98, 1.0],
        rgb2=[0.85, 0.88, 0.92],
        width=256,
        height=256,
    )
    scene.add_texture(
        name="grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.90, 0.91, 0.92],
        rgb2=[0.86, 0.87, 0.89],
        width=256,
        height=256,
    )
    scene.add_material(name="floor_mat", textures=["", "grid"], texrepeat=[8, 8], reflectance=0.0)
    scene.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], material="floor_mat", group=1)
    scene.worldbody.add_light(
        pos=[-1.0, -1.5, 4.0], dir=[0.25, 0.35, -1.0], castshadow=True, diffuse=[0.55, 0.55, 0.55]
    )
    attach_asset(scene, entry.path, name="asset", free_joint=False)
    return scene


def render_asset(entry: AssetEntry, size: tuple[int, int] = TILE) -> np.ndarray:
    """Render one asset to an ``(h, w, 3)`` uint8 image."""
    try:
        model = _scene_for(entry).compile()
    except Exception as exc:
        raise AssetError(f"{entry.asset_id}: cannot build a render scene: {exc}") from None
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo, hi = _visual_bounds(model, data)
    centre = (lo + hi) / 2
    extent = float(np.linalg.norm(hi - lo))
    cam = mujoco.MjvCamera()
    cam.lookat[:] = centre
    cam.azimuth, cam.elevation = 35.0, -24.0  # from the front-right (-x, -y), where the robot stands
    fovy = math.radians(model.vis.global_.fovy)
    cam.distance = 0.62 * extent / math.tan(fovy / 2) + 1e-3
    option = mujoco.MjvOption()
    option.geomgroup[:] = [1, 1, 1, 0, 0, 0]
    option.sitegroup[:] = [0] * 6
    width, height = size
    with mujoco.Renderer(model, height, width) as renderer:
        renderer.update_scene(data, camera=cam, scene_option=option)
        return renderer.render().copy()


def _visual_bounds(model, data) -> tuple[np.ndarray, np.ndarray]:
    lows, highs = [], []
    for g in range(model.ngeom):
        if model.geom_group[g] != 2:
            continue
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        rot = data.geom_xmat[g].reshape(3, 3)
        world_c = data.geom_xpos[g] + rot @ centre
        world_h = np.abs(rot) @ half
        lows.append(world_c - world_h)
        highs.append(world_c + world_h)
    if not lows:
        return np.zeros(3), np.full(3, 0.1)
    return np.min(lows, axis=0), np.max(highs, axis=0)


def contact_sheet(
    entries: Sequence[AssetEntry],
    out: Path,
    *,
    columns: int = 12,
    tile: tuple[int, int] = TILE,
    progress: Callable[[str], None] | None = None,
) -> Path:
    """Render ``entries`` grouped by category into one labelled PNG at ``out``."""
    by_cat = {c: [e for e in entries if e.category == c] for c in CATEGORIES}
    tw, th = tile
    header = 30
    rows = sum(math.ceil(len(v) / columns) for v in by_cat.values() if v)
    width = columns * tw
    height = rows * (th + LABEL_H) + header * sum(1 for v in by_cat.values() if v)
    sheet = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    y = 0
    for category, items in by_cat.items():
        if not items:
            continue
        draw.rectangle([0, y, width, y + header - 1], fill=(40, 60, 85))
        draw.text((10, y + 8), f"{category}  ({len(items)})", fill=(255, 255, 255))
        y += header
        for i, entry in enumerate(sorted(items, key=lambda e: e.asset_id)):
            if progress:
                progress(entry.asset_id)
            col, row = i % columns, i // columns
            x0, y0 = col * tw, y + row * (th + LABEL_H)
            sheet.paste(Image.fromarray(render_asset(entry, tile)), (x0, y0))
            draw.text((x0 + 4, y0 + th + 3), entry.asset_id[:36], fill=(20, 20, 20))
        y += math.ceil(len(items) / columns) * (th + LABEL_H)
    out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(out)
    return out
