"""Where a placement policy's failed episodes leave the object: how many end near the target and fail
there (set down off centre, or never released), from the episode logs `pipette eval` writes.

Exploratory (not a registered test of docs/reproduction/plan.md): it reads the ``xy_error`` (metres from
the target's centre at the end) and ``failure_reason`` of every episode of every setting and suite.

    python benchmarks/placement_misses.py --keep docs/reproduction/augmentation/episodes \
        --task pipette/PlaceTubeOnBalance-v1 --near 0.10
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path


def misses(folder: Path, near: float) -> dict[str, object]:
    """One evaluation folder's episodes: successes, episodes ending within ``near`` metres of the
    target, and why those near ones failed."""
    logs = [json.loads(p.read_text()) for p in sorted(folder.glob("episode_*.json"))]
    close = [e for e in logs if e.get("metrics", {}).get("xy_error", float("inf")) <= near]
    reasons = Counter(str(e.get("failure_reason")) for e in close if not e.get("success"))
    return {
        "episodes": len(logs),
        "successes": sum(bool(e.get("success")) for e in logs),
        "near": len(close),
        "near_failed": dict(sorted(reasons.items())),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--keep", type=Path, required=True, help="the kept episode logs (one folder per task)")
    parser.add_argument("--task", required=True, help="task id, e.g. pipette/PlaceTubeOnBalance-v1")
    parser.add_argument("--near", type=float, default=0.10, help="metres from the target's centre")
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    args = parser.parse_args()
    root = args.keep / args.task.replace("/", "_") / "eval"
    if not root.is_dir():
        raise SystemExit(f"{root}: no evaluation folders (is --keep the kept episode logs?)")
    rows = [
        {"suite": suite.name, "setting": setting.name, **misses(setting, args.near)}
        for suite in sorted(p for p in root.iterdir() if p.is_dir() and p.name != "curve")
        for setting in sorted(p for p in suite.iterdir() if p.is_dir())
    ]
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    print(f"| suite | setting | successes | within {args.near:g} m at the end | of those, failed (why) |")
    print("|---|---|---:|---:|---|")
    for r in rows:
        why = ", ".join(f"{k} {v}" for k, v in r["near_failed"].items()) or "-"
        print(f"| {r['suite']} | {r['setting']} | {r['successes']}/{r['episodes']} | {r['near']} | {why} |")


if __name__ == "__main__":
    main()
