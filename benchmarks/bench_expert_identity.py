"""Fingerprints of the experts' motion: a hash of every action and the final state, per task and seed.

A refactoring that should leave the experts' motion unchanged is checked by running this on the
commit before and the one after (the same seeds, robots and tasks) and comparing the two files
(``--compare``): every fingerprint equal means bit-identical actions, hence identical results on
those seeds. Much cheaper than ``bench_experts.py`` (one or two seeds, not twenty).

    python benchmarks/bench_expert_identity.py --seeds 0,1 --out /tmp/after.json --compare /tmp/before.json
    python benchmarks/bench_expert_identity.py --tasks benchmark --robots piper,ur5e --seeds 0 --out /tmp/r.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipette_cli.demos.check import expert_failure
from pipette_cli.demos.embodiment import on_robot
from pipette_cli.demos.experts.base import find_expert
from pipette_cli.demos.provenance import git_state
from pipette_cli.errors import InfeasibleTask
from pipette_cli.registry import load_registry
from pipette_cli.sim.world import World

MAX_STEPS = 3000


def fingerprint(world: World, seed: int) -> dict:
    """Run the task's expert on ``seed`` as ``run_expert_episode`` does, hashing every action and the end state."""
    world.reset(seed)
    expert = find_expert(world.task)[1]
    expert.reset(world, np.random.default_rng([seed, 1]))
    digest = hashlib.sha256()
    verdict = world.verdict
    while not verdict.done and world.step_count < MAX_STEPS:
        action = expert.act(world)
        digest.update(np.asarray(action, dtype=np.float64).tobytes())
        verdict = world.step(action)
        if expert_failure(expert) is not None and not verdict.done:
            break
    digest.update(world.data.qpos.tobytes())
    return {
        "hash": digest.hexdigest()[:16],
        "success": bool(verdict.success),
        "expert_failure": expert_failure(expert),
        "steps": world.step_count,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tasks", default="all", help="Comma-separated task ids, 'benchmark' or 'all'.")
    parser.add_argument("--robots", default="", help="Comma-separated robots (default: each task's own).")
    parser.add_argument("--seeds", default="0,1", help="Comma-separated seeds.")
    parser.add_argument("--out", type=Path, required=True, help="Write the fingerprints as JSON here.")
    parser.add_argument("--compare", type=Path, default=None, help="Fingerprints of the other side to compare with.")
    args = parser.parse_args()
    registry = load_registry()
    ids = registry.select(args.tasks)
    seeds = [int(s) for s in args.seeds.split(",")]
    robots = args.robots.split(",") if args.robots else [""]
    runs: dict[str, dict | str] = {}
    for task_id in ids:
        for robot in robots:
            task = registry.get(task_id)
            if robot:
                try:
                    task = on_robot(task, robot)
                except InfeasibleTask as exc:
                    runs[f"{task_id}@{robot}"] = f"refused: {exc}"
                    continue
            world = World(task)
            for seed in seeds:
                key = f"{task_id}@{robot}#{seed}" if robot else f"{task_id}#{seed}"
                runs[key] = fingerprint(world, seed)
                print(key, runs[key]["hash"], "ok" if runs[key]["success"] else "failed", flush=True)
    commit, dirty = git_state()
    args.out.write_text(json.dumps({"commit": commit, "dirty": dirty, "runs": runs}, indent=1) + "\n")
    if args.compare is not None:
        other = json.loads(args.compare.read_text())["runs"]
        shared = [k for k in runs if k in other]
        differ = [k for k in shared if runs[k] != other[k]]
        print(f"{len(shared)} runs compared with {args.compare}: {len(differ)} differ")
        for k in differ:
            print(f"  {k}: {other[k]} -> {runs[k]}")


if __name__ == "__main__":
    main()
