"""Kept augmented episodes per hour: a paper-faithful baseline versus the physics-first pipeline.

Baseline (paper A.7 as written): every variant is replayed with rendering on (three views at
the 10 Hz vision schedule while simulating), then judged; passing ones are written.
Ours (``pipette augment``): verify the original once, simulate only variants that change the
physics, without rendering; render only kept variants from their recorded states.
Both run on the same demos, variants and seeds, one after the other in this process, single
worker each. Prints a table and writes JSON with the git SHA.

    python benchmarks/bench_augment.py --task PickUpTestTube --input raw.h5 --variants paper
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from pipette_cli.augment.perturb import plan_variant
from pipette_cli.augment.pipeline import write_rollout
from pipette_cli.augment.render import visual_perturbation
from pipette_cli.augment.run import augment
from pipette_cli.augment.simulate import Rollout, settle_steps
from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants
from pipette_cli.demos.recorder import DatasetInfo, sim_state
from pipette_cli.demos.store import part_path, read_episode, scan
from pipette_cli.evaluators.base import Verdict
from pipette_cli.registry import load_registry
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.demos.provenance import git_state


def baseline(task, raw: Path, out: Path, spec: AugmentSpec) -> dict[str, float]:
    info: DatasetInfo = scan(raw).info  # type: ignore[assignment]
    env = PipetteEnv(task, image_size=info.image_height)
    world = env.world
    settle = settle_steps(world, spec.settle_s)
    kept = attempts = 0
    started = time.perf_counter()
    for ref in scan(raw).episodes:
        record = read_episode(ref)
        original = Rollout.from_record(record)
        for variant in spec.variants:
            plan = plan_variant(variant, original.actions, seed=spec.seed, demo_seed=ref.summary.seed, default_object=task.targets[0])
            actions = plan.actions if plan.actions is not None else original.actions
            attempts += 1
            with visual_perturbation(world.model, plan, env.rig.ids):  # type: ignore[union-attr]
                obs = env.reset(ref.summary.seed)
                rows, frames, verdict = [], [], Verdict()
                for k in range(len(actions) + settle):
                    action = np.asarray(actions[min(k, len(actions) - 1)])
                    rows.append((action, sim_state(world.model, world.data), obs))
                    obs, verdict = env.step(action)
                    if verdict.done:
                        break
            if not verdict.success:
                continue
            rollout = Rollout(
                actions=np.stack([r[0] for r in rows]), states=np.stack([r[1] for r in rows]),
                obs_state=np.stack([r[2].state for r in rows]), sim_time=np.array([r[2].sim_time for r in rows]),
                wall_time=np.array([r[2].wall_time for r in rows]), final_state=world.state(),
                final_sim_state=sim_state(world.model, world.data), verdict=verdict,
            )
            frames = [r[2].images for r in rows]
            tmp = write_rollout(part_path(out, kept), info, rollout, frames, index=kept, seed=ref.summary.seed,
                                vision_every=task.timing.vision_every, attrs={"augment_variant": plan.variant})
            tmp.replace(part_path(out, kept))
            kept += 1
    env.close()
    seconds = time.perf_counter() - started
    return {"attempts": attempts, "kept": kept, "seconds": seconds, "kept_per_hour": kept / seconds * 3600}


def ours(task, raw: Path, out: Path, spec: AugmentSpec) -> dict[str, float]:
    started = time.perf_counter()
    result = augment(task, raw, out, spec, workers=1)
    seconds = time.perf_counter() - started
    return {"attempts": result.report["attempts"], "kept": result.report["kept"], "seconds": seconds,
            "kept_per_hour": result.report["kept"] / seconds * 3600, "timings": result.timings}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--task", default="PickUpTestTube")
    parser.add_argument("--input", type=Path, required=True)
    parser.add_argument("--variants", default="paper")
    parser.add_argument("--speed", type=float, default=1.2)
    parser.add_argument("--out", "--json", dest="out", type=Path, default=Path("bench_augment.json"))
    args = parser.parse_args()
    task = load_registry([]).get(args.task)
    spec = AugmentSpec(variants=make_variants(args.variants.split(","), default_atoms(speed={"factor": args.speed})))
    work = Path(tempfile.mkdtemp(prefix="bench_augment_"))
    try:
        base = baseline(task, args.input, work / "baseline.h5", spec)
        mine = ours(task, args.input, work / "ours.h5", spec)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    sha = git_state()[0]
    ratio = mine["kept_per_hour"] / base["kept_per_hour"] if base["kept_per_hour"] else float("inf")
    print(f"{'pipeline':<10} {'attempts':>8} {'kept':>5} {'seconds':>8} {'kept/hour':>10}")
    for name, row in (("baseline", base), ("ours", mine)):
        print(f"{name:<10} {row['attempts']:>8} {row['kept']:>5} {row['seconds']:>8.1f} {row['kept_per_hour']:>10.0f}")
    print(f"ratio ours/baseline: {ratio:.2f}x")
    args.out.write_text(json.dumps({"git_sha": sha, "task": task.id, "input": str(args.input), "variants": args.variants,
                                     "baseline": base, "ours": mine, "ratio": ratio}, indent=2, default=str))


if __name__ == "__main__":
    main()
