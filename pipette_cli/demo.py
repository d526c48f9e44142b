"""``pipette demo``: the whole pipeline on one task, small enough for a CPU.

scripted demos -> success-verified augmentation -> LeRobot dataset -> tiny ACT training ->
closed-loop evaluation, then a summary table and a contact sheet / GIF of kept augmented
episodes. Every stage is the same code the individual commands run.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any


from pipette_cli.errors import PipetteError
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

TINY_ACT = (
    "--policy.dim_model=64", "--policy.dim_feedforward=128", "--policy.n_heads=2", "--policy.n_encoder_layers=1",
    "--policy.n_decoder_layers=1", "--policy.n_vae_encoder_layers=1", "--policy.latent_dim=8",
    "--policy.chunk_size=10", "--policy.n_action_steps=10", "--num_workers=0", "--log_freq=10",
)


@dataclass(frozen=True)
class DemoSize:
    demos: int
    image_size: int
    train_steps: int
    eval_episodes: int
    variants: str


FULL = DemoSize(demos=6, image_size=64, train_steps=100, eval_episodes=4, variants="light,speed,light+speed")
FAST = DemoSize(demos=2, image_size=32, train_steps=2, eval_episodes=2, variants="light,speed")


def folder_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def contact_sheet(aug: Path, out_png: Path, out_gif: Path, *, tile: int = 128) -> None:
    """The main camera at 2/3 of every kept augmented episode, labelled with its variant, and
    the first episode's three views side by side as a GIF; small images are scaled up."""
    from PIL import Image, ImageDraw

    from pipette_cli.demos.store import read_episode, scan

    refs = scan(aug).episodes
    if not refs:
        return
    tiles, frames = [], []
    for i, ref in enumerate(refs):
        record = read_episode(ref, images=True)
        main = record.images["main"]
        image = Image.fromarray(main[2 * len(main) // 3])
        scale = max(1, tile // image.width)
        image = image.resize((image.width * scale, image.height * scale), Image.NEAREST)
        ImageDraw.Draw(image).text((3, 2), str(record.attrs.get("augment_variant", "")), fill="yellow")
        tiles.append(image)
        if i == 0:
            for k in range(0, len(main), 3):
                views = [Image.fromarray(record.images[cam][k]) for cam in ("top", "main", "wrist")]
                strip = Image.new("RGB", (3 * image.width, image.height))
                for j, view in enumerate(views):
                    strip.paste(view.resize(image.size, Image.NEAREST), (j * image.width, 0))
                frames.append(strip)
    w, h = tiles[0].size
    cols = min(6, len(tiles))
    sheet = Image.new("RGB", (cols * w, ((len(tiles) + cols - 1) // cols) * h), "white")
    for i, image in enumerate(tiles):
        sheet.paste(image, ((i % cols) * w, (i // cols) * h))
    sheet.save(out_png)
    frames[0].save(out_gif, save_all=True, append_images=frames[1:], duration=100, loop=0)


def run_demo(task: TaskSpec, out: Path, size: DemoSize, *, say: Any = print) -> dict[str, Any]:
    """Run the pipeline into ``out`` (created fresh) and return the summary."""
    from pipette_cli.augment.run import augment
    from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants
    from pipette_cli.demos.collect import collect
    from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert
    from pipette_cli.lerobot.evaluate import DecodeConfig
    from pipette_cli.lerobot.runner import PolicySource, evaluate_task
    from pipette_cli.lerobot.train import IfExists, Policy, TrainOptions, train_checkpoint

    if out.exists() and any(out.iterdir()):
        raise PipetteError(f"{out} is not empty; give another --out or remove it")
    out.mkdir(parents=True, exist_ok=True)
    timings: dict[str, float] = {}
    t = time.perf_counter()
    raw = out / "raw.h5"
    collected = collect(task, raw, episodes=size.demos, seed=0, image_size=size.image_size)
    timings["collect"] = time.perf_counter() - t
    say(f"collect: {sum(e.success for e in collected.added)}/{len(collected.added)} scripted demos succeeded")
    t = time.perf_counter()
    aug = out / "aug.h5"
    spec = AugmentSpec(variants=make_variants(size.variants.split(","), default_atoms()))
    augmented = augment(task, raw, aug, spec, workers=1)
    timings["augment"] = time.perf_counter() - t
    kept, tried = augmented.report["kept"], augmented.report["attempts"]
    say(f"augment: {kept}/{tried} variants kept")
    t = time.perf_counter()
    datasets = out / "datasets"
    slug = task.id.replace("/", "_")
    root = datasets / slug / "augmented"
    convert([aug], ConvertOptions(repo_id=f"local/{slug}_augmented", root=root, video=False,
                                  dataset_version=DatasetVersion.augmented))
    timings["convert"] = time.perf_counter() - t
    say(f"convert: LeRobot dataset at {root} ({folder_size(root) / 1e6:.1f} MB)")
    t = time.perf_counter()
    options = TrainOptions(policy=Policy.act, dataset_version=DatasetVersion.augmented, steps=size.train_steps,
                           batch_size=4, device="cpu", datasets_root=datasets, output_root=out / "train",
                           if_exists=IfExists.overwrite, offline=True, extra=TINY_ACT)
    checkpoint = train_checkpoint(task.id, options)
    timings["train"] = time.perf_counter() - t
    say(f"train: tiny ACT, {size.train_steps} steps -> {checkpoint}")
    t = time.perf_counter()
    summary = evaluate_task(task, PolicySource(checkpoint=checkpoint, device="cpu"), DecodeConfig.for_policy("act"),
                            episodes=size.eval_episodes, seed=1000, out=out / "eval", image_size=size.image_size,
                            dataset_version="augmented")  # the label `pipette eval report` groups by
    timings["eval"] = time.perf_counter() - t
    contact_sheet(aug, out / "augmented_sheet.png", out / "augmented.gif")
    report = {
        "task": task.id, "demos": len(collected.added), "demo_successes": sum(e.success for e in collected.added),
        "augmented_attempts": tried, "augmented_kept": kept, "yield": kept / tried if tried else 0.0,
        "dataset_mb": folder_size(root) / 1e6,
        "train_steps": size.train_steps, "eval_episodes": summary["episodes"], "success_rate": summary["success_rate"],
        "seconds": {k: round(v, 1) for k, v in timings.items()}, "total_seconds": round(sum(timings.values()), 1),
    }
    (out / "demo_summary.json").write_text(json.dumps(report, indent=2))
    return report


def summary_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    return [
        ("task", report["task"]),
        ("scripted demos (succeeded)", f"{report['demos']} ({report['demo_successes']})"),
        ("augmented variants kept", f"{report['augmented_kept']}/{report['augmented_attempts']} (yield {100 * report['yield']:.0f} %)"),
        ("LeRobot dataset", f"{report['dataset_mb']:.1f} MB"),
        ("ACT training steps", str(report["train_steps"])),
        ("evaluation success rate", f"{100 * report['success_rate']:.0f} % of {report['eval_episodes']}"),
        ("time (s)", ", ".join(f"{k} {v}" for k, v in report["seconds"].items()) + f"; total {report['total_seconds']}"),
    ]


__all__ = ["FAST", "FULL", "run_demo", "summary_rows"]
