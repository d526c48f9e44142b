"""Three-view (top, main, wrist) capture rate per render profile and resolution.

For each task, profile (``fast``: no shadows or reflections, decimated visual meshes; ``full``:
shadows, reflections, 4x multisampling, original meshes) and square image side, builds a
PipetteEnv, resets it, renders once to warm the GL context, then times ``--frames`` calls of
``render_views()`` (3 cameras each) on the reset state. The rows of one task are measured in
``--rounds`` interleaved rounds (best round reported) so a busy machine slows every row alike. A
10 Hz vision rate needs >= 10 captures/s per environment. Prints a table and writes JSON with
the git commit, the GL backend (``MUJOCO_GL``; on this machine egl = Mesa llvmpipe, i.e. CPU),
each row's triangle count and the load average. ``--picture PNG`` also writes the three views
of each profile at the largest size, fast above full. The extra profile ``fast-original-meshes``
(fast settings, original meshes: the fast profile before decimated meshes) shows what the
decimation alone gains.

    python benchmarks/bench_render.py --out bench_render.json --picture render_profiles.png
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
import numpy as np  # noqa: E402

from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.sim.env import PipetteEnv  # noqa: E402
from pipette_cli.sim.render import PROFILES, CameraRig  # noqa: E402


def triangles(model) -> int:
    """Triangles of the mesh geoms the cameras can see (geom groups 0-2)."""
    meshes = [
        model.geom_dataid[g]
        for g in range(model.ngeom)
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH and model.geom_group[g] <= 2
    ]
    return int(sum(model.mesh_facenum[m] for m in meshes))


ORIGINAL_MESHES = "fast-original-meshes"
"""The fast profile's render settings with the original meshes: the fast profile before decimation."""


def make_env(task, profile: str, size: int) -> PipetteEnv:
    if profile != ORIGINAL_MESHES:
        return PipetteEnv(task, image_size=size, render_profile=profile)  # type: ignore[arg-type]
    env = PipetteEnv(task, image_size=size, render=False)  # built with the original meshes
    env.rig = CameraRig(env.world.model, size, size, "fast")
    return env


def bench_task(task, profiles: list[str], sizes: list[int], frames: int, rounds: int) -> tuple[list[dict], dict]:
    envs = {(p, s): make_env(task, p, s) for p in profiles for s in sizes}
    best = {key: float("inf") for key in envs}
    views = {}
    try:
        for env in envs.values():
            env.reset(0)
            env.render_views()
        for _ in range(rounds):
            for key, env in envs.items():
                started = time.perf_counter()
                for _ in range(frames):
                    views[key] = env.render_views()
                best[key] = min(best[key], time.perf_counter() - started)
        rows = []
        for (profile, size), env in envs.items():
            assert all(image.shape == (size, size, 3) for image in views[profile, size].values())
            seconds = best[profile, size]
            rows.append(
                {
                    "task": task.id,
                    "profile": profile,
                    "size": size,
                    "frames": frames,
                    "seconds": round(seconds, 3),
                    "captures_per_s": round(frames / seconds, 2),
                    "ms_per_capture": round(1000 * seconds / frames, 2),
                    "triangles": triangles(env.world.model),
                }
            )
    finally:
        for env in envs.values():
            env.close()
    return rows, {p: views[p, max(sizes)] for p in profiles if p in PROFILES}


def picture(views: dict[str, dict[str, np.ndarray]], path: Path) -> None:
    """One row per profile (top, main, wrist), labelled."""
    from PIL import Image, ImageDraw

    rows = [np.concatenate([v[c] for c in ("top", "main", "wrist")], axis=1) for v in views.values()]
    image = Image.fromarray(np.concatenate(rows, axis=0))
    draw = ImageDraw.Draw(image)
    for i, profile in enumerate(views):
        draw.text((6, 4 + i * rows[0].shape[0]), profile, fill=(255, 255, 0))
    image.save(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="PickUpTestTube", help="Comma-separated task ids.")
    parser.add_argument(
        "--profiles",
        default=",".join([*PROFILES, ORIGINAL_MESHES]),
        help=f"Render profiles; {ORIGINAL_MESHES}: fast settings with the original meshes.",
    )
    parser.add_argument("--sizes", default="64,128,224,400", help="Square image sides in pixels.")
    parser.add_argument("--frames", type=int, default=10, help="Timed 3-view captures per setting and round.")
    parser.add_argument("--rounds", type=int, default=3, help="Interleaved rounds; the best is reported.")
    parser.add_argument("--picture", type=Path, help="PNG of each profile's views at the largest size.")
    parser.add_argument("--out", type=Path, default=Path("bench_render.json"))
    args = parser.parse_args()
    registry = load_registry([])
    load = os.getloadavg()
    rows, pictures = [], {}
    for name in args.tasks.split(","):
        task_rows, pictures = bench_task(
            registry.get(name),
            args.profiles.split(","),
            [int(s) for s in args.sizes.split(",")],
            args.frames,
            args.rounds,
        )
        rows += task_rows
    backend = os.environ.get("MUJOCO_GL", "")
    print(
        f"MUJOCO_GL={backend}, mujoco {mujoco.__version__}, {os.cpu_count()} CPUs, {args.frames} captures per row and round, "
        f"best of {args.rounds} rounds, load average {load[0]:.2f}"
    )
    print(
        f"{'task':<34}{'profile':<22}{'size':>6}{'triangles':>11}{'captures/s':>12}{'ms/capture':>12}{'>= 10 Hz':>10}"
    )
    for r in rows:
        print(
            f"{r['task']:<34}{r['profile']:<22}{r['size']:>6}{r['triangles']:>11}{r['captures_per_s']:>12.1f}"
            f"{r['ms_per_capture']:>12.1f}{'yes' if r['captures_per_s'] >= 10 else 'no':>10}"
        )
    if args.picture:
        picture(pictures, args.picture)
        print(f"wrote {args.picture}")
    commit, dirty = git_state()
    args.out.write_text(
        json.dumps(
            {
                "git_sha": commit,
                "git_dirty": dirty,
                "mujoco_gl": backend,
                "mujoco": mujoco.__version__,
                "cpus": os.cpu_count(),
                "loadavg_before": [round(x, 2) for x in load],
                "loadavg_after": [round(x, 2) for x in os.getloadavg()],
                "results": rows,
            },
            indent=2,
        )
        + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
