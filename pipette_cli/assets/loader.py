"""USD asset -> ``mujoco.MjSpec``, through MuJoCo's own USD import (``mujoco[usd]``).

``MjSpec.from_file("x.usda")`` does the conversion. This module only does what that
import does not (each step is small and listed in ``docs/assets.md``):

* names: the import names every element by its full prim path (``/centrifuge_benchtop/lid``);
  we rename to the leaf (``lid``) so ``MjSpec.attach(prefix="centrifuge/")`` gives
  ``centrifuge/lid``;
* transparency: the import reads ``diffuseColor``/``roughness``/``metallic`` of a
  ``UsdPreviewSurface`` but not ``opacity``; we copy it into the material alpha;
* the free joint the import adds to an unjointed top-level body is named ``free`` (or
  removed with ``free_joint=False``);
* contacts between two bodies joined by a joint are excluded (``physics:collisionEnabled``
  is false by default on a ``UsdPhysics`` joint, which the import does not read; without it
  a lid would collide with the case it is hinged to, because MuJoCo only filters
  parent/child contacts when the parent is not welded to the world);
* gravity is reset to exactly (0, 0, -9.81) so attaching raises no float32 conflict warning.
"""

from __future__ import annotations

from pathlib import Path

import mujoco

from pipette_cli.assets.library import AssetEntry, load_asset_library
from pipette_cli.assets.semantics import open_stage
from pipette_cli.errors import AssetError

FREE_JOINT = "free"


def resolve_asset(asset: str | Path) -> tuple[str, Path]:
    """Return ``(asset_id, path)`` for an asset id or a path to a ``.usd*`` file."""
    text = str(asset)
    if isinstance(asset, Path) or text.endswith((".usda", ".usd", ".usdc", ".usdz")) or "/" in text:
        path = Path(text)
        if not path.is_file():
            raise AssetError(f"asset file {path} does not exist")
        return path.stem, path
    entry: AssetEntry = load_asset_library().get(text)
    return entry.asset_id, entry.path


def load_asset_spec(asset: str | Path, *, free_joint: bool = True):
    """Import an asset into a fresh ``mujoco.MjSpec`` with short element names.

    Args:
        asset: An asset id (``"centrifuge_benchtop"``) or a path to a USD file.
        free_joint: Keep the free joint of a free-standing object (named ``free``). Pass
            ``False`` when the scene gives the object its own joint or welds it.

    Returns:
        The spec. Free objects have one top-level body ``body`` with joint ``free``; static
        assets have a top-level body ``base`` with no joint (welded to whatever it is
        attached to), and their moving parts as child bodies with named joints.

    Raises:
        AssetError: the file is missing, does not parse, or MuJoCo rejects it.
    """
    asset_id, path = resolve_asset(asset)
    stage = open_stage(path)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # the importer raises ValueError/FatalError with its own text
        raise AssetError(f"{asset_id}: MuJoCo USD import failed: {exc}") from None
    spec.modelname = asset_id
    spec.option.gravity = [0.0, 0.0, -9.81]
    _shorten_names(spec, asset_id)
    _copy_opacity(spec, stage)
    _exclude_jointed_pairs(spec, stage)
    for body in spec.worldbody.bodies:
        for joint in body.joints:
            if joint.type == mujoco.mjtJoint.mjJNT_FREE:
                if free_joint:
                    joint.name = FREE_JOINT
                else:
                    spec.delete(joint)
    return spec


def _leaf(name: str) -> str:
    return name.rsplit("/", 1)[-1]


def _shorten_names(spec, asset_id: str) -> None:
    renamed: dict[str, dict[str, str]] = {}
    groups = {
        "mesh": spec.meshes,
        "material": spec.materials,
        "texture": spec.textures,
        "body": spec.bodies,
        "geom": spec.geoms,
        "site": spec.sites,
        "joint": spec.joints,
        "actuator": spec.actuators,
    }
    for kind, elements in groups.items():
        taken: set[str] = set()
        mapping = renamed.setdefault(kind, {})
        for element in elements:
            old = element.name
            if not old or "/" not in old:
                continue
            new = _leaf(old)
            if new in taken:
                raise AssetError(f"{asset_id}: two {kind}s are both named {new!r}; prim names must be unique per kind")
            taken.add(new)
            mapping[old] = new
            element.name = new
    for geom in spec.geoms:
        if geom.meshname in renamed["mesh"]:
            geom.meshname = renamed["mesh"][geom.meshname]
        if geom.material in renamed["material"]:
            geom.material = renamed["material"][geom.material]
    for actuator in spec.actuators:
        if actuator.target in renamed["joint"]:
            actuator.target = renamed["joint"][actuator.target]


def _exclude_jointed_pairs(spec, stage) -> None:
    # deferred: pxr.Usd (~110 ms; sim.scene, loaded by every command, imports this module)
    from pxr import UsdPhysics

    for prim in stage.Traverse():
        if not prim.IsA(UsdPhysics.Joint):
            continue
        joint = UsdPhysics.Joint(prim)
        if joint.GetCollisionEnabledAttr().Get():
            continue
        body0, body1 = joint.GetBody0Rel().GetTargets(), joint.GetBody1Rel().GetTargets()
        if len(body0) == 1 and len(body1) == 1:
            spec.add_exclude(name=f"{prim.GetName()}_pair", bodyname1=body0[0].name, bodyname2=body1[0].name)


def _copy_opacity(spec, stage) -> None:
    from pxr import UsdShade  # deferred: pxr.Usd (as above)

    by_leaf = {}
    for prim in stage.Traverse():
        if prim.IsA(UsdShade.Material):
            shader = UsdShade.Material(prim).ComputeSurfaceSource()[0]
            opacity = shader.GetInput("opacity") if shader else None
            if opacity and opacity.Get() is not None:
                by_leaf[prim.GetName()] = float(opacity.Get())
    for material in spec.materials:
        alpha = by_leaf.get(material.name)
        if alpha is not None and alpha < 1.0:
            rgba = list(material.rgba)
            material.rgba = [rgba[0], rgba[1], rgba[2], alpha]


def attach_asset(
    scene, asset: str | Path, *, name: str, pos=(0.0, 0.0, 0.0), quat=(1.0, 0.0, 0.0, 0.0), parent=None, free_joint=True
):
    """Attach ``asset`` into ``scene`` (an ``MjSpec``) under a frame, with prefix ``name + "/"``.

    Free objects keep their free joint only when ``parent`` is the world body; static assets
    are welded to ``parent`` (the world body by default). Returns the attached root body.
    """
    child = load_asset_spec(asset, free_joint=free_joint and parent is None)
    parent_body = scene.worldbody if parent is None else parent
    root = child.worldbody.first_body()
    root_name = root.name if root is not None else None
    frame = parent_body.add_frame(pos=list(pos), quat=list(quat))
    scene.attach(child, prefix=f"{name}/", frame=frame)
    return scene.body(f"{name}/{root_name}") if root_name else None
