"""Scripted success of every task's skill program, per task and per skill, and the time per episode.

Each task's expert (its ``expert:`` program) runs on N seeds without rendering (physics and the
skills' planning only). A skill's success rate counts the episodes in which a step of that skill
ran: it succeeded when the expert got past it (the expert did not stop there).

    python benchmarks/bench_experts.py --episodes 20 --out docs/benchmarks/bench_experts.json \\
        --markdown docs/experts_table.md
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipette_cli.demos.check import check_expert, step_of
from pipette_cli.demos.experts.base import expert_program
from pipette_cli.demos.provenance import git_state
from pipette_cli.registry import load_registry


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--tasks", default="all", help="Comma-separated task ids, 'benchmark' (tag paper-benchmark) or 'all'."
    )
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--registry-dir", action="append", default=[], help="Extra task folders.")
    parser.add_argument("--out", type=Path, default=None, help="Write the results as JSON here.")
    parser.add_argument("--markdown", type=Path, default=None, help="Write the tables as markdown here.")
    args = parser.parse_args()
    registry = load_registry([Path(d) for d in args.registry_dir])
    if args.tasks == "all":
        ids = registry.ids()
    elif args.tasks == "benchmark":
        ids = registry.ids("paper-benchmark")
    else:
        ids = [registry.get(t).id for t in args.tasks.split(",")]
    started = time.perf_counter()
    rows, ran, stopped = [], Counter(), Counter()
    for task_id in ids:
        task = registry.get(task_id)
        steps, _ = expert_program(task)
        report = check_expert(task, args.episodes, args.seed)
        failed_at = Counter(step_of(why) for why in report.expert_failures.values())
        for skill in {s.skill for s in steps}:
            ran[skill] += report.episodes
            stopped[skill] += failed_at.get(skill, 0)
        rows.append(
            {
                "task": task_id,
                "program": [s.describe() for s in steps],
                "episodes": report.episodes,
                "successes": report.successes,
                "success_rate": report.success_rate,
                "failures": dict(report.failures),
                "failed_steps": dict(failed_at),
                "failed_seeds": report.failed_seeds,
                "expert_failures": {str(k): v for k, v in report.expert_failures.items()},
                "median_episode_s": report.median_seconds,
                "seconds": report.seconds,
                "stage_count": report.stage_count,
                "stages": report.stages,
                "mean_progress": report.mean_progress,
            }
        )
        staged = (
            f"  progress {100 * report.mean_progress:3.0f} % of {report.stage_count} stages"
            if report.stage_count
            else ""
        )
        print(
            f"{task_id:60s} {report.successes:3d}/{report.episodes:<3d} {100 * report.success_rate:5.0f} %  "
            f"median {report.median_seconds:4.1f} s/episode{staged}  {dict(report.failures) or ''}",
            flush=True,
        )
    skills = {
        k: {"episodes": ran[k], "stopped": stopped[k], "success_rate": 1 - stopped[k] / ran[k]} for k in sorted(ran)
    }
    print("\nper skill (episodes in which a step of the skill ran; success: the expert got past it)")
    for name, row in skills.items():
        print(
            f"  {name:14s} {row['episodes'] - row['stopped']:4d}/{row['episodes']:<4d} {100 * row['success_rate']:5.1f} %"
        )
    total = sum(r["successes"] for r in rows), sum(r["episodes"] for r in rows)
    commit, dirty = git_state()
    result = {
        "commit": commit,
        "dirty": dirty,
        "episodes_per_task": args.episodes,
        "first_seed": args.seed,
        "tasks": rows,
        "skills": skills,
        "successes": total[0],
        "episodes": total[1],
        "wall_s": time.perf_counter() - started,
        "cpu_count": os.cpu_count(),
    }
    print(f"\n{total[0]}/{total[1]} episodes solved over {len(rows)} tasks in {result['wall_s']:.0f} s")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    if args.markdown:
        lines = [
            f"Scripted success of every task's skill program, {args.episodes} seeds from {args.seed} per task "
            f"(`python benchmarks/bench_experts.py --episodes {args.episodes}`, commit {commit[:10]}{' + local changes' if dirty else ''}).",
            "",
            "| task | program | success | stages (mean progress) | failures (reason: count) | median s/episode |",
            "| --- | --- | ---: | ---: | --- | ---: |",
        ]
        for r in rows:
            failures = ", ".join(f"{k}: {v}" for k, v in r["failures"].items()) or "-"
            stages = f"{r['stage_count']} ({100 * r['mean_progress']:.0f} %)" if r["stage_count"] else "-"
            lines.append(
                f"| {r['task']} | {'; '.join(r['program'])} | {r['successes']}/{r['episodes']} | {stages} | {failures} | "
                f"{r['median_episode_s']:.1f} |"
            )
        lines += ["", "| skill | episodes | the expert got past it |", "| --- | ---: | ---: |"]
        lines += [f"| {k} | {v['episodes']} | {100 * v['success_rate']:.1f} % |" for k, v in skills.items()]
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
