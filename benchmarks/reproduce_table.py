"""The paper's ACT experiment (table 2): raw vs success-verified augmented demonstrations.

For each task: 30 scripted demonstrations -> augmentation (re-simulated, re-rendered, kept only
when the task's evaluator accepts the replay) -> two LeRobot datasets (raw; augmented, which
holds the re-rendered originals plus the perturbed replays) -> one ACT policy per dataset ->
closed-loop evaluation of both on a frozen suite (registry/suites/): the same seeds for both, so
their outcomes pair. Every stage is the code behind the `pipette` commands (collect, augment,
convert, train, eval) and resumes where it stopped: run it again and finished stages are
reused, and an evaluation continues after its last finished episode.

Presets (each setting can be overridden by its flag):

  cpu    this machine's scale: suite pipette/CpuReproduction-v1 (4 tasks, 64 px, 50 episodes
         each), a small ACT, 300 steps of batch 8 (lr 1e-4), one torch thread and one dataloader
         worker (docs/training.md: "Training speed on a CPU").
  paper  the paper's settings (appendix D.1, table 6): suite pipette/PaperBenchmark-v1 (12 tasks,
         400 px, 75 episodes each), LeRobot's default ACT, 15000 steps of batch 32, on CUDA.

The suite sets the image size of every stage (demonstrations, training, evaluation). The table
(markdown: success with 95 % Wilson intervals, the change, McNemar's exact test on the paired
episodes, Holm-adjusted), its data (JSON, with the git commit and every setting) and a bar chart
with interval whiskers go to --docs; regressions are listed as plainly as gains, next to the
paper's ACT numbers for the same tasks.

    python benchmarks/reproduce_table.py --preset cpu --work runs/reproduce --docs docs/reproduction
    python benchmarks/reproduce_table.py --preset paper --work /data/reproduce --docs docs/reproduction_paper
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
from pipette_cli.demo import SMALL_ACT, SMALL_ACT_THREADS  # noqa: E402
from pipette_cli.demos.collect import collect  # noqa: E402
from pipette_cli.demos.provenance import git_state  # noqa: E402
from pipette_cli.demos.store import scan  # noqa: E402
from pipette_cli.evaluation import report  # noqa: E402
from pipette_cli.evaluation.runner import PolicySource, TaskRun, evaluate_runs  # noqa: E402
from pipette_cli.evaluation.settings import DecodeConfig, EvalSettings  # noqa: E402
from pipette_cli.evaluation.significance import ALPHA, Comparison  # noqa: E402
from pipette_cli.evaluation.suites import RegisteredSuite, episode_plan, load_suites  # noqa: E402
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert  # noqa: E402
from pipette_cli.lerobot.train import IfExists, Policy, TrainOptions, train_checkpoint  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.specs.task import TaskSpec  # noqa: E402


@dataclass(frozen=True)
class Preset:
    suite: str
    demos: int
    variants: str
    steps: int
    batch_size: int
    device: str
    act_flags: tuple[str, ...]
    threads: int | None
    """Torch threads of each training run (None: torch's, one per core)."""


PRESETS = {
    "cpu": Preset(
        suite="pipette/CpuReproduction-v1",
        demos=30,
        variants="original,light,speed,light+speed",
        steps=300,
        batch_size=8,
        device="cpu",
        act_flags=SMALL_ACT,
        threads=SMALL_ACT_THREADS,
    ),
    "paper": Preset(
        suite="pipette/PaperBenchmark-v1",
        demos=30,
        variants="original,paper",
        steps=15000,
        batch_size=32,
        device="cuda",
        act_flags=("--num_workers=4",),
        threads=None,
    ),
}
# The paper's ACT success rates (table 2), raw ("Unenh.") and augmented ("Enh."), in percent.
PAPER_ACT = {
    "pipette/PickUpTestTube-v1": (100, 100),
    "pipette/PipetteToPetriDish-v1": (81, 78),
    "pipette/RemovePetriDishFromIncubator-v1": (0, 9),
    "pipette/PlacePetriDishInIncubator-v1": (57, 90),
    "pipette/CloseCentrifugeLid-v1": (76, 84),
    "pipette/OpenCentrifugeLid-v1": (88, 100),
    "pipette/OpenWaterBathLid-v1": (70, 98),
    "pipette/CloseSpectrophotometerLid-v1": (83, 52),
    "pipette/PlaceTubeOnBalance-v1": (58, 3),
    "pipette/RemoveTubeFromBalance-v1": (40, 71),
    "pipette/PlacePipetteInRack-v1": (67, 5),
    "pipette/PlaceFlaskOnShaker-v1": (4, 18),
}
VERSIONS = (DatasetVersion.raw, DatasetVersion.augmented)


def say(message: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)


def run_task(task: TaskSpec, suite: RegisteredSuite, preset: Preset, work: Path, workers: int) -> dict[str, Any]:
    """All stages of one task under ``work/<task>``; returns its results and stage timings."""
    slug = task.id.replace("/", "_")
    folder = work / slug
    folder.mkdir(parents=True, exist_ok=True)
    image_size = suite.spec.image_size
    seconds: dict[str, float] = {}
    t = time.perf_counter()
    raw = folder / "raw.h5"
    collect(task, raw, episodes=preset.demos, seed=0, image_size=image_size, workers=workers)
    seconds["collect"] = time.perf_counter() - t
    demos = scan(raw).episodes
    say(f"{task.id}: {sum(r.summary.success for r in demos)}/{len(demos)} demonstrations succeeded")
    t = time.perf_counter()
    aug = folder / "aug.h5"
    spec = AugmentSpec(variants=make_variants(preset.variants.split(","), default_atoms()))
    result = augment(task, raw, aug, spec, workers=workers)
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
            convert(
                [inputs[version]],
                ConvertOptions(
                    repo_id=f"local/{slug}_{name}", root=root, video=False, dataset_version=version, overwrite=True
                ),
            )
        seconds[f"convert_{name}"] = time.perf_counter() - t
        frames = json.loads((root / "meta" / "info.json").read_text())
        t = time.perf_counter()
        options = TrainOptions(
            policy=Policy.act,
            dataset_version=version,
            steps=preset.steps,
            batch_size=preset.batch_size,
            device=preset.device,
            datasets_root=datasets,
            output_root=folder / "train",
            if_exists=IfExists.skip,
            offline=True,
            threads=preset.threads,
            extra=preset.act_flags,
        )
        checkpoint = train_checkpoint(
            task.id,
            options,
            on_train=lambda job, name=name, frames=frames: say(
                f"{task.id}: training ACT on {name} ({frames['total_episodes']} episodes, {frames['total_frames']} frames)"
            ),
        )
        seconds[f"train_{name}"] = time.perf_counter() - t
        t = time.perf_counter()
        run = TaskRun(task, folder / "eval" / name, tuple(episode_plan(suite.spec, [task.id])[task.id]))
        settings = EvalSettings(
            DecodeConfig.for_policy("act"), image_size, suite.spec.render_profile, name, suite.record()
        )
        evaluated = evaluate_runs(
            [run],
            PolicySource(checkpoint=checkpoint, device=preset.device),
            settings,
            workers=workers,
            on_start=lambda done, todo, name=name: say(
                f"{task.id}: evaluating ACT on {name}: {done} episodes logged, {todo} to go"
            ),
        )
        summary = evaluated.summaries[task.id]
        seconds[f"eval_{name}"] = time.perf_counter() - t
        say(f"{task.id}: ACT on {name}: {summary['successes']}/{summary['episodes']} successes")
        versions[name] = {
            "episodes": frames["total_episodes"],
            "frames": frames["total_frames"],
            "eval": str(run.folder),
        }
    timings = folder / "seconds.json"  # a resumed run skips finished stages: keep the time they took
    previous = json.loads(timings.read_text()) if timings.is_file() else {}
    seconds = {k: round(max(v, previous.get(k, 0.0)), 1) for k, v in seconds.items()}
    timings.write_text(json.dumps(seconds, indent=2))
    return {
        "task": task.id,
        "demos": len(demos),
        "demo_successes": sum(r.summary.success for r in demos),
        "augment_kept": kept,
        "augment_tried": tried,
        "versions": versions,
        "seconds": seconds,
    }


def verdict(comparison: Comparison | None, holm_p: float | None) -> str:
    if comparison is None or comparison.difference == 0:
        return "no change"
    direction = "gain" if comparison.difference > 0 else "regression"
    return f"{direction}, significant" if holm_p is not None and holm_p < ALPHA else f"{direction}, not significant"


def write_docs(
    results: list[dict[str, Any]], settings: dict[str, Any], command: str, docs: Path, pending: list[str]
) -> str:
    """``table.md``, ``results.json`` and ``success.png`` in ``docs``; returns the markdown table.

    ``pending`` are the suite's tasks without results yet: the table says that it leaves them out.
    """
    docs.mkdir(parents=True, exist_ok=True)
    table_report = report.build_report(
        report.load_runs([Path(v["eval"]) for r in results for v in r["versions"].values()])
    )
    report.bar_chart(table_report, docs / "success.png")
    lines = [
        "| task | demos (ok) | augmented kept / tried | raw episodes / frames | augmented episodes / frames "
        "| ACT raw (95 % CI) | ACT augmented (95 % CI) | change | McNemar exact p (Holm) | paper ACT raw -> augmented |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- | ---: |",
    ]
    tally: dict[str, list[str]] = {}
    for r in results:
        cells = {name: table_report.cells[r["task"], "act", name].summary for name in ("raw", "augmented")}
        comparison = table_report.comparisons.get((r["task"], "act"))
        holm_p = table_report.holm_p.get((r["task"], "act"))
        change = verdict(comparison, holm_p)
        tally.setdefault(change, []).append(r["task"].split("/")[-1])
        test = (
            f"{comparison.p_value:.3g} ({holm_p:.3g}); {comparison.only_a} vs {comparison.only_b} discordant"
            if comparison is not None and comparison.only_a is not None
            else "-"
        )
        paper = PAPER_ACT.get(r["task"])
        raw, aug = r["versions"]["raw"], r["versions"]["augmented"]
        lines.append(
            f"| {r['task']} | {r['demos']} ({r['demo_successes']}) | {r['augment_kept']} / {r['augment_tried']} "
            f"| {raw['episodes']} / {raw['frames']} | {aug['episodes']} / {aug['frames']} "
            f"| {report.cell_text(cells['raw'])} | {report.cell_text(cells['augmented'])} "
            f"| {change} ({100 * (comparison.difference if comparison else 0.0):+.0f} pt) | {test} "
            f"| {f'{paper[0]} -> {paper[1]}' if paper else '-'} |"
        )
        r["versions"]["raw"].update(_cell(cells["raw"]))
        r["versions"]["augmented"].update(_cell(cells["augmented"]))
        r["comparison"] = None if comparison is None else {**comparison.as_dict(), "p_holm": holm_p, "verdict": change}
    mean = {
        name: sum(r["versions"][name]["success_rate"] for r in results) / len(results) for name in ("raw", "augmented")
    }
    lines += [
        "",
        f"Mean success: raw {100 * mean['raw']:.1f} %, augmented {100 * mean['augmented']:.1f} %.",
        "; ".join(f"{change.capitalize()}: {', '.join(names)}" for change, names in sorted(tally.items())) + ".",
        "Cells: successes/episodes (rate, 95 % Wilson interval). Raw and augmented policies ran the same "
        f"episodes (suite {settings['suite']['id']}), so each difference is tested on the paired outcomes "
        "(McNemar's exact test: episodes one policy solved and the other did not); p-values in brackets are "
        f"Holm-adjusted over the {len(results)} tasks; significant means adjusted p < {ALPHA}.",
    ]
    if pending:
        lines.append(
            f"Not in this table: {', '.join(pending)} (of suite {settings['suite']['id']}); "
            "rerunning the command continues with them."
        )
    table = "\n".join(lines) + "\n"
    (docs / "table.md").write_text(table)
    data = {"settings": settings, "command": command, "results": results, "pending": pending}
    (docs / "results.json").write_text(json.dumps(data, indent=2) + "\n")
    return table


def _cell(summary: dict[str, Any]) -> dict[str, Any]:
    keys = ("successes", "success_rate", "success_ci95", "failures", "planned", "complete", "suite")
    return {"eval_episodes": summary["episodes"], **{k: summary[k] for k in keys}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", choices=sorted(PRESETS), default="cpu")
    parser.add_argument("--suite", default=None, help="Evaluation suite (default: the preset's); sets the image size.")
    parser.add_argument("--tasks", default=None, help="Comma-separated task ids of the suite (default: all of them).")
    parser.add_argument("--registry-dir", type=Path, action="append", default=[], help="Extra task/suite folder.")
    parser.add_argument(
        "--work", type=Path, default=Path("runs/reproduce"), help="Datasets, checkpoints, logs (resumable)."
    )
    parser.add_argument(
        "--docs", type=Path, default=ROOT / "docs" / "reproduction", help="Where the table, JSON and plot go."
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="Processes for collection, augmentation and evaluation.",
    )
    for field in ("demos", "steps", "batch_size", "threads"):
        parser.add_argument(f"--{field.replace('_', '-')}", type=int, default=None)
    parser.add_argument("--variants", default=None, help="Augmentation variants, as `pipette augment --variants`.")
    parser.add_argument("--device", default=None)
    args = parser.parse_args()
    preset = PRESETS[args.preset]
    overrides = {
        k: getattr(args, k)
        for k in ("suite", "demos", "steps", "batch_size", "threads", "variants", "device")
        if getattr(args, k) is not None
    }
    preset = replace(preset, **overrides)
    registry = load_registry(args.registry_dir)
    suite = load_suites(registry, args.registry_dir).get(preset.suite)
    names = [entry.task for entry in suite.spec.tasks] if args.tasks is None else args.tasks.split(",")
    tasks = [registry.get(name) for name in names]
    command = "python benchmarks/reproduce_table.py " + " ".join(sys.argv[1:])
    started = time.perf_counter()
    results = []
    for task in tasks:
        results.append(run_task(task, suite, preset, args.work, args.workers))
        commit, dirty = git_state()
        settings = {
            "preset": args.preset,
            **asdict(preset),
            "suite": suite.record(),
            "image_size": suite.spec.image_size,
            "workers": args.workers,
            "git_commit": commit,
            "git_dirty": dirty,
            "cpus": os.cpu_count(),
            "wall_minutes_this_run": round((time.perf_counter() - started) / 60, 1),
            "stage_minutes": round(sum(sum(r["seconds"].values()) for r in results) / 60, 1),
        }
        pending = [entry.task for entry in suite.spec.tasks if entry.task not in {r["task"] for r in results}]
        table = write_docs(
            results, settings, command, args.docs, pending
        )  # after every task: a partial run still reports
    print(table)
    print(f"wrote {args.docs}/table.md, results.json and success.png")


if __name__ == "__main__":
    main()
