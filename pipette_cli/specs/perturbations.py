"""Perturbation specs (pydantic, ``type:``-dispatched): one home for augmentation and evaluation.

Each perturbation is a frozen ``*Spec`` registered in :data:`PERTURBATIONS` under its ``type``;
impossible parameters (``s_v <= 0``, a negative radius, ...) fail validation before any work.
The same specs make augmented variants (``pipette augment --variants``) and the per-episode
conditions of an evaluation suite (``perturbations:`` in ``registry/suites/*.yaml``), so a
shifted evaluation varies the world exactly as augmentation can.

``physics`` says whether the perturbation changes what is simulated (speed, joint noise,
object pose) or only what is rendered (lighting, camera pose, surface colour); ``on_actions``
whether it rewrites a demonstration's actions (speed, joint noise), which an evaluation, having
no demonstration, cannot apply. ``scaled(f)`` returns the same perturbation with its magnitude
multiplied by ``f`` in ``(0, 1]`` (``--target-yield``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, Literal

from pydantic import Field, model_validator

from pipette_cli.specs.base import TypedSpec, TypeRegistry


class PerturbationSpec(TypedSpec):
    """Base of every perturbation."""

    physics: ClassVar[bool] = False
    on_actions: ClassVar[bool] = False
    needs_demo: ClassVar[bool] = False
    """It is drawn around a demonstration (its actions, or where its hand went): augmentation only."""
    atom: ClassVar[str] = ""
    """Short name used in variant names (``light``, ``speed``, ...)."""

    def scaled(self, factor: float) -> PerturbationSpec:
        raise NotImplementedError

    def magnitude(self) -> str:
        """Human-readable magnitude for the yield report."""
        raise NotImplementedError


PERTURBATIONS: TypeRegistry[PerturbationSpec] = TypeRegistry("perturbation", PerturbationSpec)
if TYPE_CHECKING:  # to a type checker a field is its base spec; pydantic dispatches on the type key
    PerturbationField = PerturbationSpec
else:
    PerturbationField = PERTURBATIONS.field_type()


@PERTURBATIONS.register
class LightingSpec(PerturbationSpec):
    """``I' = s_I I`` for every light of the scene (and the headlight); ``s_I`` drawn per episode
    from ``[scale - jitter, scale + jitter]`` when ``jitter > 0``."""

    type: Literal["lighting"] = "lighting"
    atom: ClassVar[str] = "light"
    scale: float = Field(0.8, gt=0, description="s_I, every light's intensity factor; paper A.7")
    jitter: float = Field(0.0, ge=0, description="s_I is drawn uniformly from scale +- jitter (0: always scale)")
    headlight: bool = Field(True, description="scale the viewer headlight too")

    @model_validator(mode="after")
    def _positive(self) -> LightingSpec:
        if self.scale - self.jitter <= 0:
            raise ValueError(f"scale - jitter must stay above 0 (got {self.scale} - {self.jitter})")
        return self

    def scaled(self, factor: float) -> LightingSpec:
        return self.model_copy(update={"scale": 1.0 + (self.scale - 1.0) * factor, "jitter": self.jitter * factor})

    def magnitude(self) -> str:
        return f"s_I={self.scale:.3g}" + (f"+-{self.jitter:.3g}" if self.jitter else "")


@PERTURBATIONS.register
class SpeedSpec(PerturbationSpec):
    """Resample the joint targets along ``x_i = x_{i-1} + s_v m_i`` (paper A.7)."""

    type: Literal["speed"] = "speed"
    atom: ClassVar[str] = "speed"
    physics: ClassVar[bool] = True
    on_actions: ClassVar[bool] = True
    needs_demo: ClassVar[bool] = True
    factor: float = Field(1.2, gt=0, description="s_v, speed factor of the resampling; paper A.7")
    rho: float = Field(0.10, ge=0, description="rho, strength of the local speed noise; paper A.7")
    window: int = Field(11, ge=1, description="moving-average length smoothing the noise")
    interpolation: Literal["catmull_rom", "linear"] = "catmull_rom"

    def scaled(self, factor: float) -> SpeedSpec:
        return self.model_copy(update={"factor": 1.0 + (self.factor - 1.0) * factor, "rho": self.rho * factor})

    def magnitude(self) -> str:
        return f"s_v={self.factor:.3g},rho={self.rho:.3g}"


@PERTURBATIONS.register
class JointNoiseSpec(PerturbationSpec):
    """``eta ~ N(0, sigma^2)`` clipped to ``+-bound`` rad, added to the arm joint targets."""

    type: Literal["joint_noise"] = "joint_noise"
    atom: ClassVar[str] = "noise"
    physics: ClassVar[bool] = True
    on_actions: ClassVar[bool] = True
    needs_demo: ClassVar[bool] = True
    sigma: float = Field(0.005, ge=0, description="rad, std of the joint-target noise; paper A.7")
    bound: float = Field(0.02, ge=0, description="rad, bound of the joint-target noise; paper A.7")
    window: int = Field(
        1,
        ge=1,
        description="control steps of a moving average over each joint's noise, rescaled to sigma (1: independent "
        "per step, the paper's; more: a slow drift off the demonstrated path)",
    )
    corrective: bool = Field(
        False,
        description="record the clean demonstrated targets as the actions while the simulation executes the noisy "
        "ones (DART: the demonstrator's action at the perturbed state; the file keeps what ran as executed_action)",
    )

    def scaled(self, factor: float) -> JointNoiseSpec:
        return self.model_copy(update={"sigma": self.sigma * factor, "bound": self.bound * factor})

    def magnitude(self) -> str:
        window = f",window={self.window}" if self.window > 1 else ""
        return f"sigma={self.sigma:.3g},clip={self.bound:.3g}{window}" + (",corrective" if self.corrective else "")


@PERTURBATIONS.register
class CameraPoseSpec(PerturbationSpec):
    """Move one camera (or all three) by ``delta = r U^(1/3) n/|n|`` (uniform in a ball of radius r)."""

    type: Literal["camera_pose"] = "camera_pose"
    atom: ClassVar[str] = "cam"
    camera: Literal["random", "all", "top", "main", "wrist"] = Field(
        "random", description="which camera; random: one per variant; all: each its own offset"
    )
    radius: float = Field(0.2, ge=0, description="m, for the top and main cameras")
    wrist_radius: float = Field(0.002, ge=0, description="m, for the wrist camera")

    def scaled(self, factor: float) -> CameraPoseSpec:
        return self.model_copy(update={"radius": self.radius * factor, "wrist_radius": self.wrist_radius * factor})

    def magnitude(self) -> str:
        return f"r={self.radius:.3g},r_wrist={self.wrist_radius:.3g}"


@PERTURBATIONS.register
class ObjectPoseSpec(PerturbationSpec):
    """Move the task's target object and carry the demonstration along with it (object-centric
    transform, as in MimicGen).

    By default the object moves by up to ``xy`` metres and ``yaw_deg`` from where it starts. With
    ``task_range`` it is placed anew, uniformly within ``task_range`` times the task's own
    randomisation range (``scene.objects[].randomize``) around its nominal pose: 1 covers the
    range the task's episodes start in, more goes beyond it.
    """

    type: Literal["object_pose"] = "object_pose"
    atom: ClassVar[str] = "object"
    physics: ClassVar[bool] = True
    object: str | None = Field(None, description="scene object (default: the task's first target)")
    xy: float = Field(0.02, ge=0, description="m, uniform in [-xy, xy] along x and y")
    yaw_deg: float = Field(0.0, ge=0, le=180, description="uniform in [-yaw, yaw] about the vertical")
    task_range: float | None = Field(
        None, gt=0, le=5, description="place anew within this multiple of the task's randomisation range (replaces xy)"
    )
    ramp_steps: int = Field(15, ge=0, description="control steps over which the offset is blended in")

    def scaled(self, factor: float) -> ObjectPoseSpec:
        update: dict[str, float | None] = {"xy": self.xy * factor, "yaw_deg": self.yaw_deg * factor}
        if self.task_range is not None:
            update["task_range"] = self.task_range * factor
        return self.model_copy(update=update)

    def magnitude(self) -> str:
        if self.task_range is not None:
            return f"range x{self.task_range:.3g}"
        return f"xy={self.xy:.3g},yaw={self.yaw_deg:.3g}"


@PERTURBATIONS.register
class SurfaceColorSpec(PerturbationSpec):
    """Recolour the bench and the floor: each surface's material colour mixed with a colour drawn
    uniformly from the RGB cube, ``rgb' = (1 - blend) rgb + blend c``; rendering only."""

    type: Literal["surface_color"] = "surface_color"
    atom: ClassVar[str] = "table"
    surfaces: tuple[Literal["bench", "floor"], ...] = Field(
        ("bench", "floor"), min_length=1, description="what is recoloured"
    )
    blend: float = Field(0.5, gt=0, le=1, description="weight of the random colour mixed into each surface's own")

    def scaled(self, factor: float) -> SurfaceColorSpec:
        return self.model_copy(update={"blend": self.blend * factor})

    def magnitude(self) -> str:
        return f"blend={self.blend:.3g}"


DISTRACTOR_ASSETS = (
    "beaker_100ml",
    "lab_tape_roll",
    "petri_dish_60mm",
    "media_bottle_100ml",
    "reagent_reservoir_25ml",
    "erlenmeyer_flask_125ml",
)
"""Everyday bench objects, each under 9 cm across, none a target of a benchmark task."""


@PERTURBATIONS.register
class DistractorSpec(PerturbationSpec):
    """Put ``count`` objects of ``assets`` on the bench where the demonstration's hand never
    passes: each at least ``clearance`` from the task's objects and from the hand's path below
    ``path_height`` above the bench, uniformly within ``reach`` of the task's objects. The scene
    is rebuilt with them and the demonstration re-simulated (a touched distractor can fail it).
    An evaluation episode, which has no demonstration, keeps them clear of the path of the task's
    scripted expert on that episode."""

    type: Literal["distractors"] = "distractors"
    atom: ClassVar[str] = "clutter"
    physics: ClassVar[bool] = True
    count: int = Field(2, ge=1, le=6, description="objects put on the bench")
    assets: tuple[str, ...] = Field(DISTRACTOR_ASSETS, min_length=1, description="asset ids drawn from")
    clearance: float = Field(0.06, ge=0, description="m, free space kept around the task's objects and the hand's path")
    reach: float = Field(0.3, gt=0, description="m, how far from the task's objects they may stand")
    path_height: float = Field(
        0.25, gt=0, description="m above the bench: lower parts of the hand's path are kept clear"
    )

    def scaled(self, factor: float) -> DistractorSpec:
        return self.model_copy(update={"count": max(1, round(self.count * factor))})

    def magnitude(self) -> str:
        return f"n={self.count},clear={self.clearance:.3g}"
