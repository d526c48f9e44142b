"""A stage (one plan step as a criterion and the skills that satisfy it) and what every stage
builder reads: the laid-out scene, the plan's thresholds and each object's geometry."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pipette_cli.skills.moves import HELD_SPEED
from pipette_cli.specs import evaluators as ev
from pipette_cli.specs import expert as sk
from pipette_cli.specs.mechanisms import ButtonReleaseSpec, InstrumentSpec
from pipette_cli.taskgen.layout import PlacedObject
from pipette_cli.taskgen.measure import AssetGeometry, measure_asset
from pipette_cli.taskgen.plan import PlanStepSpec, PlanThresholdsSpec
from pipette_cli.taskgen.scene import SceneBuilder, covered

CARRY_COVERED = 0.3
"""Metres of carry a placing stage's default time limit covers; longer carries get more time."""


@dataclass
class Stage:
    """One step as a criterion and the skills that satisfy it."""

    step: PlanStepSpec
    criterion: ev.EvaluatorSpec
    program: list[sk.StepSpec]
    comments: dict[str, str] = field(default_factory=dict)  # criterion field path -> comment
    targets: list[str] = field(default_factory=list)
    mechanisms: list[ButtonReleaseSpec] = field(default_factory=list)
    instruments: list[InstrumentSpec] = field(default_factory=list)
    """Motorised lids and drawers the stage works with their button (one per instrument and task)."""


def reference_point(name: str, geom: AssetGeometry) -> tuple[str, float]:
    """The point whose position is tested and its height above the surface at rest: an upright
    object's origin; a lying one's ``grasp`` site (its middle)."""
    if not geom.semantics.get("upright", True) and "grasp" in geom.sites:
        return f"{name}/grasp", geom.origin_height + float(geom.sites["grasp"][2])
    return name, geom.origin_height


class StageBase:
    """The scene, thresholds and geometry lookups the stage builders share."""

    def __init__(self, scene: SceneBuilder, thresholds: PlanThresholdsSpec, multi: bool) -> None:
        self.scene = scene
        self.checked = scene.checked
        self.placed: dict[str, PlacedObject] = scene.out.placed
        self.th = thresholds
        self.multi = multi
        self.ws = scene.ws
        self.bench = scene.ws.bench_z
        self.held_at: dict[str, tuple[str, str]] = dict(scene.out.start_site)  # item -> (holder, site) now

    def geom(self, name: str) -> AssetGeometry:
        """``name``'s geometry in the pose it starts in, which the skills keep while carrying it: an
        object that rests lying on a bench but starts standing in a rack (a conical tube) is
        measured standing, so a criterion for where it is set down expects it standing."""
        placed = self.placed[name]
        rest = measure_asset(placed.asset)
        standing = rest.free and rest.rest_euler_deg != (0.0, 0.0, 0.0) and placed.euler_deg == (0.0, 0.0, 0.0)
        return measure_asset(placed.asset, standing=True) if standing else rest

    def human(self, name: str) -> str:
        return self.scene.human(name)

    def hold(self, default: float) -> float:
        return self.th.hold_s if self.th.hold_s is not None and not self.multi else default

    def timeout(self, default: float) -> float | None:
        """The description's time limit, else ``default`` plus any hold it asks for (the defaults
        leave room for the default holds only)."""
        if self.multi:
            return default
        return self.th.timeout_s or default + (self.th.hold_s or 0.0)

    def carry_timeout(self, item: str, to: Sequence[float], default: float = 15.0) -> float | None:
        """:meth:`timeout` for a stage that carries ``item`` from where it starts to ``to``: ``default``
        covers a carry of :data:`CARRY_COVERED`; beyond that, twice what the rest takes at the speed
        the experts carry at (a beaker taken 66 cm round a shaker needed 16.5 s of 15, and its hold)."""
        start = np.asarray(self.placed[item].pos[:2], float)
        extra = max(0.0, float(np.linalg.norm(np.asarray(to[:2], float) - start)) - CARRY_COVERED)
        return self.timeout(round(default + 2.0 * extra / HELD_SPEED, 1))

    def _take(self, name: str, lift: float | None = None, hold_s: float = 0.0) -> list[sk.StepSpec]:
        """Grasp ``name`` where it is: out of an enclosure with ``remove_from``, else ``pick``."""
        where = self.held_at.get(name)
        if (
            where is not None
            and where[1] != "slot_grid"
            and where[1] in self.geom(where[0]).sites
            and covered(self.geom(where[0]), where[1])
        ):
            return [sk.RemoveFromSpec(object=name, source=where[0], to="hold", hold_s=0.3)]
        if lift is None:
            return [sk.PickSpec(object=name)]
        return [sk.PickSpec(object=name, lift=lift, hold_s=hold_s)]


__all__ = ["Stage", "StageBase", "reference_point"]
