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
import re
import sys
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipette_cli.demos.check import LIMIT, check_expert
from pipette_cli.demos.embodiment import on_robot, resolve_robot
from pipette_cli.demos.provenance import git_state
from pipette_cli.errors import InfeasibleTask
from pipette_cli.registry import load_registry
from pipette_cli.specs.robot import robot_names
from pipette_cli.specs.task import TaskSpec


def run_cell(task: TaskSpec, robot: str, episodes: int, seed: int) -> dict:
    """One task on one robot: success over ``episodes`` seeds, or the refusal."""
    try:
        placed = on_robot(task, robot)
    except InfeasibleTask as exc:
        return {"task": task.id, "robot": robot, "refused": str(exc)}
    report = check_expert(placed, episodes, seed)
    row = {
        "task": task.id,
        "robot": robot,
        "base": list(placed.embodiment.base.pos),
        "episodes": report.episodes,
        "successes": report.successes,
        "success_rate": report.success_rate,
        "failures": dict(report.failures),
        "expert_failures": {str(k): v for k, v in report.expert_failures.items()},
        "median_episode_s": report.median_seconds,
        "seconds": report.seconds,
    }
    # a skill that finds before moving that a physical limit rules the task out ("reach: ...") on
    # every seed: the robot cannot do it, and the cell says which limit
    limits = [LIMIT.search(v) for v in report.expert_failures.values()]
    if report.successes == 0 and len(limits) == report.episodes and all(limits):
        first = limits[0]
        assert first is not None
        row["refused"] = f"{task.id} on the {robot}: {first.group(1)}"
    return row


def cell_text(row: dict) -> str:
    if "refused" in row:
        limit = row["refused"].split(": ", 2)[1] if row["refused"].count(": ") >= 2 else "refused"
        return f"refused ({limit})"
    return f"{row['successes']}/{row['episodes']}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--tasks", default="benchmark", help="Comma-separated task ids, 'benchmark' (tag paper-benchmark) or 'all'."
    )
    parser.add_argument("--robots", default="all", help="Comma-separated robots (ids or aliases) or 'all'.")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="Write the results as JSON here.")
    parser.add_argument("--markdown", type=Path, default=None, help="Write the table as markdown here.")
    parser.add_argument(
        "--merge",
        action="store_true",
        help="Keep the cells of --out that this run does not redo (a new robot's column, say).",
    )
    args = parser.parse_args()
    registry = load_registry()
    ids = registry.select(args.tasks)
    robots = robot_names() if args.robots == "all" else [resolve_robot(r).name for r in args.robots.split(",")]
    started = time.perf_counter()
    rows = []
    for task_id in ids:
        task = registry.get(task_id)
        for robot in robots:
            row = run_cell(task, robot, args.episodes, args.seed)
            rows.append(row)
            detail = row.get("refused") or (
                f"{100 * row['success_rate']:5.0f} %  base {row['base'][:2]}  {row['failures'] or ''}"
            )
            print(f"{task_id:45s} {robot:14s} {cell_text(row):>8s}  {detail}", flush=True)
    sha, dirty = git_state()
    for row in rows:
        row.update(git_sha=sha, git_dirty=dirty)
    wall = time.perf_counter() - started
    if args.merge and args.out is not None and args.out.is_file():
        rows, ids, robots, wall = merged(json.loads(args.out.read_text()), rows, ids, robots, wall)
    result = {
        "git_sha": sha,
        "git_dirty": dirty,
        "episodes_per_cell": args.episodes,
        "first_seed": args.seed,
        "robots": robots,
        "tasks": ids,
        "cells": rows,
        "wall_s": wall,
        "cpu_count": os.cpu_count(),
    }
    commits = {(r["git_sha"][:10], r["git_dirty"]) for r in rows}
    commit = (
        f"{sha[:10]}{' + local changes' if dirty else ''}"
        if len(commits) == 1
        else "per cell in docs/benchmarks/bench_robots.json"
    )
    table = markdown(rows, ids, robots, args.episodes, args.seed, commit)
    print("\n" + table)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    if args.markdown:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(table, encoding="utf-8")


def merged(
    old: dict, rows: list[dict], ids: list[str], robots: list[str], wall: float
) -> tuple[list[dict], list[str], list[str], float]:
    """The cells of an earlier run (``old``, its JSON) that this run did not redo, plus this run's."""
    done = {(r["task"], r["robot"]) for r in rows}
    sha, dirty = (old["git_sha"], old.get("git_dirty", False)) if "git_sha" in old else old["commit"]
    kept = [{"git_sha": sha, "git_dirty": dirty, **r} for r in old["cells"] if (r["task"], r["robot"]) not in done]
    all_ids = list(dict.fromkeys([*old.get("tasks", [r["task"] for r in old["cells"]]), *ids]))
    all_robots = sorted({*old["robots"], *robots})
    return kept + rows, all_ids, all_robots, old.get("wall_s", 0.0) + wall


def markdown(rows: list[dict], ids: list[str], robots: list[str], episodes: int, seed: int, commit: str) -> str:
    """The task x robot table (successes/episodes per cell), then every refusal and failure reason."""
    by = {(r["task"], r["robot"]): r for r in rows}
    lines = [
        (
            f"Scripted success per task and robot, {episodes} seeds from {seed} per cell "
            f"(`python benchmarks/bench_robots.py --episodes {episodes}`, commit {commit})."
        ),
        "",
        "| task | " + " | ".join(robots) + " |",
        "| --- |" + " ---: |" * len(robots),
    ]
    for task_id in ids:
        lines.append(f"| {task_id} | " + " | ".join(cell_text(by[task_id, r]) for r in robots) + " |")
    notes = []
    for row in rows:
        if "refused" in row:
            tried = f" (found by the expert on all {row['episodes']} seeds)" if "episodes" in row else ""
            notes.append(f"- {row['refused']}{tried}")
        elif row["failures"]:
            reasons = ", ".join(f"{k}: {v}" for k, v in row["failures"].items())
            why = Counter(
                re.sub(r"-?[0-9.]+(?= ?(?:mm|m|deg|kg)\b)", "N", v) for v in row.get("expert_failures", {}).values()
            )
            example = f" (most often: {why.most_common(1)[0][0]})" if why else ""
            notes.append(f"- {row['task']} on the {row['robot']}: {reasons}{example}")
    if notes:
        lines += ["", "Refusals and failures:", "", *notes]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
