"""Write an :class:`~pipette_cli.assets.model.AssetDef` as a human-editable ``.usda`` file.

What is authored, and what reads it:

* ``UsdPhysics``: rigid bodies with ``MassAPI`` (mass, centre of mass, diagonal inertia,
  principal axes), primitive colliders (``Cube``/``Cylinder``/``Sphere``/``Capsule`` with
  ``CollisionAPI``, purpose ``guide`` so viewers hide them), revolute/prismatic joints with
  limits, a ``FixedJoint`` to the world for static assets, and ``DriveAPI`` on driven joints.
  MuJoCo's USD import (``mujoco[usd]``) reads all of these except the drive.
* ``MjcPhysics`` (MuJoCo's schema): ``MjcActuator`` position servos (a ``UsdPhysics`` drive
  is not turned into an actuator), ``MjcSiteAPI`` sites, ``MjcCollisionAPI`` /
  ``MjcImageableAPI`` geom groups (visual 2, collision 3, sites 4).
* ``NewtonJointAPI``: joint damping, dry friction and armature (MuJoCo 4 reads these in
  place of the deprecated ``mjc:damping``; angular damping is per degree).
* ``UsdShade``: one ``UsdPreviewSurface`` per material (``opacity`` < 1 for glass).
* Task semantics as ``pipette:*`` custom attributes on the default prim.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco  # noqa: F401  (registers the MjcPhysics and Newton USD schemas with pxr)
from pxr import Gf, Kind, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

from pipette_cli.assets.model import AssetDef, Body, Collider, Joint, Material, PositionDrive

VISUAL_GROUP = 2
COLLISION_GROUP = 3
SITE_GROUP = 4
_AXIS_FLIP = {"x": Gf.Quatf(0, 0, 0, 1), "y": Gf.Quatf(0, 0, 0, 1), "z": Gf.Quatf(0, 1, 0, 0)}


def _r(v: float) -> float:
    return round(float(v), 6)


def _vec3(v) -> Gf.Vec3f:
    return Gf.Vec3f(*(_r(x) for x in v))


def write_usda(asset: AssetDef, path: Path) -> None:
    """Author ``asset`` into ``path`` (overwritten), as ASCII USD."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    root_path = Sdf.Path(f"/{asset.asset_id}")
    root = UsdGeom.Xform.Define(stage, root_path).GetPrim()
    stage.SetDefaultPrim(root)
    Usd.ModelAPI(root).SetKind(Kind.Tokens.component)
    Usd.ModelAPI(root).SetAssetName(asset.asset_id)
    stage.GetRootLayer().documentation = f"Pipette asset {asset.asset_id} ({asset.category}): {asset.description}"
    _write_semantics(root, asset)

    looks = UsdGeom.Scope.Define(stage, root_path.AppendChild("Looks"))
    materials = {m.name: _define_material(stage, looks.GetPath(), m) for m in _all_materials(asset)}
    for body in asset.bodies:
        _define_body(stage, root_path, body, materials)
    if asset.static:
        anchor = UsdPhysics.FixedJoint.Define(stage, root_path.AppendChild(f"{asset.main_body.name}_anchor"))
        anchor.CreateBody1Rel().SetTargets([root_path.AppendChild(asset.main_body.name)])
    bodies = {b.name: b for b in asset.bodies}
    for joint in asset.joints:
        _define_joint(stage, root_path, joint, bodies)
    for drive in asset.drives:
        _define_drive(stage, root_path, drive, next(j for j in asset.joints if j.name == drive.joint))
    path.parent.mkdir(parents=True, exist_ok=True)
    stage.GetRootLayer().Export(str(path))


def _all_materials(asset: AssetDef) -> list[Material]:
    seen: dict[str, Material] = {m.name: m for m in asset.materials}
    for b in asset.bodies:
        for v in b.visuals:
            seen.setdefault(v.material.name, v.material)
    return list(seen.values())


def _write_semantics(prim: Usd.Prim, asset: AssetDef) -> None:
    def put(name: str, type_name: Sdf.ValueTypeName, value) -> None:
        prim.CreateAttribute(f"pipette:{name}", type_name, custom=True).Set(value)

    put("category", Sdf.ValueTypeNames.String, asset.category)
    put("description", Sdf.ValueTypeNames.String, asset.description)
    put("graspable", Sdf.ValueTypeNames.Bool, asset.graspable)
    put("static", Sdf.ValueTypeNames.Bool, asset.static)
    put("upright", Sdf.ValueTypeNames.Bool, asset.upright)
    put("rest_quat", Sdf.ValueTypeNames.DoubleArray, Vt.DoubleArray([_r(q) for q in asset.rest_quat]))
    put("mass", Sdf.ValueTypeNames.Double, _r(asset.total_mass()))
    put("dimensions", Sdf.ValueTypeNames.Double3, Gf.Vec3d(*asset.dimensions()))
    put("main_body", Sdf.ValueTypeNames.String, asset.main_body.name)
    put("bodies", Sdf.ValueTypeNames.StringArray, [b.name for b in asset.bodies])
    put("sites", Sdf.ValueTypeNames.StringArray, asset.site_names())
    put("joints", Sdf.ValueTypeNames.StringArray, [j.name for j in asset.joints if j.kind != "fixed"])
    put("actuators", Sdf.ValueTypeNames.StringArray, [d.name for d in asset.drives])
    for key, value in sorted(asset.extra.items()):
        if isinstance(value, bool):
            put(key, Sdf.ValueTypeNames.Bool, value)
        elif isinstance(value, str):
            put(key, Sdf.ValueTypeNames.String, value)
        elif isinstance(value, tuple):
            put(key, Sdf.ValueTypeNames.DoubleArray, Vt.DoubleArray([_r(v) for v in value]))
        else:
            put(key, Sdf.ValueTypeNames.Double, _r(value))


def _define_material(stage: Usd.Stage, scope: Sdf.Path, mat: Material) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, scope.AppendChild(mat.name))
    shader = UsdShade.Shader.Define(stage, material.GetPath().AppendChild("surface"))
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*mat.color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(mat.roughness)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(mat.metallic)
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(mat.opacity)
    if mat.opacity < 1:
        shader.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.5)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def _set_group(prim: Usd.Prim, api: str, group: int) -> None:
    prim.AddAppliedSchema(api)  # MuJoCo's mjcPhysics schemas are not registered in usd-core: no validation
    prim.CreateAttribute("mjc:group", Sdf.ValueTypeNames.Int, custom=False, variability=Sdf.VariabilityUniform).Set(
        group
    )


def _define_body(stage: Usd.Stage, root: Sdf.Path, body: Body, materials: dict[str, UsdShade.Material]) -> None:
    xform = UsdGeom.Xform.Define(stage, root.AppendChild(body.name))
    if any(body.pos):
        xform.AddTranslateOp().Set(Gf.Vec3d(*(_r(v) for v in body.pos)))
    prim = xform.GetPrim()
    UsdPhysics.RigidBodyAPI.Apply(prim)
    mass_api = UsdPhysics.MassAPI.Apply(prim)
    com, moments, axes = body.mass_properties()
    mass_api.CreateMassAttr(_r(body.mass))
    mass_api.CreateCenterOfMassAttr(_vec3(com))
    mass_api.CreateDiagonalInertiaAttr(Gf.Vec3f(*(float(f"{max(m, 1e-12):.6g}") for m in moments)))
    mass_api.CreatePrincipalAxesAttr(Gf.Quatf(*(_r(q) for q in axes)))
    for visual in body.visuals:
        mesh = UsdGeom.Mesh.Define(stage, xform.GetPath().AppendChild(visual.name))
        points = [Gf.Vec3f(*(_r(c) for c in p)) for p in visual.mesh.points]
        mesh.CreatePointsAttr(points)
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray([int(c) for c in visual.mesh.counts]))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in visual.mesh.indices]))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        lo, hi = visual.mesh.bounds()
        mesh.CreateExtentAttr([_vec3(lo), _vec3(hi)])
        mesh.CreateDisplayColorAttr([Gf.Vec3f(*visual.material.color)])
        if visual.material.opacity < 1:
            mesh.CreateDisplayOpacityAttr([visual.material.opacity])
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(materials[visual.material.name])
        _set_group(mesh.GetPrim(), "MjcImageableAPI", VISUAL_GROUP)
    for collider in body.colliders:
        _define_collider(stage, xform.GetPath(), collider, body.condim)
    for site in body.sites:
        sphere = UsdGeom.Sphere.Define(stage, xform.GetPath().AppendChild(site.name))
        sphere.CreateRadiusAttr(site.radius)
        sphere.AddTranslateOp().Set(Gf.Vec3d(*(_r(v) for v in site.pos)))
        sphere.CreatePurposeAttr(UsdGeom.Tokens.guide)
        _set_group(sphere.GetPrim(), "MjcSiteAPI", SITE_GROUP)


def _define_collider(stage: Usd.Stage, parent: Sdf.Path, c: Collider, condim: int = 3) -> None:
    path = parent.AppendChild(c.name)
    if c.kind == "box":
        gprim = UsdGeom.Cube.Define(stage, path)
        gprim.CreateSizeAttr(1.0)
    elif c.kind == "sphere":
        gprim = UsdGeom.Sphere.Define(stage, path)
        gprim.CreateRadiusAttr(_r(c.size[0]))
    elif c.kind == "cylinder":
        gprim = UsdGeom.Cylinder.Define(stage, path)
        gprim.CreateRadiusAttr(_r(c.size[0]))
        gprim.CreateHeightAttr(_r(2 * c.size[1]))
        gprim.CreateAxisAttr(UsdGeom.Tokens.z)
    else:
        gprim = UsdGeom.Capsule.Define(stage, path)
        gprim.CreateRadiusAttr(_r(c.size[0]))
        gprim.CreateHeightAttr(_r(2 * c.size[1]))
        gprim.CreateAxisAttr(UsdGeom.Tokens.z)
    gprim.AddTranslateOp().Set(Gf.Vec3d(*(_r(v) for v in c.pos)))
    if c.quat != (1.0, 0.0, 0.0, 0.0):
        gprim.AddOrientOp().Set(Gf.Quatf(*(_r(q) for q in c.quat)))
    if c.kind == "box":
        gprim.AddScaleOp().Set(Gf.Vec3f(*(_r(2 * s) for s in c.size)))
    gprim.CreatePurposeAttr(UsdGeom.Tokens.guide)
    gprim.CreateDisplayColorAttr([Gf.Vec3f(0.9, 0.4, 0.1)])
    UsdPhysics.CollisionAPI.Apply(gprim.GetPrim())
    _set_group(gprim.GetPrim(), "MjcCollisionAPI", COLLISION_GROUP)
    if condim != 3:
        gprim.GetPrim().CreateAttribute(
            "mjc:condim", Sdf.ValueTypeNames.Int, custom=False, variability=Sdf.VariabilityUniform
        ).Set(condim)


def _axis(axis: str) -> tuple[str, Gf.Quatf]:
    name = axis.lstrip("+-").lower()
    flip = _AXIS_FLIP[name] if axis.startswith("-") else Gf.Quatf(1, 0, 0, 0)
    return name.upper(), flip


def _define_joint(stage: Usd.Stage, root: Sdf.Path, joint: Joint, bodies: dict[str, Body]) -> None:
    path = root.AppendChild(joint.name)
    if joint.kind == "fixed":
        prim_joint = UsdPhysics.FixedJoint.Define(stage, path)
    elif joint.kind == "revolute":
        prim_joint = UsdPhysics.RevoluteJoint.Define(stage, path)
    else:
        prim_joint = UsdPhysics.PrismaticJoint.Define(stage, path)
    parent, child = bodies[joint.parent], bodies[joint.child]
    prim_joint.CreateBody0Rel().SetTargets([root.AppendChild(parent.name)])
    prim_joint.CreateBody1Rel().SetTargets([root.AppendChild(child.name)])
    anchor = list(joint.anchor)
    prim_joint.CreateLocalPos0Attr(_vec3([a - p for a, p in zip(anchor, parent.pos, strict=True)]))
    prim_joint.CreateLocalPos1Attr(_vec3([a - p for a, p in zip(anchor, child.pos, strict=True)]))
    if joint.kind == "fixed":
        return
    axis, rot = _axis(joint.axis)
    prim_joint.CreateAxisAttr(axis)
    prim_joint.CreateLocalRot0Attr(rot)
    prim_joint.CreateLocalRot1Attr(rot)
    prim_joint.CreateLowerLimitAttr(_r(joint.lower))
    prim_joint.CreateUpperLimitAttr(_r(joint.upper))
    per_unit = math.pi / 180 if joint.kind == "revolute" else 1.0
    prim = prim_joint.GetPrim()
    prim.ApplyAPI("NewtonJointAPI")
    for name, value in (
        ("damping", joint.damping * per_unit),
        ("friction", joint.friction),
        ("armature", joint.armature),
    ):
        if value:
            prim.CreateAttribute(f"newton:{name}", Sdf.ValueTypeNames.Float, custom=False).Set(_r(value))


def _define_drive(stage: Usd.Stage, root: Sdf.Path, drive: PositionDrive, joint: Joint) -> None:
    joint_prim = stage.GetPrimAtPath(root.AppendChild(joint.name))
    angular = joint.kind == "revolute"
    per_unit = math.pi / 180 if angular else 1.0
    usd_drive = UsdPhysics.DriveAPI.Apply(joint_prim, "angular" if angular else "linear")
    usd_drive.CreateTypeAttr("force")
    usd_drive.CreateStiffnessAttr(_r(drive.kp * per_unit))
    usd_drive.CreateDampingAttr(_r(drive.kv * per_unit))
    usd_drive.CreateMaxForceAttr(_r(drive.max_force))
    usd_drive.CreateTargetPositionAttr(_r(math.degrees(drive.target) if angular else drive.target))

    act = stage.DefinePrim(root.AppendChild(drive.name), "MjcActuator")
    act.CreateRelationship("mjc:target", custom=False).SetTargets([joint_prim.GetPath()])

    def put(name: str, type_name: Sdf.ValueTypeName, value) -> None:
        act.CreateAttribute(f"mjc:{name}", type_name, custom=False, variability=Sdf.VariabilityUniform).Set(value)

    put("gainType", Sdf.ValueTypeNames.Token, "fixed")
    put("gainPrm", Sdf.ValueTypeNames.DoubleArray, Vt.DoubleArray([drive.kp]))
    put("biasType", Sdf.ValueTypeNames.Token, "affine")
    put("biasPrm", Sdf.ValueTypeNames.DoubleArray, Vt.DoubleArray([0.0, -drive.kp, -drive.kv]))
    put("ctrlLimited", Sdf.ValueTypeNames.Token, "true")
    put("ctrlRange:min", Sdf.ValueTypeNames.Double, _r(drive.ctrl_range[0]))
    put("ctrlRange:max", Sdf.ValueTypeNames.Double, _r(drive.ctrl_range[1]))
    put("forceLimited", Sdf.ValueTypeNames.Token, "true")
    put("forceRange:min", Sdf.ValueTypeNames.Double, -drive.max_force)
    put("forceRange:max", Sdf.ValueTypeNames.Double, drive.max_force)
