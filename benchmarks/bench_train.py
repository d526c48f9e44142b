"""Seconds per ``lerobot-train`` ACT step on this CPU, as the CPU reproduction preset runs it, and
what each lever changes.

A small real dataset (6 scripted CloseCentrifugeLid demonstrations at 64 px, also at 32 px for the
image-size row) is converted twice, PNG images (``pipette convert --images``, what the presets
train on) and MP4 video. Then every configuration runs ``lerobot-train`` (the command that
``pipette train`` builds: LeRobot's ACT policy and LeRobotDataset, the preset's small ACT: dim
128, 2 encoder / 1 decoder layers, chunk 20, ResNet-18 from scratch, batch 8) for ``--steps``
steps with ``--log_freq=1``; each step's ``data_s`` (waiting for the batch: loading, decoding,
collation, normalisation; with workers only what they did not hide) and ``updt_s`` (forward,
backward, gradient clipping, optimizer) are parsed from its log, the first ``--warmup`` steps
(start-up, worker spawn) dropped, and the median kept. Configurations run interleaved, round
after round (A, B, C, A, B, C, ...), and each row is the median over rounds, so a machine shared
with other work slows every row alike; the load average before each run is recorded.

``--components`` also times the parts in one process (interleaved): one sample's
``LeRobotDataset.__getitem__`` from images and from video, the default collation of a batch,
and ResNet-18 forward+backward, the whole ACT forward+backward and the optimizer step on a
batch, with 1 and 2 torch threads.

    python benchmarks/bench_train.py --rounds 2 --components --out docs/benchmarks/bench_train.json
    python benchmarks/bench_train.py --configs before,after --rounds 3 --steps 60
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")
THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OMP_WAIT_POLICY")
INHERITED = {k: os.environ.pop(k) for k in THREAD_VARIABLES if k in os.environ}  # each row sets its own

from pipette_cli.demo import SMALL_ACT, SMALL_ACT_THREADS  # noqa: E402
from pipette_cli.demos.collect import collect  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert, slug  # noqa: E402
from pipette_cli.lerobot.train import (  # noqa: E402
    IfExists,
    Policy,
    TrainOptions,
    dataset_root,
    lerobot_train_executable,
    plan,
    run_dir,
    run_job,
)
from pipette_cli.registry import load_registry  # noqa: E402

TASK = "pipette/CloseCentrifugeLid-v1"
STEP = re.compile(r"step:(\d+) .*?loss:([\d.]+) .*?updt_s:([\d.]+) data_s:([\d.]+)")
# lerobot-train flags of the CPU preset before this benchmark: data loaded in the training process
BEFORE = ("--num_workers=0",)


@dataclass(frozen=True)
class Config:
    """One row: which dataset, which flags after the preset's, which torch threads."""

    what: str
    data: str = "images"
    flags: tuple[str, ...] = ()
    threads: int | None = None
    env: tuple[tuple[str, str], ...] = ()
    batch_size: int = 8


AFTER = Config("the preset now: 1 torch thread, 1 dataloader worker", threads=SMALL_ACT_THREADS)
CONFIGS = {
    "before": Config("the preset before: images, data in the training process, torch's 2 threads", flags=BEFORE),
    "video": Config("before, MP4 video (pyav) instead of PNG images", data="video", flags=BEFORE),
    "threads1": Config("before, 1 torch thread (OMP_NUM_THREADS=1)", flags=BEFORE, threads=1),
    "workers1": Config("before, 1 dataloader worker (--num_workers=1)"),
    "after": AFTER,
    "after_video": replace(AFTER, what="after, MP4 video", data="video"),
    "after_passive2": replace(
        AFTER,
        what="after, 2 torch threads with OMP_WAIT_POLICY=PASSIVE",
        threads=2,
        env=(("OMP_WAIT_POLICY", "PASSIVE"),),
    ),
    "after_bf16": replace(
        AFTER, what="after, bfloat16 autocast (--policy.use_amp=true)", flags=("--policy.use_amp=true",)
    ),
    "after_dim64": replace(
        AFTER,
        what="after, dim_model 64, dim_feedforward 256",
        flags=("--policy.dim_model=64", "--policy.dim_feedforward=256"),
    ),
    "after_32px": replace(AFTER, what="after, 32 px images (another dataset)", data="images32"),
    "after_batch4": replace(AFTER, what="after, batch 4", batch_size=4),
    "after_batch16": replace(AFTER, what="after, batch 16", batch_size=16),
}
DATASETS = {"images": (64, False), "video": (64, True), "images32": (32, False)}


def build_datasets(work: Path, episodes: int, names: set[str]) -> dict[str, Path]:
    """``work/<name>/<task>/raw`` for each of :data:`DATASETS` in ``names`` (reused when present)."""
    task = load_registry().get(TASK)
    roots = {}
    for name in sorted(names):
        size, video = DATASETS[name]
        roots[name] = work / name
        root = dataset_root(TASK, DatasetVersion.raw, roots[name])
        if (root / "meta" / "info.json").is_file():
            continue
        demos = work / f"demos_{size}.h5"
        if not demos.is_file():
            collect(task, demos, episodes=episodes, seed=0, image_size=size)
        convert([demos], ConvertOptions(repo_id=f"local/{slug(TASK)}_raw", root=root, video=video, overwrite=True))
    return roots


def run_config(name: str, config: Config, roots: dict[str, Path], work: Path, steps: int) -> dict[str, Any]:
    """One ``lerobot-train`` run of ``config``; its per-step timings parsed from the log."""
    options = TrainOptions(
        policy=Policy.act,
        steps=steps,
        batch_size=config.batch_size,
        device="cpu",
        datasets_root=roots[config.data],
        output_root=work / "runs" / name,
        if_exists=IfExists.overwrite,
        offline=True,
        threads=config.threads,
        extra=(*SMALL_ACT, *config.flags, "--log_freq=1", "--save_checkpoint=false"),
    )
    output = run_dir(TASK, Policy.act, DatasetVersion.raw, options.output_root)
    shutil.rmtree(output, ignore_errors=True)  # lerobot-train refuses an existing output folder
    [job] = plan([TASK], options, executable=lerobot_train_executable())
    job.log_file.unlink(missing_ok=True)
    job = replace(job, env={**job.env, **dict(config.env)})
    load = os.getloadavg()[0]
    start = time.perf_counter()
    result = run_job(job)
    wall = time.perf_counter() - start
    rows = [tuple(map(float, m.groups())) for m in STEP.finditer(job.log_file.read_text())]
    if result.returncode != 0 or len(rows) < steps:
        raise SystemExit(f"{name}: lerobot-train failed or logged {len(rows)}/{steps} steps; see {job.log_file}")
    return {"argv": list(job.argv), "env": job.env, "load": load, "wall_s": wall, "steps": rows}


def summarise(runs: list[dict[str, Any]], warmup: int, batch_size: int) -> dict[str, Any]:
    """Median over rounds of each run's median step (after ``warmup`` steps)."""

    def per_run(column: int) -> list[float]:
        return [statistics.median(r[column] for r in run["steps"][warmup:]) for run in runs]

    update, data = per_run(2), per_run(3)
    step = [statistics.median(r[2] + r[3] for r in run["steps"][warmup:]) for run in runs]
    median = statistics.median(step)
    return {
        "s_per_step": median,
        "s_per_step_rounds": step,
        "data_s": statistics.median(data),
        "update_s": statistics.median(update),
        "samples_per_s": batch_size / median,
        "final_loss": statistics.mean(r[1] for r in runs[0]["steps"][-10:]),
        "load": [run["load"] for run in runs],
    }


def components(roots: dict[str, Path], rounds: int) -> dict[str, float]:
    """Seconds of each part of a step, measured in this process, interleaved over ``rounds``."""
    # deferred: torch, lerobot (only with --components)
    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.factory import make_policy
    from torch.utils.data import default_collate

    size = dict(arg.removeprefix("--policy.").split("=", 1) for arg in SMALL_ACT if arg.startswith("--policy."))
    actions = [i / 10 for i in range(int(size["chunk_size"]))]
    sets = {
        name: LeRobotDataset(
            f"local/{slug(TASK)}_raw",
            root=dataset_root(TASK, DatasetVersion.raw, roots[name]),
            delta_timestamps={"action": actions},
            video_backend="pyav",
        )
        for name in ("images", "video")
    }
    config = ACTConfig(
        device="cpu",
        pretrained_backbone_weights=None,
        **{k: type(getattr(ACTConfig, k))(v) for k, v in size.items() if not k.startswith("optimizer")},
    )
    policy = make_policy(config, ds_meta=sets["images"].meta)
    policy.train()
    optimizer = torch.optim.AdamW(policy.parameters(), lr=1e-4, weight_decay=1e-4)
    batch = {
        k: v
        for k, v in default_collate([sets["images"][i] for i in range(8)]).items()
        if (isinstance(v, torch.Tensor) and v.dtype.is_floating_point) or k == "action_is_pad"
    }
    cameras = [v for k, v in batch.items() if k.startswith("observation.images.")]

    def sample(name: str) -> None:
        for i in range(8):
            sets[name][(37 * i) % len(sets[name])]

    def collate() -> None:
        default_collate(items)

    def backbone() -> None:
        sum(policy.model.backbone(image)["feature_map"].sum() for image in cameras).backward()
        optimizer.zero_grad()

    def forward_backward() -> None:
        policy.forward(batch)[0].backward()
        optimizer.zero_grad()

    def optimizer_step() -> None:
        for p in policy.parameters():
            p.grad = torch.zeros_like(p)
        torch.nn.utils.clip_grad_norm_(policy.parameters(), 10.0)
        optimizer.step()
        optimizer.zero_grad()

    items = [sets["images"][i] for i in range(8)]
    parts = {"dataset_8_samples_images": lambda: sample("images"), "dataset_8_samples_video": lambda: sample("video")}
    parts["collate_8"] = collate
    for threads in (1, 2):
        for part, fn in (
            ("resnet18_fwd_bwd", backbone),
            ("act_fwd_bwd", forward_backward),
            ("optimizer", optimizer_step),
        ):
            parts[f"{part}_{threads}t"] = lambda fn=fn, threads=threads: (torch.set_num_threads(threads), fn())
    times: dict[str, list[float]] = {k: [] for k in parts}
    for fn in parts.values():
        fn()
    for _ in range(max(3, rounds)):
        for name, fn in parts.items():
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    return {k: round(statistics.median(v), 4) for k, v in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", type=Path, default=Path("/tmp/bench_train"), help="Datasets and runs (reused).")
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--configs", default=",".join(CONFIGS), help=f"Comma-separated rows of {', '.join(CONFIGS)}.")
    parser.add_argument("--steps", type=int, default=30, help="Training steps per run.")
    parser.add_argument("--warmup", type=int, default=5, help="First steps of each run left out.")
    parser.add_argument("--rounds", type=int, default=2, help="Interleaved rounds; each row is their median.")
    parser.add_argument("--components", action="store_true", help="Also time the parts of a step in-process.")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "benchmarks" / "bench_train.json")
    args = parser.parse_args()
    names = args.configs.split(",")
    unknown = set(names) - set(CONFIGS)
    if unknown:
        parser.error(f"unknown --configs {sorted(unknown)}; choose from {', '.join(CONFIGS)}")
    roots = build_datasets(
        args.work, args.episodes, {CONFIGS[n].data for n in names} | ({"images", "video"} if args.components else set())
    )
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in names}
    for r in range(args.rounds):
        for name in names:
            runs[name].append(run_config(name, CONFIGS[name], roots, args.work, args.steps))
            print(f"round {r + 1}/{args.rounds} {name}: {runs[name][-1]['wall_s']:.0f} s", file=sys.stderr, flush=True)
    rows = {name: {**summarise(runs[name], args.warmup, CONFIGS[name].batch_size)} for name in names}
    base = rows.get("before", {}).get("s_per_step")
    print(f"| config | s/step | speed-up | samples/s | data_s | updt_s | loss at step {args.steps} | what |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for name, row in rows.items():
        speedup = f"{base / row['s_per_step']:.2f}x" if base else "-"
        print(
            f"| {name} | {row['s_per_step']:.3f} | {speedup} | {row['samples_per_s']:.1f} | {row['data_s']:.3f} "
            f"| {row['update_s']:.3f} | {row['final_loss']:.2f} | {CONFIGS[name].what} |"
        )
    parts = components(roots, 5) if args.components else None
    if parts:
        print("\n| part (in-process) | median s |\n| --- | ---: |")
        for name, seconds in parts.items():
            print(f"| {name} | {seconds:.4f} |")
    commit, dirty = git_state()
    data = {
        "benchmark": "bench_train",
        "command": "python benchmarks/bench_train.py " + " ".join(sys.argv[1:]),
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "inherited_env": INHERITED},
        "task": TASK,
        "settings": {
            "steps": args.steps,
            "warmup": args.warmup,
            "rounds": args.rounds,
            "episodes": args.episodes,
            "git_commit": commit,
            "git_dirty": dirty,
        },
        "preset_flags": list(SMALL_ACT),
        "rows": {name: {"what": CONFIGS[name].what, **row} for name, row in rows.items()},
        "components_s": parts,
        "runs": {name: [{k: v for k, v in run.items() if k != "steps"} for run in rs] for name, rs in runs.items()},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
