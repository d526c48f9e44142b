"""Three-view (top, main, wrist) capture rate per render profile and resolution.

For each task, profile (``fast``: no shadows or reflections; ``full``: both, 4x multisampling)
and square image side, builds a PipetteEnv, resets it, renders once to warm the GL context, then
times ``--frames`` calls of ``render_views()`` (3 cameras each) on the reset state. A 10 Hz
vision rate needs >= 10 captures/s per environment. Prints a table and writes JSON with the git
commit and the GL backend (``MUJOCO_GL``; on this machine egl = Mesa llvmpipe, i.e. CPU).

    python benchmarks/bench_render.py --out bench_render.json
    python benchmarks/bench_render.py --tasks PickUpTestTube,OpenCentrifugeLid --sizes 64,400 --frames 20
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")

import mujoco  # noqa: E402

from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.sim.env import PipetteEnv  # noqa: E402
from pipette_cli.sim.render import PROFILES  # noqa: E402


def bench(task, profile: str, size: int, frames: int) -> dict:
    env = PipetteEnv(task, image_size=size, render_profile=profile)  # type: ignore[arg-type]
    try:
        env.reset(0)
        env.render_views()
        started = time.perf_counter()
        for _ in range(frames):
            views = env.render_views()
        seconds = time.perf_counter() - started
    finally:
        env.close()
    assert all(image.shape == (size, size, 3) for image in views.values())
    return {"task": task.id, "profile": profile, "size": size, "frames": frames, "seconds": round(seconds, 3),
            "captures_per_s": round(frames / seconds, 2), "ms_per_capture": round(1000 * seconds / frames, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="PickUpTestTube", help="Comma-separated task ids.")
    parser.add_argument("--profiles", default=",".join(PROFILES))
    parser.add_argument("--sizes", default="64,128,224,400", help="Square image sides in pixels.")
    parser.add_argument("--frames", type=int, default=10, help="Timed 3-view captures per setting.")
    parser.add_argument("--out", type=Path, default=Path("bench_render.json"))
    args = parser.parse_args()
    registry = load_registry([])
    rows = [
        bench(registry.get(name), profile, int(size), args.frames)
        for name in args.tasks.split(",") for profile in args.profiles.split(",") for size in args.sizes.split(",")
    ]
    backend = os.environ.get("MUJOCO_GL", "")
    print(f"MUJOCO_GL={backend}, mujoco {mujoco.__version__}, {os.cpu_count()} CPUs, {args.frames} captures per row")
    print(f"{'task':<34}{'profile':<9}{'size':>6}{'captures/s':>12}{'ms/capture':>12}{'>= 10 Hz':>10}")
    for r in rows:
        print(f"{r['task']:<34}{r['profile']:<9}{r['size']:>6}{r['captures_per_s']:>12.1f}{r['ms_per_capture']:>12.1f}"
              f"{'yes' if r['captures_per_s'] >= 10 else 'no':>10}")
    commit, dirty = git_state()
    args.out.write_text(json.dumps({"git_sha": commit, "git_dirty": dirty, "mujoco_gl": backend, "mujoco": mujoco.__version__,
                                    "cpus": os.cpu_count(), "results": rows}, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
