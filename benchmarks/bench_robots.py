"""Scripted success of every benchmark task on every robot: the task x robot table.

Each cell runs the task's skill program (unchanged) on N seeds without rendering, with the robot
placed by :func:`pipette_cli.demos.embodiment.on_robot` (its home pose and wrist camera; the base
moved along the bench where the task's own leaves a work point out of reach). A robot that
physically cannot do a task is refused before any episode runs; the cell shows the limit.

    python benchmarks/bench_robots.py --episodes 20 --out docs/benchmarks/bench_robots.json \\
        --markdown docs/robots_table.md
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipette_cli.demos.check import check_expert  # noqa: E402
from pipette_cli.demos.embodiment import on_robot, resolve_robot  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.errors import InfeasibleTask  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.specs.robot import robot_names  # noqa: E402


def run_cell(task, robot: str, episodes: int, seed: int) -> dict:  # noqa: ANN001
    """One task on one robot: success over ``episodes`` seeds, or the refusal."""
    try:
        placed = on_robot(task, robot)
    except InfeasibleTask as exc:
        return {"task": task.id, "robot": robot, "refused": str(exc)}
    report = check_expert(placed, episodes, seed)
    return {
        "task": task.id, "robot": robot, "base": list(placed.embodiment.base.pos), "episodes": report.episodes,
        "successes": report.successes, "success_rate": report.success_rate, "failures": dict(report.failures),
        "expert_failures": {str(k): v for k, v in report.expert_failures.items()},
        "median_episode_s": report.median_seconds, "seconds": report.seconds,
    }


def cell_text(row: dict) -> str:
    if "refused" in row:
        limit = row["refused"].split(": ", 2)[1] if row["refused"].count(": ") >= 2 else "refused"
        return f"refused ({limit})"
    return f"{row['successes']}/{row['episodes']}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tasks", default="benchmark", help="Comma-separated task ids, 'benchmark' (tag paper-benchmark) or 'all'.")
    parser.add_argument("--robots", default="all", help="Comma-separated robots (ids or aliases) or 'all'.")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="Write the results as JSON here.")
    parser.add_argument("--markdown", type=Path, default=None, help="Write the table as markdown here.")
    args = parser.parse_args()
    registry = load_registry()
    if args.tasks in ("all", "benchmark"):
        ids = registry.ids("paper-benchmark" if args.tasks == "benchmark" else None)
    else:
        ids = [registry.get(t).id for t in args.tasks.split(",")]
    robots = robot_names() if args.robots == "all" else [resolve_robot(r).name for r in args.robots.split(",")]
    started = time.perf_counter()
    rows = []
    for task_id in ids:
        task = registry.get(task_id)
        for robot in robots:
            row = run_cell(task, robot, args.episodes, args.seed)
            rows.append(row)
            detail = row.get("refused") or (f"{100 * row['success_rate']:5.0f} %  base {row['base'][:2]}  "
                                            f"{row['failures'] or ''}")
            print(f"{task_id:45s} {robot:14s} {cell_text(row):>8s}  {detail}", flush=True)
    sha, dirty = git_state()
    result = {"git_sha": sha, "git_dirty": dirty, "episodes_per_cell": args.episodes, "first_seed": args.seed, "robots": robots,
              "cells": rows, "wall_s": time.perf_counter() - started, "cpu_count": os.cpu_count()}
    table = markdown(rows, ids, robots, args.episodes, args.seed, f"{sha[:10]}{' + local changes' if dirty else ''}")
    print("\n" + table)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    if args.markdown:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(table, encoding="utf-8")


def markdown(rows: list[dict], ids: list[str], robots: list[str], episodes: int, seed: int, commit: str) -> str:
    """The task x robot table (successes/episodes per cell), then every refusal and failure reason."""
    by = {(r["task"], r["robot"]): r for r in rows}
    lines = [f"Scripted success per task and robot, {episodes} seeds from {seed} per cell "
             f"(`python benchmarks/bench_robots.py --episodes {episodes}`, commit {commit}).", "",
             "| task | " + " | ".join(robots) + " |", "| --- |" + " ---: |" * len(robots)]
    for task_id in ids:
        lines.append(f"| {task_id} | " + " | ".join(cell_text(by[task_id, r]) for r in robots) + " |")
    notes = []
    for row in rows:
        if "refused" in row:
            notes.append(f"- {row['refused']}")
        elif row["failures"]:
            reasons = ", ".join(f"{k}: {v}" for k, v in row["failures"].items())
            notes.append(f"- {row['task']} on the {row['robot']}: {reasons}")
    if notes:
        lines += ["", "Refusals and failures:", "", *notes]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
