"""`pipette new-task` on sentence sets: the share handled right and the share that became solvable tasks.

A sentence is *handled right* when the outcome is the expected one: the expected plan (actions
and assets, robot) and a task that validates and builds; or a one-line refusal containing the
expected words. Of the sentences expected to become tasks, a task is *solvable* when its generated
expert program succeeds on at least 4 of 5 seeds (what ``new-task --check`` demands). Any
traceback (an exception that is not a :class:`PipetteError`) counts as wrong and is listed.

    python benchmarks/bench_new_task.py --set tests/data/new_task_heldout.yaml --out docs/benchmarks/bench_new_task_heldout.json
    python benchmarks/bench_new_task.py --set tests/fixtures/authoring/descriptions.yaml --no-solve

With ``--backend openai --base-url URL`` (or ``--local-llm``: start SmolLM2-135M behind
llama-cpp-python's server) the sentences go to an LLM server instead; the same checks apply.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import traceback
from contextlib import ExitStack
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ruamel.yaml import YAML

from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.workflow import draft_task, plan_summary
from pipette_cli.demos.provenance import git_state
from pipette_cli.errors import PipetteError
from pipette_cli.taskgen.check import check_task


def load_cases(path: Path) -> list[dict]:
    data = YAML(typ="safe").load(path.read_text(encoding="utf-8"))
    return list(data["cases"])


def judge(case: dict, backend, solve: bool, episodes: int) -> dict:
    """Run one sentence; the row says what came out and whether it was right."""
    row: dict = {"text": case["text"], "expected": case.get("steps") or f"refuse: {case['refuse']}"}
    began = time.perf_counter()
    try:
        drafted = draft_task(case["text"], backend, namespace="bench")
    except PipetteError as exc:
        message = " ".join(getattr(exc, "problems", None) or [str(exc)])
        row.update(
            outcome="refused", message=message, right="refuse" in case and case["refuse"].lower() in message.lower()
        )
    except Exception as exc:
        row.update(
            outcome="traceback",
            message=f"{type(exc).__name__}: {exc}",
            right=False,
            traceback=traceback.format_exc()[-2000:],
        )
    else:
        steps = plan_summary(drafted.composed.checked)
        robot = drafted.spec.embodiment.robot
        row.update(
            outcome="task",
            task=drafted.spec.id,
            steps=steps,
            robot=robot,
            not_understood=drafted.not_understood,
            # right only with every word used or listed as the case expects: never right by dropping words
            right="steps" in case
            and steps == case["steps"]
            and robot == case.get("robot", "franka_panda")
            and drafted.not_understood == case.get("not_understood", []),
        )
        if solve and "steps" in case:
            report = check_task(drafted.spec, episodes)
            row["check"] = report.as_dict()
            row["solvable"] = report.ok and report.solve.status == "solved"
    row["seconds"] = round(time.perf_counter() - began, 2)
    return row


def failure_summary(rows: list[dict]) -> dict[str, dict]:
    """The unsolved sentences' failed seeds by class (``check.solve.failure_classes``), most first."""
    out: dict[str, dict] = {}
    for row in rows:
        solve = row.get("check", {}).get("solve", {})
        if row.get("solvable") is not False:
            continue
        for name, seeds in solve.get("failure_classes", {}).items():
            entry = out.setdefault(name, {"seeds": 0, "sentences": []})
            entry["seeds"] += len(seeds)
            entry["sentences"].append(row["text"])
    return dict(sorted(out.items(), key=lambda kv: -kv[1]["seeds"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", type=Path, action="append", required=True, help="A YAML file with `cases:`.")
    parser.add_argument("--backend", default="offline")
    parser.add_argument("--base-url", default=None)
    parser.add_argument("--model", default=None)
    parser.add_argument(
        "--local-llm", action="store_true", help="Serve SmolLM2-135M with llama-cpp-python for the run."
    )
    parser.add_argument("--no-solve", action="store_true", help="Skip running the experts (plans and builds only).")
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--limit", type=int, default=0, help="Only the first N sentences of each set.")
    parser.add_argument(
        "--stride", type=int, default=1, help="Every Nth sentence of each set (a spread sample for slow backends)."
    )
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    cases = [c for path in args.set for c in load_cases(path)[:: max(1, args.stride)][: args.limit or None]]
    model = args.model or ("smollm2" if args.local_llm else None)
    started = time.perf_counter()
    with ExitStack() as stack:
        base_url, backend_name = args.base_url, args.backend
        if args.local_llm:
            from pipette_cli.llm.local import local_llama_server

            base_url, backend_name = stack.enter_context(local_llama_server(n_ctx=4096)), "openai"
        backend = make_backend(backend_name, base_url=base_url, model=model)
        rows = []
        for case in cases:
            row = judge(case, backend, solve=not args.no_solve, episodes=args.episodes)
            rows.append(row)
            mark = "ok " if row["right"] else ("TB " if row["outcome"] == "traceback" else "-- ")
            check = row.get("check", {})
            why = "; ".join(check.get("problems", [])) or check.get("solve", {}).get("detail", "")
            extra = "" if "solvable" not in row else ("  solved" if row["solvable"] else f"  UNSOLVED {why}")
            got = row.get("steps") or row.get("message", "")[:140]
            print(f"{mark}{row['seconds']:6.1f}s  {case['text'][:70]:70s} -> {got}{extra}", flush=True)
    n = len(rows)
    right = sum(r["right"] for r in rows)
    expected_tasks = [r for r in rows if isinstance(r["expected"], list)]
    solvable = sum(bool(r.get("solvable")) for r in expected_tasks)
    tracebacks = [r["text"] for r in rows if r["outcome"] == "traceback"]
    result = {
        "commit": git_state(),
        "sets": [str(p) for p in args.set],
        "backend": backend_name,
        "model": model,
        "stride": args.stride,
        "limit": args.limit or None,
        "sentences": n,
        "handled_right": right,
        "handled_right_share": right / max(1, n),
        "expected_tasks": len(expected_tasks),
        "solvable": solvable if not args.no_solve else None,
        "solvable_share": solvable / max(1, len(expected_tasks)) if not args.no_solve else None,
        "tracebacks": tracebacks,
        "failure_classes": failure_summary(rows),
        "episodes": args.episodes,
        "wall_s": round(time.perf_counter() - started, 1),
        "rows": rows,
    }
    print(f"\nhandled right: {right}/{n} ({100 * right / max(1, n):.0f} %)")
    if not args.no_solve:
        print(
            f"solvable tasks (expert >= 4/5 seeds): {solvable}/{len(expected_tasks)} "
            f"({100 * solvable / max(1, len(expected_tasks)):.0f} %)"
        )
    print(f"tracebacks: {len(tracebacks)}; {result['wall_s']:.0f} s")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
