"""Both language development sets, offline, in one table: `pipette agent`'s requests and `pipette
new-task`'s sentences, each case judged on its meaning (plan fields), never right by dropping
words (a case lists the words its plan must report as not understood; any other unused word makes
it wrong), with the tracebacks (must be 0). New-task sentences are planned and built, not solved
(`bench_new_task.py` runs the experts).

    python benchmarks/bench_language.py --out bench_language.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from bench_agent import score  # noqa: E402
from bench_new_task import judge, load_cases  # noqa: E402

from pipette_cli.agent.devset import load_dev_set  # noqa: E402
from pipette_cli.agent.offline import OfflineAgent  # noqa: E402
from pipette_cli.authoring.backends import make_backend  # noqa: E402
from pipette_cli.cli.main import load_catalog  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402

AGENT_SET = ROOT / "tests" / "fixtures" / "agent" / "dev_set.yaml"
NEW_TASK_SET = ROOT / "tests" / "fixtures" / "authoring" / "descriptions.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("bench_language.json"))
    parser.add_argument("--limit", type=int, default=0, help="only the first N cases of each set")
    args = parser.parse_args()
    limit = args.limit or None
    started = time.perf_counter()
    agent = score(
        "offline", OfflineAgent(load_catalog(), load_registry()), load_dev_set(AGENT_SET)[:limit], verbose=False
    )
    backend = make_backend("offline")
    rows = [judge(case, backend, solve=False, episodes=0) for case in load_cases(NEW_TASK_SET)[:limit]]
    new_task = {
        "sentences": len(rows),
        "right": sum(bool(r["right"]) for r in rows),
        "tracebacks": sum(r["outcome"] == "traceback" for r in rows),
        "wrong": [r for r in rows if not r["right"]],
    }
    table = [
        ("pipette agent", agent["requests"], agent["right"], agent["tracebacks"]),
        ("pipette new-task", new_task["sentences"], new_task["right"], new_task["tracebacks"]),
    ]
    print(f"{'development set':<20}{'cases':>8}{'right':>8}{'share':>9}{'tracebacks':>12}")
    for name, cases, right, tracebacks in table:
        print(f"{name:<20}{cases:>8}{right:>8}{right / max(cases, 1):>9.1%}{tracebacks:>12}")
    for row in new_task["wrong"]:
        print(f"  new-task wrong: {row['text']} -> {row.get('steps') or row.get('message', '')}"[:160])
    for row in agent["wrong"]:
        print(f"  agent wrong: {row['request']} -> {row['got']} {row['error']}"[:160])
    args.out.write_text(
        json.dumps(
            {
                "git_sha": git_state()[0],
                "agent": agent,
                "new_task": new_task,
                "wall_s": round(time.perf_counter() - started, 1),
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
