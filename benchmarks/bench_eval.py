"""Closed-loop evaluation throughput (episodes per hour) for 1, 2, ... workers, and how fast a
dead policy server is noticed.

Throughput: the same episodes (seeds 100000..) of one task are evaluated once per worker count,
each into a fresh folder, with an ACT policy loaded in each worker (a tiny untrained ACT by
default, or --policy DIR); wall time includes starting the workers and loading the policy, as a
user sees it. An untrained policy never succeeds, so every episode runs to the task's timeout:
the slowest case. All counts run in one process, one after the other, so their ratio holds on a
shared machine.

Dead server: a policy server (a fixed-action stub, own process) is killed (SIGKILL) or stopped
(SIGSTOP: alive but silent) mid-evaluation; the table gives the seconds from that moment to the
safe hold, and from the hold to the end of the run, at the default settings (--dead-after 5 s).

Prints a table and writes JSON with the git SHA.

    python benchmarks/bench_eval.py --episodes 8 --workers 1,2 --out bench_eval.json
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")
sys.path.insert(0, str(ROOT / "tests" / "fixtures" / "policy"))

from tiny_policy import make_tiny_act  # noqa: E402

from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.evaluation.evaluate import ServerLost  # noqa: E402
from pipette_cli.evaluation.runner import PolicySource, TaskRun, evaluate_runs  # noqa: E402
from pipette_cli.evaluation.settings import DecodeConfig, EvalSettings  # noqa: E402
from pipette_cli.evaluation.suites import adhoc_plan  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402

FIRST_SEED = 100_000


def throughput(task, policy: Path, image_size: int, episodes: int, workers: int, device: str) -> dict:
    settings = EvalSettings(DecodeConfig.for_policy("act"), image_size)
    with tempfile.TemporaryDirectory() as tmp:
        run = TaskRun(task, Path(tmp), tuple(adhoc_plan(task, episodes, FIRST_SEED)))
        started = time.perf_counter()
        result = evaluate_runs([run], PolicySource(checkpoint=policy, device=device), settings, workers=workers)
        wall = time.perf_counter() - started
    summary = result.summaries[task.id]
    return {
        "workers": workers,
        "episodes": episodes,
        "wall_s": round(wall, 2),
        "episodes_per_hour": round(3600 * episodes / wall, 1),
        "mean_episode_s": round(summary["mean_runtime_s"], 2),
        "successes": summary["successes"],
    }


def dead_server(task, image_size: int, how: str, after_s: float) -> dict:
    """Seconds from killing/stopping the server to the safe hold, and from the hold to the end."""
    hold = [*task.embodiment.initial_joints, 1.0]
    server = subprocess.Popen(
        [
            sys.executable,
            str(ROOT / "tests" / "fixtures" / "policy" / "serve_fixed.py"),
            "--action",
            ",".join(map(str, hold)),
            "--image-size",
            str(image_size),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    endpoint = server.stdout.readline().strip()
    struck: list[float] = []

    def strike() -> None:
        time.sleep(after_s)
        struck.append(time.time())
        server.send_signal(signal.SIGKILL if how == "killed" else signal.SIGSTOP)

    settings = EvalSettings(DecodeConfig.for_policy("act"), image_size)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            run = TaskRun(task, Path(tmp), tuple(adhoc_plan(task, 1000, FIRST_SEED)))
            threading.Thread(target=strike, daemon=True).start()
            try:
                evaluate_runs([run], PolicySource(endpoints=(endpoint,)), settings)
                raise RuntimeError("the evaluation ended without noticing the server")
            except ServerLost as exc:
                ended = time.time()
                held = exc.record["held_at"]
    finally:
        server.kill()
        server.wait()
    return {"server": how, "to_safe_hold_s": round(held - struck[0], 2), "hold_to_end_s": round(ended - held, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="PickUpTestTube")
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--episodes", type=int, default=8, help="episodes per worker count")
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    parser.add_argument(
        "--policy", type=Path, default=None, help="an ACT policy folder (default: a tiny untrained ACT)"
    )
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--no-dead-server", action="store_true", help="skip the dead-server timings")
    parser.add_argument(
        "--strike-after", type=float, default=3.0, help="seconds into the run the server is killed/stopped"
    )
    parser.add_argument("--out", type=Path, default=Path("bench_eval.json"))
    args = parser.parse_args()
    task = load_registry().get(args.task)
    rows, dead = [], []
    with tempfile.TemporaryDirectory() as tmp:
        policy = args.policy or make_tiny_act(Path(tmp) / "act", image_size=args.image_size, chunk_size=20)
        for workers in (int(w) for w in args.workers.split(",")):
            rows.append(throughput(task, policy, args.image_size, args.episodes, workers, args.device))
    if not args.no_dead_server:
        dead = [dead_server(task, args.image_size, how, after_s=args.strike_after) for how in ("killed", "stopped")]
    print(
        f"{task.id}, {args.image_size} px, {args.episodes} episodes per run, "
        f"{'tiny untrained ACT' if args.policy is None else args.policy}, {os.cpu_count()} CPUs"
    )
    print(f"{'workers':>8}{'wall s':>9}{'episodes/h':>12}{'s/episode':>11}{'successes':>11}")
    for r in rows:
        print(
            f"{r['workers']:>8}{r['wall_s']:>9.1f}{r['episodes_per_hour']:>12.1f}{r['mean_episode_s']:>11.2f}{r['successes']:>11}"
        )
    for d in dead:
        print(
            f"server {d['server']}: safe hold after {d['to_safe_hold_s']:.1f} s, run ended {d['hold_to_end_s']:.1f} s later"
        )
    args.out.write_text(
        json.dumps(
            {
                "git_sha": git_state()[0],
                "task": task.id,
                "image_size": args.image_size,
                "policy": str(args.policy or "tiny untrained ACT"),
                "cpus": os.cpu_count(),
                "results": rows,
                "dead_server": dead,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
