"""Physics real-time factor per task, under the scripted expert's own actions (no rendering).

For each task: one World (compiled once), ``--episodes`` expert episodes from seed 0. Times
``World.step`` (20 physics substeps at 600 Hz per 30 Hz control step, contacts, evaluator) apart
from the expert's ``act`` (planning + damped-least-squares IK), so the real-time factor is the
simulator's alone: simulated seconds / wall seconds spent stepping. Also reports the model's
size and the scene build (MjSpec compose + compile) time. Prints a table and writes JSON with
the git commit.

    python benchmarks/bench_sim.py --episodes 2 --out bench_sim.json
    python benchmarks/bench_sim.py --tasks PickUpTestTube,OpenCentrifugeLid
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from pipette_cli.demos.experts.base import expert_failure, find_expert  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.sim.world import World  # noqa: E402


def bench_task(task, episodes: int) -> dict:
    started = time.perf_counter()
    world = World(task)
    build_s = time.perf_counter() - started
    step_s = act_s = 0.0
    steps = successes = 0
    for seed in range(episodes):
        world.reset(seed)
        expert = find_expert(task)[1]
        expert.reset(world, np.random.default_rng(seed))
        verdict = world.verdict
        while not verdict.done and expert_failure(expert) is None:
            t0 = time.perf_counter()
            action = expert.act(world)
            t1 = time.perf_counter()
            verdict = world.step(action)
            step_s += time.perf_counter() - t1
            act_s += t1 - t0
            steps += 1
        successes += verdict.success
    model = world.model
    simulated = steps * world.control_dt
    return {
        "task": task.id,
        "robot": task.embodiment.robot,
        "nbody": model.nbody,
        "ngeom": model.ngeom,
        "nv": model.nv,
        "build_s": round(build_s, 3),
        "episodes": episodes,
        "successes": successes,
        "control_steps": steps,
        "simulated_s": round(simulated, 2),
        "step_wall_s": round(step_s, 3),
        "expert_wall_s": round(act_s, 3),
        "real_time_factor": round(simulated / step_s, 2),
        "control_steps_per_s": round(steps / step_s, 1),
        "real_time_factor_with_expert": round(simulated / (step_s + act_s), 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--tasks",
        default="benchmark",
        help="Comma-separated task ids, or 'benchmark' for the 12 paper tasks (tag paper-benchmark).",
    )
    parser.add_argument("--episodes", type=int, default=2, help="Expert episodes per task.")
    parser.add_argument("--out", type=Path, default=Path("bench_sim.json"))
    args = parser.parse_args()
    registry = load_registry([])
    if args.tasks == "benchmark":
        names = registry.ids("paper-benchmark")
    else:
        names = args.tasks.split(",")
    tasks = [registry.get(name) for name in names]
    rows = [bench_task(task, args.episodes) for task in tasks]
    print(
        f"mujoco {mujoco.__version__}, {os.cpu_count()} CPUs ({platform.processor() or platform.machine()}), "
        f"{args.episodes} expert episodes per task, physics 600 Hz / control 30 Hz"
    )
    header = f"{'task':<42}{'robot':<14}{'ngeom':>6}{'nv':>4}{'build s':>9}{'steps':>7}{'ok':>4}{'RTF':>7}{'steps/s':>9}{'RTF+expert':>12}"
    print(header)
    for r in rows:
        print(
            f"{r['task']:<42}{r['robot']:<14}{r['ngeom']:>6}{r['nv']:>4}{r['build_s']:>9.2f}{r['control_steps']:>7}"
            f"{r['successes']:>3}/{r['episodes']}{r['real_time_factor']:>6.1f}{r['control_steps_per_s']:>9.0f}"
            f"{r['real_time_factor_with_expert']:>12.1f}"
        )
    commit, dirty = git_state()
    args.out.write_text(
        json.dumps(
            {
                "git_sha": commit,
                "git_dirty": dirty,
                "mujoco": mujoco.__version__,
                "cpus": os.cpu_count(),
                "results": rows,
            },
            indent=2,
        )
        + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
