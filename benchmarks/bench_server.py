"""Per-step overhead of `pipette serve` beyond inference, for 3x400x400 camera observations.

Serves a policy on a loopback port (server thread, same process) and times, per step, the
client's round trip (pack, send, receive, decode, checks, inference, reply) against the
inference alone (the same runner called directly on the same observation, in the same run).
Overhead = round trip - inference, for a trivial policy (answers zeros: pure overhead) and,
unless --no-act, a tiny untrained ACT policy (real pre/post-processing and torch), each with
uint8 and float32 images. Also times msgpack encoding and decoding alone. Prints a table and
writes JSON with the git SHA.

    python benchmarks/bench_server.py --steps 200 --out bench_server.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "fixtures" / "policy"))

import numpy as np  # noqa: E402
from tiny_policy import ConstantRunner, make_tiny_act, observation  # noqa: E402

from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.serving.client import PolicyClient  # noqa: E402
from pipette_cli.serving.protocol import check_observation, pack, parse_request, unpack  # noqa: E402
from pipette_cli.serving.server import PolicyServer, serving_in_thread  # noqa: E402


def _ms(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "median_ms": round(1000 * statistics.median(ordered), 3),
        "p95_ms": round(1000 * ordered[min(len(ordered) - 1, int(0.95 * len(ordered)))], 3),
    }


def measure(name: str, runner, obs: dict[str, np.ndarray], steps: int, warmup: int) -> dict:
    """Round trip through the server vs the same runner called directly, interleaved step by step."""
    checked = check_observation(parse_request(unpack(pack(obs))), runner.spec)
    direct, round_trip = [], []
    with (
        serving_in_thread(PolicyServer(runner, "tcp://127.0.0.1:0"), join_s=10) as server,
        PolicyClient(server.endpoint, timeout_ms=120_000) as client,
    ):
        for i in range(warmup + steps):
            t0 = time.perf_counter()
            runner.act(checked, "", chunk=False)
            t1 = time.perf_counter()
            client.act(obs)
            t2 = time.perf_counter()
            if i >= warmup:
                direct.append(t1 - t0)
                round_trip.append(t2 - t1)
    overhead = [r - d for r, d in zip(round_trip, direct, strict=True)]
    image = obs["observation.images.top"]
    return {
        "policy": name,
        "image_dtype": str(image.dtype),
        "request_bytes": len(pack(obs)),
        "steps": steps,
        "inference": _ms(direct),
        "round_trip": _ms(round_trip),
        "overhead_median_ms": round(1000 * (statistics.median(round_trip) - statistics.median(direct)), 3),
        "overhead_of_pairs": _ms(overhead),
    }


def codec(obs: dict[str, np.ndarray], n: int = 50) -> dict[str, float]:
    payload = pack(obs)
    t0 = time.perf_counter()
    for _ in range(n):
        pack(obs)
    t1 = time.perf_counter()
    for _ in range(n):
        unpack(payload)
    t2 = time.perf_counter()
    return {"pack_ms": round(1000 * (t1 - t0) / n, 3), "unpack_ms": round(1000 * (t2 - t1) / n, 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=400, help="image height and width")
    parser.add_argument("--steps", type=int, default=200, help="timed steps for the trivial policy")
    parser.add_argument("--act-steps", type=int, default=20, help="timed steps for the tiny ACT policy")
    parser.add_argument("--no-act", action="store_true", help="skip the tiny ACT policy (no torch/lerobot)")
    parser.add_argument("--out", type=Path, default=Path("bench_server.json"))
    args = parser.parse_args()
    rows, codecs = [], {}
    for dtype in ("uint8", "float32"):
        obs = observation(args.size, dtype=dtype)
        codecs[dtype] = codec(obs)
        rows.append(measure("trivial", ConstantRunner(image_size=args.size), obs, args.steps, warmup=10))
    if not args.no_act:
        from pipette_cli.serving.server import LeRobotRunner

        with tempfile.TemporaryDirectory() as tmp:
            runner = LeRobotRunner(make_tiny_act(Path(tmp) / "act", image_size=args.size, chunk_size=1), device="auto")
            for dtype in ("uint8", "float32"):  # chunk_size 1: every step runs the network
                rows.append(
                    measure(
                        f"tiny ACT ({runner.device})",
                        runner,
                        observation(args.size, dtype=dtype),
                        args.act_steps,
                        warmup=3,
                    )
                )
    print(
        f"3 cameras x 3x{args.size}x{args.size} + state(8), loopback tcp, server thread in the same process, "
        f"{os.cpu_count()} CPUs"
    )
    print(
        "codec: "
        + "; ".join(f"{k} pack {v['pack_ms']:.2f} ms, unpack {v['unpack_ms']:.2f} ms" for k, v in codecs.items())
    )
    header = f"{'policy':<18}{'images':>8}{'MB':>7}{'inference':>11}{'round trip':>12}{'overhead':>10}{'p95 ovh':>9}"
    print(header + "   (ms, medians)")
    for r in rows:
        print(
            f"{r['policy']:<18}{r['image_dtype']:>8}{r['request_bytes'] / 1e6:>7.2f}{r['inference']['median_ms']:>11.2f}"
            f"{r['round_trip']['median_ms']:>12.2f}{r['overhead_median_ms']:>10.2f}{r['overhead_of_pairs']['p95_ms']:>9.2f}"
        )
    args.out.write_text(
        json.dumps(
            {
                "git_sha": git_state()[0],
                "image_size": args.size,
                "cpus": os.cpu_count(),
                "codec": codecs,
                "results": rows,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
