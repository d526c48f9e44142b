"""The paper's ACT experiment (table 2): raw vs success-verified augmented demonstrations.

For each task: 30 scripted demonstrations -> augmentation (re-simulated, re-rendered, kept only
when the task's evaluator accepts the replay) -> two LeRobot datasets (raw; augmented, which
holds the re-rendered originals plus the perturbed replays) -> one ACT policy per dataset ->
closed-loop evaluation of both on the same seeds. Every stage is the code behind the `pipette`
commands (collect, augment, convert, train, eval) and resumes where it stopped: run it again
and finished stages are reused.

Presets (each setting can be overridden by its flag):

  cpu    this machine's scale: 64 px images, a small ACT, 300 steps of batch 8 (lr 1e-4),
         10 evaluation episodes; about 25 minutes per task on 2 CPU cores.
  paper  the paper's settings (appendix D.1, table 6): 400 px images, LeRobot's default ACT,
         15000 steps of batch 32, 100 evaluation episodes, on CUDA.

The table (markdown), its data (JSON, with the git commit and every setting) and a bar chart
go to --docs; regressions (augmented below raw) are listed as plainly as gains, next to the
paper's ACT numbers for the same tasks.

    python benchmarks/reproduce_table.py --preset cpu --work runs/reproduce --docs docs/reproduction
    python benchmarks/reproduce_table.py --preset paper --tasks all --work /data/reproduce --docs docs/reproduction_paper
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")

from pipette_cli.augment.run import augment  # noqa: E402
from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants  # noqa: E402
from pipette_cli.demo import SMALL_ACT  # noqa: E402
from pipette_cli.demos.collect import collect  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.demos.store import scan  # noqa: E402
from pipette_cli.lerobot import report  # noqa: E402
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert  # noqa: E402
from pipette_cli.lerobot.evaluate import DecodeConfig, InProcessSource, evaluate  # noqa: E402
from pipette_cli.lerobot.train import IfExists, Policy, TrainOptions, train_checkpoint  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.specs.task import TaskSpec  # noqa: E402


@dataclass(frozen=True)
class Preset:
    demos: int
    image_size: int
    variants: str
    steps: int
    batch_size: int
    eval_episodes: int
    device: str
    act_flags: tuple[str, ...]


PRESETS = {
    "cpu": Preset(demos=30, image_size=64, variants="original,light,speed,light+speed", steps=300, batch_size=8,
                  eval_episodes=10, device="cpu", act_flags=SMALL_ACT),
    "paper": Preset(demos=30, image_size=400, variants="original,paper", steps=15000, batch_size=32,
                    eval_episodes=100, device="cuda", act_flags=("--num_workers=4",)),
}
CPU_TASKS = ("CloseCentrifugeLid", "OpenCentrifugeLid", "CloseSpectrophotometerLid", "PickUpTestTube")
# The paper's ACT success rates (table 2), raw ("Unenh.") and augmented ("Enh."), in percent.
PAPER_ACT = {
    "pipette/PickUpTestTube-v1": (100, 100), "pipette/PipetteToPetriDish-v1": (81, 78),
    "pipette/RemovePetriDishFromIncubator-v1": (0, 9), "pipette/PlacePetriDishInIncubator-v1": (57, 90),
    "pipette/CloseCentrifugeLid-v1": (76, 84), "pipette/OpenCentrifugeLid-v1": (88, 100),
    "pipette/OpenWaterBathLid-v1": (70, 98), "pipette/CloseSpectrophotometerLid-v1": (83, 52),
    "pipette/PlaceTubeOnBalance-v1": (58, 3), "pipette/RemoveTubeFromBalance-v1": (40, 71),
    "pipette/PlacePipetteInRack-v1": (67, 5), "pipette/PlaceFlaskOnShaker-v1": (4, 18),
}
VERSIONS = (DatasetVersion.raw, DatasetVersion.augmented)
EVAL_SEED = 100_000  # evaluation seeds never overlap the demonstrations' (0 .. demos - 1)


def say(message: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)


def run_task(task: TaskSpec, preset: Preset, work: Path) -> dict[str, Any]:
    """All stages of one task under ``work/<task>``; returns its results and stage timings."""
    slug = task.id.replace("/", "_")
    folder = work / slug
    folder.mkdir(parents=True, exist_ok=True)
    seconds: dict[str, float] = {}
    t = time.perf_counter()
    raw = folder / "raw.h5"
    collect(task, raw, episodes=preset.demos, seed=0, image_size=preset.image_size)
    seconds["collect"] = time.perf_counter() - t
    demos = scan(raw).episodes
    say(f"{task.id}: {sum(r.summary.success for r in demos)}/{len(demos)} demonstrations succeeded")
    t = time.perf_counter()
    aug = folder / "aug.h5"
    spec = AugmentSpec(variants=make_variants(preset.variants.split(","), default_atoms()))
    result = augment(task, raw, aug, spec, workers=1)
    seconds["augment"] = time.perf_counter() - t
    kept, tried = result.report["kept"], result.report["attempts"]
    say(f"{task.id}: augmentation kept {kept}/{tried} replays")
    datasets = folder / "datasets"
    inputs = {DatasetVersion.raw: raw, DatasetVersion.augmented: aug}
    versions: dict[str, Any] = {}
    for version in VERSIONS:
        name = version.value
        t = time.perf_counter()
        root = datasets / slug / name
        if not (root / "meta" / "info.json").is_file():
            convert([inputs[version]], ConvertOptions(repo_id=f"local/{slug}_{name}", root=root, video=False,
                                                      dataset_version=version, overwrite=True))
        seconds[f"convert_{name}"] = time.perf_counter() - t
        frames = json.loads((root / "meta" / "info.json").read_text())
        t = time.perf_counter()
        options = TrainOptions(policy=Policy.act, dataset_version=version, steps=preset.steps, batch_size=preset.batch_size,
                               device=preset.device, datasets_root=datasets, output_root=folder / "train",
                               if_exists=IfExists.skip, offline=True, extra=preset.act_flags)
        checkpoint = train_checkpoint(task.id, options, on_train=lambda job: say(
            f"{task.id}: training ACT on {name} ({frames['total_episodes']} episodes, {frames['total_frames']} frames)"))
        seconds[f"train_{name}"] = time.perf_counter() - t
        t = time.perf_counter()
        out = folder / "eval" / name
        summary_file = out / "summary.json"
        summary = json.loads(summary_file.read_text()) if summary_file.is_file() else {}
        if summary.get("episodes") != preset.eval_episodes:
            summary = evaluate(task, InProcessSource(checkpoint, device=preset.device), DecodeConfig.for_policy("act"),
                               episodes=preset.eval_episodes, seed=EVAL_SEED, out=out, image_size=preset.image_size)
            summary["dataset_version"] = name
            summary_file.write_text(json.dumps(summary, indent=2))
        seconds[f"eval_{name}"] = time.perf_counter() - t
        say(f"{task.id}: ACT on {name}: {summary['successes']}/{summary['episodes']} successes")
        versions[name] = {"episodes": frames["total_episodes"], "frames": frames["total_frames"],
                          "successes": summary["successes"], "eval_episodes": summary["episodes"],
                          "success_rate": summary["success_rate"], "failures": summary["failures"]}
    timings = folder / "seconds.json"  # a resumed run skips finished stages: keep the time they took
    previous = json.loads(timings.read_text()) if timings.is_file() else {}
    seconds = {k: round(max(v, previous.get(k, 0.0)), 1) for k, v in seconds.items()}
    timings.write_text(json.dumps(seconds, indent=2))
    return {"task": task.id, "demos": len(demos), "demo_successes": sum(r.summary.success for r in demos),
            "augment_kept": kept, "augment_tried": tried, "versions": versions,
            "seconds": seconds}


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a success rate (sound at 0/n and n/n, unlike the normal one)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * ((p * (1 - p) + z * z / (4 * n)) / n) ** 0.5 / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def rate(v: dict[str, Any]) -> str:
    low, high = wilson(v["successes"], v["eval_episodes"])
    return f"{v['successes']}/{v['eval_episodes']} ({100 * v['success_rate']:.0f} %, {100 * low:.0f}-{100 * high:.0f})"


def verdict(raw: float, augmented: float) -> str:
    if augmented > raw:
        return "gain"
    return "regression" if augmented < raw else "no change"


def write_docs(results: list[dict[str, Any]], settings: dict[str, Any], command: str, docs: Path) -> str:
    """``table.md``, ``results.json`` and ``success.png`` in ``docs``; returns the markdown table."""
    docs.mkdir(parents=True, exist_ok=True)
    rows = [{"task": r["task"], "policy": "act", "version": name, "episodes": v["eval_episodes"], "success_rate": v["success_rate"]}
            for r in results for name, v in r["versions"].items()]
    report.bar_chart(rows, docs / "success.png")
    lines = [
        "| task | demos (ok) | augmented kept / tried | raw episodes / frames | augmented episodes / frames "
        "| ACT raw (95 % CI) | ACT augmented (95 % CI) | change | paper ACT raw -> augmented |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |",
    ]
    tally: dict[str, list[str]] = {"gain": [], "regression": [], "no change": []}
    for r in results:
        raw, aug = r["versions"]["raw"], r["versions"]["augmented"]
        change = verdict(raw["success_rate"], aug["success_rate"])
        tally[change].append(r["task"].split("/")[-1])
        paper = PAPER_ACT.get(r["task"])
        lines.append(
            f"| {r['task']} | {r['demos']} ({r['demo_successes']}) | {r['augment_kept']} / {r['augment_tried']} "
            f"| {raw['episodes']} / {raw['frames']} | {aug['episodes']} / {aug['frames']} "
            f"| {rate(raw)} | {rate(aug)} "
            f"| {change} ({100 * (aug['success_rate'] - raw['success_rate']):+.0f} pt) "
            f"| {f'{paper[0]} -> {paper[1]}' if paper else '-'} |"
        )
    mean = {name: sum(r["versions"][name]["success_rate"] for r in results) / len(results) for name in ("raw", "augmented")}
    lines += [
        "",
        f"Mean success: raw {100 * mean['raw']:.1f} %, augmented {100 * mean['augmented']:.1f} %.",
        f"Augmented above raw on {len(tally['gain'])} task(s) ({', '.join(tally['gain']) or 'none'}), "
        f"below raw on {len(tally['regression'])} ({', '.join(tally['regression']) or 'none'}), "
        f"equal on {len(tally['no change'])} ({', '.join(tally['no change']) or 'none'}).",
        "Intervals are 95 % Wilson intervals of each success rate; where they overlap, the change is "
        "within what the number of evaluation episodes can tell apart.",
    ]
    table = "\n".join(lines) + "\n"
    (docs / "table.md").write_text(table)
    (docs / "results.json").write_text(json.dumps({"settings": settings, "command": command, "results": results}, indent=2) + "\n")
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", choices=sorted(PRESETS), default="cpu")
    parser.add_argument("--tasks", default=None, help="Comma-separated task ids or 'all' (default: cpu preset "
                        f"{','.join(CPU_TASKS)}; paper preset all 12).")
    parser.add_argument("--work", type=Path, default=Path("runs/reproduce"), help="Datasets, checkpoints, logs (resumable).")
    parser.add_argument("--docs", type=Path, default=ROOT / "docs" / "reproduction", help="Where the table, JSON and plot go.")
    for field in ("demos", "image_size", "steps", "batch_size", "eval_episodes"):
        parser.add_argument(f"--{field.replace('_', '-')}", type=int, default=None)
    parser.add_argument("--variants", default=None, help="Augmentation variants, as `pipette augment --variants`.")
    parser.add_argument("--device", default=None)
    args = parser.parse_args()
    preset = PRESETS[args.preset]
    overrides = {k: getattr(args, k) for k in ("demos", "image_size", "steps", "batch_size", "eval_episodes", "variants", "device")
                 if getattr(args, k) is not None}
    preset = replace(preset, **overrides)
    registry = load_registry([])
    if args.tasks is None:
        names = list(CPU_TASKS) if args.preset == "cpu" else registry.ids("paper-benchmark")
    elif args.tasks == "all":
        names = registry.ids("paper-benchmark")
    else:
        names = args.tasks.split(",")
    tasks = [registry.get(name) for name in names]
    command = "python benchmarks/reproduce_table.py " + " ".join(sys.argv[1:])
    started = time.perf_counter()
    results = []
    for task in tasks:
        results.append(run_task(task, preset, args.work))
        commit, dirty = git_state()
        settings = {"preset": args.preset, **asdict(preset), "git_commit": commit, "git_dirty": dirty,
                    "cpus": os.cpu_count(), "eval_seeds": [EVAL_SEED, EVAL_SEED + preset.eval_episodes - 1],
                    "wall_minutes_this_run": round((time.perf_counter() - started) / 60, 1),
                    "stage_minutes": round(sum(sum(r["seconds"].values()) for r in results) / 60, 1)}
        table = write_docs(results, settings, command, args.docs)  # after every task: a partial run still reports
    print(table)
    print(f"wrote {args.docs}/results.json and success.png")


if __name__ == "__main__":
    main()
