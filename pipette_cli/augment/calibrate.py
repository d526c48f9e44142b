"""``--target-yield``: shrink every perturbation's magnitude until enough variants pass.

Calibration runs physics only (no rendering, nothing written) on the first few successful demos
of the input: each round scales every variant's magnitudes toward "no perturbation" by
``shrink`` (``PerturbationSpec.scaled``) until the fraction of variants the evaluator accepts
reaches the target. The augmentation then runs once with the magnitudes found.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pipette_cli.augment.pipeline import DemoAugmenter, DemoJob
from pipette_cli.augment.specs import AugmentSpec
from pipette_cli.demos.store import scan
from pipette_cli.errors import DatasetError, PipetteError
from pipette_cli.specs.task import TaskSpec


@dataclass
class Calibration:
    spec: AugmentSpec
    factor: float
    rounds: list[dict[str, float]] = field(default_factory=list)


def scaled_spec(spec: AugmentSpec, factor: float) -> AugmentSpec:
    return spec.model_copy(update={"variants": [v.scaled(factor) for v in spec.variants]})


def calibrate(
    task: TaskSpec,
    source: Path,
    spec: AugmentSpec,
    target: float,
    *,
    demos: int = 3,
    shrink: float = 0.7,
    max_rounds: int = 6,
) -> Calibration:
    """The largest magnitudes (factor ``shrink ** k``) whose physics-only yield reaches ``target``.

    Raises:
        PipetteError: a target outside (0, 1], or a shrink outside (0, 1).
        DatasetError: no successful demo to calibrate on, or the target is not reached.
    """
    if not 0 < target <= 1:
        raise PipetteError(f"--target-yield must be in (0, 1], not {target}")
    if not 0 < shrink < 1:
        raise PipetteError(f"shrink must be in (0, 1), not {shrink}")
    listing = scan(Path(source))
    refs = [ref for ref in listing.episodes if ref.summary.success][:demos]
    if not refs or listing.info is None:
        raise DatasetError(f"{source}: no successful demo to calibrate the magnitudes on")
    augmenter = DemoAugmenter(task, spec, listing.info, render=False)
    result = Calibration(spec, 1.0)
    factor = 1.0
    try:
        for _ in range(max_rounds + 1):
            augmenter.spec = scaled_spec(spec, factor)
            kept = tried = 0
            for ref in refs:
                outcome = augmenter.run(DemoJob(ref.index, ref, None, None))
                tried += len(outcome.outcomes)
                kept += sum(o.kept for o in outcome.outcomes)
            achieved = kept / tried if tried else 0.0
            result.rounds.append({"factor": factor, "yield": achieved, "attempts": float(tried), "kept": float(kept)})
            if tried and achieved >= target:
                result.spec, result.factor = augmenter.spec, factor
                return result
            factor *= shrink
    finally:
        augmenter.close()
    last = result.rounds[-1]
    raise DatasetError(
        f"yield {last['yield']:.0%} is still below the target {target:.0%} with magnitudes scaled by "
        f"{last['factor']:.2f}; lower --target-yield or check the demos (pipette data replay --check)"
    )
