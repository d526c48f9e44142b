"""``pipette demo``: the whole pipeline on one task, small enough for a CPU, ending in a policy that works.

scripted demos -> success-verified augmentation -> LeRobot dataset -> small ACT training ->
closed-loop evaluation, then a summary table, a plot (training loss, evaluation outcomes), a
contact sheet / GIF of kept augmented episodes and a GIF of each evaluation episode. Every stage
is the same code the individual commands run.

The default task and budget (:data:`FULL`) were chosen so that a 2-core CPU learns the task in
about ten minutes: CloseSpectrophotometerLid, 20 scripted demonstrations at 64 px plus their
light and speed replays, ACT of the CPU reproduction (``docs/reproduction``) for 300 steps of
batch 8, 10 evaluation episodes. A run that learns less than :data:`MIN_SUCCESS` of its
evaluation episodes is reported as a failure (the CLI exits 1). Seeds are fixed (demos 0..,
training seed 1000, evaluation 1000..), so a rerun on the same machine repeats the run.
"""

from __future__ import annotations

import json
import logging
import os
import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants
from pipette_cli.demos.collect import collect
from pipette_cli.demos.store import read_episode, scan
from pipette_cli.errors import PipetteError, plural
from pipette_cli.evaluation.settings import DecodeConfig
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert
from pipette_cli.lerobot.train import IfExists, Policy, TrainOptions, logged_step, train_checkpoint
from pipette_cli.progress import ProgressFactory, ProgressLines, StageProgress
from pipette_cli.sim.scene import CAMERA_NAMES
from pipette_cli.sim.views import save_animation, views_sheet
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

DEFAULT_TASK = "CloseSpectrophotometerLid"
SMALL_ACT = (
    "--policy.dim_model=128",
    "--policy.dim_feedforward=512",
    "--policy.n_heads=4",
    "--policy.n_encoder_layers=2",
    "--policy.n_decoder_layers=1",
    "--policy.n_vae_encoder_layers=2",
    "--policy.latent_dim=16",
    "--policy.chunk_size=20",
    "--policy.n_action_steps=20",
    "--policy.optimizer_lr=1e-4",
    "--policy.optimizer_lr_backbone=1e-4",
    "--num_workers=1",
    "--log_freq=20",
    "--seed=1000",
)
"""The ACT of the CPU reproduction (``docs/reproduction``): dim 128, 2 encoder / 1 decoder layers,
chunk 20, ResNet-18 from scratch; it learns the lid tasks from a few dozen demonstrations. Its batches
are loaded by one dataloader worker while the training process computes (docs/training.md)."""
SMALL_ACT_THREADS = 1
"""Torch threads of the training process for :data:`SMALL_ACT` on a CPU: the training process on one
core, its dataloader worker on the other (a 2-core machine); with other work on the machine, two
threads wait for each other (``benchmarks/bench_train.py``, docs/training.md)."""
TINY_ACT = (
    "--policy.dim_model=64",
    "--policy.dim_feedforward=128",
    "--policy.n_heads=2",
    "--policy.n_encoder_layers=1",
    "--policy.n_decoder_layers=1",
    "--policy.n_vae_encoder_layers=1",
    "--policy.latent_dim=8",
    "--policy.chunk_size=10",
    "--policy.n_action_steps=10",
    "--num_workers=0",
    "--log_freq=1",
    "--seed=1000",
)
MIN_SUCCESS = 0.5
"""Evaluation success rate below which the demo reports that the policy did not learn the task."""


@dataclass(frozen=True)
class DemoSize:
    demos: int
    image_size: int
    train_steps: int
    batch_size: int
    eval_episodes: int
    variants: str
    act: tuple[str, ...]
    threads: int | None
    judged: bool
    """Whether the policy is expected to learn (False: a smoke run of every stage)."""


FULL = DemoSize(
    demos=20,
    image_size=64,
    train_steps=300,
    batch_size=8,
    eval_episodes=10,
    variants="original,light,speed",
    act=SMALL_ACT,
    threads=SMALL_ACT_THREADS,
    judged=True,
)
FAST = DemoSize(
    demos=2,
    image_size=32,
    train_steps=2,
    batch_size=4,
    eval_episodes=2,
    variants="light,speed",
    act=TINY_ACT,
    threads=SMALL_ACT_THREADS,
    judged=False,
)


def folder_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def contact_sheet(aug: Path, out_png: Path, out_gif: Path, *, tile: int = 128) -> None:
    """The main camera at 2/3 of every kept augmented episode, labelled with its variant, and
    the first episode's three views side by side, labelled, as a GIF; small images are scaled up."""
    from PIL import Image, ImageDraw  # deferred: PIL (~15 ms of `pipette --help`, which imports this module)

    refs = scan(aug).episodes
    if not refs:
        return
    tiles, frames = [], []
    for i, ref in enumerate(refs):
        record = read_episode(ref, images=True)
        main = record.images["main"]
        image = Image.fromarray(main[2 * len(main) // 3])
        scale = max(1, tile // image.width)
        image = image.resize((image.width * scale, image.height * scale), Image.Resampling.NEAREST)
        label = f"{i} {record.attrs.get('augment_variant', '')}".strip()  # episode index and variant, on black
        draw = ImageDraw.Draw(image)
        draw.rectangle(draw.textbbox((3, 2), label), fill="black")
        draw.text((3, 2), label, fill="white")
        tiles.append(image)
        if i == 0:
            for k in range(0, len(main), 3):
                views = {cam: record.images[cam][k] for cam in CAMERA_NAMES}
                frames.append(views_sheet(views, scale=scale))
    w, h = tiles[0].size
    cols = min(6, len(tiles))
    sheet = Image.new("RGB", (cols * w, ((len(tiles) + cols - 1) // cols) * h), "white")
    for i, image in enumerate(tiles):
        sheet.paste(image, ((i % cols) * w, (i // cols) * h))
    sheet.save(out_png)
    save_animation(frames, out_gif)


class RecordingSource:
    """An action source that keeps what the policy saw (its views, at its 10 Hz query rate) per
    evaluation episode, to write as GIFs of the views side by side, each labelled."""

    def __init__(self, source: Any) -> None:
        self.source = source
        self.episodes: list[list[dict[str, np.ndarray]]] = []

    def act(self, observation: dict[str, np.ndarray], *, task: str, reset: bool, chunk: bool) -> np.ndarray:
        if reset or not self.episodes:
            self.episodes.append([])
        views = {}
        for camera in CAMERA_NAMES:
            image = observation.get(f"observation.images.{camera}")
            if image is not None:
                image = np.asarray(image).transpose(1, 2, 0)
                views[camera] = image if image.dtype == np.uint8 else (image * 255).astype(np.uint8)
        if views:
            self.episodes[-1].append(views)
        return self.source.act(observation, task=task, reset=reset, chunk=chunk)

    def write_gifs(self, folder: Path, *, scale: int = 2) -> list[Path]:
        return [
            save_animation([views_sheet(views, scale=scale) for views in frames], folder / f"episode_{i:04d}.gif")
            for i, frames in enumerate(self.episodes)
            if frames
        ]


def training_losses(log_file: Path) -> list[tuple[int, float]]:
    """``(step, loss)`` from a ``lerobot-train`` log (its ``step:... loss:...`` lines)."""
    points = []
    if log_file.is_file():
        for line in log_file.read_text(errors="replace").splitlines():
            step, loss = logged_step(line), re.search(r"\bloss:([\d.eE+-]+)", line)
            if step is not None and loss:
                points.append((step, float(loss.group(1))))
    return points


def plot_run(out_png: Path, losses: list[tuple[int, float]], episodes: list[dict[str, Any]], title: str) -> None:
    """Left: training loss per step (log scale); right: each evaluation episode, green if it succeeded."""
    from PIL import Image, ImageDraw  # deferred: PIL (~15 ms of `pipette --help`, which imports this module)

    w, h, pad = 360, 200, 40
    image = Image.new("RGB", (2 * w + 3 * pad, h + 2 * pad + 34), "white")
    draw = ImageDraw.Draw(image)
    draw.text((pad, 6), title, fill="black")
    x0, y0 = pad, pad
    draw.rectangle([x0, y0, x0 + w, y0 + h], outline="black")
    draw.text((x0, y0 + h + 4), "ACT training loss (log) vs step", fill="black")
    if len(losses) >= 2:
        steps = np.array([s for s, _ in losses], dtype=float)
        logs = np.log10(np.maximum([v for _, v in losses], 1e-9))
        sx = (steps - steps.min()) / max(np.ptp(steps), 1e-9)
        sy = (logs - logs.min()) / max(np.ptp(logs), 1e-9)
        draw.line([(x0 + w * a, y0 + h - h * b) for a, b in zip(sx, sy)], fill=(40, 90, 170), width=2)
        draw.text((x0 + 4, y0 + 2), f"loss {10 ** logs.max():.3g}", fill="black")
        draw.text((x0 + 4, y0 + h - 14), f"loss {10 ** logs.min():.3g}", fill="black")
        draw.text((x0, y0 + h + 18), f"step {int(steps.min())}", fill="black")
        draw.text((x0 + w - 60, y0 + h + 18), f"step {int(steps.max())}", fill="black")
    x1 = 2 * pad + w
    draw.text((x1, y0 + h + 4), "evaluation episodes (green: success)", fill="black")
    cell = w / max(len(episodes), 1)
    for i, e in enumerate(episodes):
        color = (60, 160, 80) if e["success"] else (200, 70, 60)
        draw.rectangle([x1 + i * cell + 2, y0, x1 + (i + 1) * cell - 2, y0 + h], fill=color)
        draw.text((x1 + i * cell + 4, y0 + 4), f"{i}", fill="white")
    failed = [f"{i} {e.get('failure_reason') or 'failed'}" for i, e in enumerate(episodes) if not e["success"]]
    draw.text((x1, y0 + h + 18), "failed: " + (", ".join(failed[:6]) if failed else "none"), fill="black")
    image.save(out_png)


@contextmanager
def _stage(progress: StageProgress) -> Iterator[StageProgress]:
    """``progress`` for the length of a stage: stopped however the stage ends."""
    try:
        yield progress
    finally:
        progress.stop()


def run_demo(
    task: TaskSpec, out: Path, size: DemoSize, *, say: Any = print, progress: ProgressFactory | None = None
) -> dict[str, Any]:
    """Run the pipeline into ``out`` (created fresh) and return the summary.

    ``say`` gets a line after each stage; ``progress`` makes each stage's progress report
    (default: a line to ``say`` every few seconds, :class:`~pipette_cli.progress.ProgressLines`).
    """
    # deferred: the augmentation pipeline (~35 ms), evaluation (zmq, scipy: ~0.8 s), out of `pipette --help`
    from pipette_cli.augment.run import augment
    from pipette_cli.evaluation.runner import PolicySource, evaluate_task

    def lines(stage: str, unit: str) -> StageProgress:
        return ProgressLines(stage, say, unit=unit)

    report_progress = progress or lines

    if out.exists() and any(out.iterdir()):
        raise PipetteError(f"{out} is not empty; give another --out or remove it")
    out.mkdir(parents=True, exist_ok=True)
    # torch's OpenMP threads spin while they wait; on a machine that is also busy with other work
    # this made training 4.6x slower (40 ACT steps: 324 s spinning, 71 s passive, at load 5-6)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    timings: dict[str, float] = {}
    t = time.perf_counter()
    raw = out / "raw.h5"
    with _stage(report_progress("collect", "episodes")) as shown:
        collected = collect(
            task,
            raw,
            episodes=size.demos,
            seed=0,
            image_size=size.image_size,
            on_start=lambda have, todo: shown.start(todo),
            on_episode=lambda _: shown.update(advance=1),
        )
    timings["collect"] = time.perf_counter() - t
    say(f"collect: {sum(e.success for e in collected.added)}/{plural(len(collected.added), 'scripted demo')} succeeded")
    t = time.perf_counter()
    aug = out / "aug.h5"
    spec = AugmentSpec(variants=make_variants(size.variants.split(","), default_atoms()))
    with _stage(report_progress("augment", "demos")) as shown:
        augmented = augment(
            task,
            raw,
            aug,
            spec,
            workers=1,
            on_start=lambda skipped, todo: shown.start(todo),
            on_demo=lambda _: shown.update(advance=1),
        )
    timings["augment"] = time.perf_counter() - t
    kept, tried = augmented.report["kept"], augmented.report["attempts"]
    say(f"augment: {kept}/{plural(tried, 'variant')} kept")
    t = time.perf_counter()
    datasets = out / "datasets"
    slug = task.id.replace("/", "_")
    root = datasets / slug / "augmented"
    with _stage(report_progress("convert", "episodes")) as shown:
        convert(
            [aug],
            ConvertOptions(
                repo_id=f"local/{slug}_augmented", root=root, video=False, dataset_version=DatasetVersion.augmented
            ),
            on_plan=lambda plan: shown.start(len(plan.episodes)),
            on_episode=lambda done, total: shown.update(done, total=total),
        )
    timings["convert"] = time.perf_counter() - t
    say(f"convert: LeRobot dataset at {root} ({folder_size(root) / 1e6:.1f} MB)")
    t = time.perf_counter()
    options = TrainOptions(
        policy=Policy.act,
        dataset_version=DatasetVersion.augmented,
        steps=size.train_steps,
        batch_size=size.batch_size,
        device="cpu",
        datasets_root=datasets,
        output_root=out / "train",
        if_exists=IfExists.overwrite,
        offline=True,
        threads=size.threads,
        extra=size.act,
    )
    with _stage(report_progress("train", "steps")) as shown:
        shown.start(size.train_steps)
        checkpoint = train_checkpoint(task.id, options, on_step=lambda step: shown.update(step))
    timings["train"] = time.perf_counter() - t
    say(f"train: ACT, {size.train_steps} steps of batch {size.batch_size} -> {checkpoint}")
    t = time.perf_counter()
    policy, recorded = PolicySource(checkpoint=checkpoint, device="cpu"), []

    def recording(worker: int, config: DecodeConfig) -> RecordingSource:
        recorded.append(RecordingSource(policy(worker, config)))
        return recorded[-1]

    with _stage(report_progress("eval", "episodes")) as shown:
        summary = evaluate_task(
            task,
            recording,
            DecodeConfig.for_policy("act"),
            episodes=size.eval_episodes,
            seed=1000,
            out=out / "eval",
            image_size=size.image_size,
            dataset_version="augmented",  # the label `pipette eval report` groups by
            on_start=lambda done, todo: shown.start(todo),
            on_episode=lambda log: shown.update(advance=1),
        )
    timings["eval"] = time.perf_counter() - t
    videos = [path for source in recorded for path in source.write_gifs(out / "eval")]
    contact_sheet(aug, out / "augmented_sheet.png", out / "augmented.gif")
    episodes = [json.loads(p.read_text()) for p in sorted((out / "eval").glob("episode_*.json"))]
    log_file = next(iter(sorted((out / "train").glob("*/*.log"))), out / "train" / "missing.log")
    plot_run(
        out / "summary.png",
        training_losses(log_file),
        episodes,
        f"{task.id}: {summary['successes']}/{plural(summary['episodes'], 'evaluation episode')} succeeded",
    )
    learned = summary["success_rate"] >= MIN_SUCCESS if size.judged else None
    report = {
        "task": task.id,
        "robot": task.embodiment.robot,
        "demos": len(collected.added),
        "demo_successes": sum(e.success for e in collected.added),
        "augmented_attempts": tried,
        "augmented_kept": kept,
        "yield": kept / tried if tried else 0.0,
        "dataset_mb": folder_size(root) / 1e6,
        "dataset": str(root),
        "checkpoint": str(checkpoint),
        "image_size": size.image_size,
        "train_steps": size.train_steps,
        "batch_size": size.batch_size,
        "eval_episodes": summary["episodes"],
        "eval_successes": summary["successes"],
        "success_rate": summary["success_rate"],
        "failures": summary["failures"],
        "failed_episodes": [
            {"episode": e["episode"], "seed": e["seed"], "reason": e.get("failure_reason") or "failed"}
            for e in episodes
            if not e["success"]
        ],
        "learned": learned,
        "min_success_rate": MIN_SUCCESS if size.judged else None,
        "videos": [str(p) for p in videos],
        "augmented_video": str(out / "augmented.gif"),
        "plots": [str(out / "summary.png"), str(out / "augmented_sheet.png")],
        "seconds": {k: round(v, 1) for k, v in timings.items()},
        "total_seconds": round(sum(timings.values()), 1),
    }
    (out / "demo_summary.json").write_text(json.dumps(report, indent=2))
    return report


def verdict_line(report: dict[str, Any]) -> str:
    """One plain sentence: did the policy learn the task?"""
    n, k = report["eval_episodes"], report["eval_successes"]
    if report["learned"] is None:
        return (
            f"smoke run: {report['train_steps']} training steps do not train a policy, so its {k}/{n} "
            "evaluation successes mean nothing; run `pipette demo` without --fast for a policy that works"
        )
    if report["learned"]:
        return f"the learned policy works: {k}/{plural(n, 'evaluation episode')} succeeded"
    return (
        f"the learned policy FAILED: only {k}/{plural(n, 'evaluation episode')} succeeded (this demo expects at least "
        f"{100 * report['min_success_rate']:.0f} %); failures: {report['failures']}"
    )


def next_steps(report: dict[str, Any]) -> str:
    """What to try with the policy the demo trained: more episodes, or serve it."""
    checkpoint, task = report["checkpoint"], report["task"]
    return (
        f"next: evaluate it on more episodes (pipette eval {task} --policy {checkpoint} --episodes 50 --image-size "
        f"{report['image_size']} --out evals/demo) or serve it (pipette serve --policy {checkpoint})"
    )


def summary_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    return [
        ("task", report["task"]),
        ("robot", report["robot"]),
        ("scripted demos (succeeded)", f"{report['demos']} ({report['demo_successes']})"),
        (
            "augmented variants kept",
            f"{report['augmented_kept']}/{report['augmented_attempts']} (yield {100 * report['yield']:.0f} %)",
        ),
        ("LeRobot dataset", f"{report['dataset_mb']:.1f} MB: {report['dataset']}"),
        ("ACT training", f"{report['train_steps']} steps of batch {report['batch_size']}"),
        (
            "evaluation success rate",
            f"{100 * report['success_rate']:.0f} % ({report['eval_successes']} of {report['eval_episodes']})"
            + "".join(f"; episode {f['episode']}: {f['reason']}" for f in report["failed_episodes"][:5]),
        ),
        ("policy", report["checkpoint"]),
        (
            "time (s)",
            ", ".join(f"{k} {v}" for k, v in report["seconds"].items()) + f"; total {report['total_seconds']}",
        ),
        (
            "videos",
            ", ".join(
                report["videos"][:1]
                + ([f"... ({len(report['videos'])} evaluation GIFs)"] if len(report["videos"]) > 1 else [])
                + [f"augmented: {report['augmented_video']}"]
            ),
        ),
        ("plots", ", ".join(report["plots"])),
    ]


__all__ = ["DEFAULT_TASK", "FAST", "FULL", "MIN_SUCCESS", "next_steps", "run_demo", "summary_rows", "verdict_line"]
