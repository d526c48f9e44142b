"""Conversion speed of `pipette convert` (frames/s) for images and both video codecs.

Records N episodes of the fixture task testlab/HoldTube-v1 (Wiggle expert, 15 control steps,
5 fresh frames each) at the given image size once, marks them successful, then converts the
same file with --images, --video (libsvtav1, LeRobot's default) and --video --vcodec h264 in
one process, so the ratios hold on a noisy machine. Prints a table and writes JSON with the
git SHA.

    python benchmarks/bench_convert.py --episodes 20 --image-size 128 --out bench_convert.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")
sys.path.insert(0, str(ROOT / "tests" / "fixtures" / "demos"))

import demo_experts  # noqa: E402
import h5py  # noqa: E402

from pipette_cli.demos.collect import collect  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.lerobot.convert import ConvertOptions, convert  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--image-size", type=int, default=128)
    parser.add_argument("--out", type=Path, default=Path("bench_convert.json"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "rec.h5"
        task = load_registry([ROOT / "tests" / "fixtures" / "demos" / "registry"]).get("testlab/HoldTube-v1")
        started = time.perf_counter()
        collect(
            task, src, episodes=args.episodes, seed=0, image_size=args.image_size, expert_factory=demo_experts.Wiggle
        )
        record_s = time.perf_counter() - started
        with h5py.File(src, "r+") as f:
            for group in f["episodes"].values():
                group.attrs["success"] = True
        convert([src], ConvertOptions(repo_id="local/warm", root=Path(tmp) / "warm", video=False))  # imports, caches
        rows = []
        for name, video, vcodec in (
            ("images (png)", False, "libsvtav1"),
            ("video libsvtav1", True, "libsvtav1"),
            ("video h264", True, "h264"),
        ):
            result = convert(
                [src],
                ConvertOptions(
                    repo_id="local/bench", root=Path(tmp) / name.replace(" ", "_"), video=video, vcodec=vcodec
                ),
            )
            size = sum(p.stat().st_size for p in result.root.rglob("*") if p.is_file())
            rows.append(
                {
                    "mode": name,
                    "episodes": result.episodes,
                    "frames": result.frames,
                    "seconds": round(result.seconds, 3),
                    "frames_per_s": round(result.frames_per_s, 1),
                    "dataset_mb": round(size / 1e6, 3),
                }
            )
    print(
        f"{args.episodes} episodes at {args.image_size}x{args.image_size} x 3 cameras (recording took {record_s:.1f} s), {os.cpu_count()} CPUs"
    )
    print(f"{'mode':<18}{'frames':>8}{'seconds':>10}{'frames/s':>10}{'MB':>9}")
    for r in rows:
        print(f"{r['mode']:<18}{r['frames']:>8}{r['seconds']:>10.2f}{r['frames_per_s']:>10.1f}{r['dataset_mb']:>9.2f}")
    args.out.write_text(
        json.dumps(
            {
                "git_sha": git_state()[0],
                "episodes": args.episodes,
                "image_size": args.image_size,
                "cpus": os.cpu_count(),
                "results": rows,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
