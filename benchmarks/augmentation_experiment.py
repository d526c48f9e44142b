"""The augmentation experiment of docs/reproduction/plan.md: what verified augmentation buys ACT.

Stages (each resumes: rerun the same command after an interruption and finished work is reused):

  data    per task: the 30 demonstrations, the three augmented sets and the matching number of
          fresh demonstrations (what does not depend on training; `run` does it too).
  pilot   raw ACT on every candidate task of the nominal suite, checkpoints at 500-4000 steps,
          each evaluated on 30 demonstration-range seeds (1000-1029, never a suite seed); picks
          the training steps S and the tasks by the plan's rule; writes pilot.json.
  run     per task and data setting (raw, aug_all, aug_object, aug_visual, more_demos): data ->
          LeRobot dataset -> ACT for S steps -> evaluation on the nominal and the shifted suite
          (and the learning-curve checkpoints of raw and aug_all on the nominal suite).
  report  the tables of the plan's analysis: Wilson intervals, McNemar's exact test per task and
          pooled over tasks, Holm-adjusted; learning curves, failure modes, augmentation yield;
          results.json and table.md in --docs.
  diagnose  how much each trained policy's actions follow its images, on the first frames of the
          raw demonstrations (no suite seed): diagnosis.json in --docs (plan.md, point 6).
  contained  per task, whether a setting's data hold the replays of the setting it contains unchanged
          (amendment 14: aug_all_plus_drift holds aug_all's): contained.json beside the kept logs.
  hashes  per task, a hash of every dataset's arrays (all but wall time), the code that made them and
          the CPU: data_hashes.json beside the kept logs, to tell on another machine whether its
          datasets, or only its policies, differ (plan.md, amendments 7 and 8).

    python benchmarks/augmentation_experiment.py data --work runs/augmentation
    python benchmarks/augmentation_experiment.py pilot --work runs/augmentation
    python benchmarks/augmentation_experiment.py run --work runs/augmentation
    python benchmarks/augmentation_experiment.py report --work runs/augmentation

With ``--keep docs/reproduction/augmentation/episodes`` every finished evaluation's episode logs (with
the yield reports and training logs) are copied there as they come and restored at start, so a new
machine goes on from the first unfinished setting (plan amendment 7).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import multiprocessing
import os
import platform
import re
import shutil
import sys
import time
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from statistics import fmean
from typing import Any, TypeVar

import h5py
import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
ROOT = Path(__file__).resolve().parents[1]
if "MENAGERIE_ROOT" not in os.environ and (ROOT.parent / "shared" / "menagerie").is_dir():
    os.environ["MENAGERIE_ROOT"] = str(ROOT.parent / "shared" / "menagerie")

from pipette_cli.augment.objectcentric import hands_over  # noqa: E402
from pipette_cli.augment.run import augment  # noqa: E402
from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants  # noqa: E402
from pipette_cli.demo import SMALL_ACT, SMALL_ACT_THREADS  # noqa: E402
from pipette_cli.demos.collect import collect  # noqa: E402
from pipette_cli.demos.experts.base import expert_program  # noqa: E402
from pipette_cli.demos.provenance import describe_code, git_state, recorded_code  # noqa: E402
from pipette_cli.demos.store import DatasetStatus, EpisodeRef, read_episode, scan  # noqa: E402
from pipette_cli.evaluation.results import read_logs  # noqa: E402
from pipette_cli.evaluation.runner import PolicySource, TaskRun, evaluate_runs  # noqa: E402
from pipette_cli.evaluation.settings import DecodeConfig, EvalSettings  # noqa: E402
from pipette_cli.evaluation.significance import (  # noqa: E402
    ALPHA,
    compare,
    holm,
    smallest_significant,
    wilson_interval,
)
from pipette_cli.evaluation.suites import EpisodePlan, RegisteredSuite, adhoc_plan, episode_plan, load_suites  # noqa: E402
from pipette_cli.kernels import cpu_field, cpu_flags  # noqa: E402
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, convert  # noqa: E402
from pipette_cli.lerobot.train import IfExists, Policy, TrainOptions, train_checkpoint  # noqa: E402
from pipette_cli.registry import load_registry  # noqa: E402
from pipette_cli.specs.task import TaskSpec  # noqa: E402

NOMINAL, SHIFTED = "pipette/AugmentationNominal-v1", "pipette/AugmentationShifted-v1"
CLUTTER = "pipette/AugmentationClutter-v1"
"""Amendment 1 (plan.md): the nominal episodes with two distractors on the bench."""
DEMOS = 30
ATOMS = {  # the shifted suite's parameters: the augmentation covers what that evaluation varies
    "object": {"task_range": 1.5},
    "light": {"scale": 0.9, "jitter": 0.4},
    "cam": {"camera": "all", "radius": 0.05, "wrist_radius": 0.002},
    "table": {"blend": 0.5},
    "clutter": {"count": 2},
}
VARIANTS = {
    "aug_all": "original,object+light+cam+table*5",
    "aug_object": "original,object*5",
    "aug_visual": "original,light+cam+table*5",
    "aug_clutter": "original,clutter*5",
}
VARIANTS |= {"aug_all_seg": VARIANTS["aug_all"], "aug_object_seg": VARIANTS["aug_object"]}
"""Amendment 5: the same variants built by the segmented retargeting (the code after 2740d3a)."""
VARIANTS["aug_all_dart"] = "original,object+light+cam+table+noise*5"
VARIANTS["aug_all_drift"] = VARIANTS["aug_all_dart"]
VARIANTS["aug_all_plus_drift"] = VARIANTS["aug_all"] + ",light+cam+table+noise*5"
DRIFT = {"sigma": 0.01, "bound": 0.03, "window": 15, "corrective": True}
SETTING_ATOMS: dict[str, dict[str, dict[str, Any]]] = {
    "aug_all_dart": {"noise": {"corrective": True}},
    "aug_all_drift": {"noise": DRIFT},
    "aug_all_plus_drift": {"noise": DRIFT},
}
"""Amendment 10: aug_all's variants with corrective joint noise (``pipette augment``'s sigma and bound),
whose episodes record the demonstrated targets while the noisy ones run. Amendment 12: the same with the
noise drifting over 15 steps at sigma 0.01 rad (the hand about 9 mm off the path on average, not 2).
Amendment 14: aug_all's variants as they are (the same names, so the same draws) followed by five of the
drift without moving the objects."""
CORRECTIVE = tuple(SETTING_ATOMS)
"""The settings with corrective joint noise (amendments 10, 12 and 14), each at S."""
CONTAINS = {"aug_all_plus_drift": "aug_all"}
"""Amendment 14: a setting whose data hold another's replays, which :func:`contained` checks."""
SETTINGS = ("raw", "aug_all", "aug_object", "aug_visual", "more_demos", "aug_clutter")
SEGMENTED = ("aug_all_seg", "aug_object_seg")
"""Amendment 5's settings, run after the main run (``--settings aug_all_seg,aug_object_seg``) for the
tasks whose skill program hands the held object over to another object (:func:`segmented`)."""
EPOCH_MATCHED = {
    "aug_all_ep": "aug_all",
    "more_demos_ep": "more_demos",
    "aug_all_dart_ep": "aug_all_dart",
    "aug_all_drift_ep": "aug_all_drift",
}
"""Amendment 6: the data of the setting named, trained for as many passes over it as ``raw`` gets in
S steps (:func:`matched_steps`)."""
REPLICATE_SEEDS = (1001, 1002)
REPLICATED = {"amendment 8": "aug_all", "amendment 16": "aug_all_plus_drift"}
"""The settings trained again with other training seeds, each read against raw's replicates."""
REPLICATES = {f"{s}_seed{seed}": (s, seed) for seed in REPLICATE_SEEDS for s in ("raw", *REPLICATED.values())}
"""Amendment 8: the primary comparison's settings trained again with other training seeds on the same
data, evaluated on the nominal and shifted suites; run after the registered cells (``--settings``).
Amendment 16: aug_all_plus_drift's, the same way (RemoveTubeFromBalance)."""
SUITE_SETTINGS = {
    "nominal": (*SETTINGS[:5], *SEGMENTED, *EPOCH_MATCHED, *REPLICATES, *CORRECTIVE),
    "shifted": (*SETTINGS[:5], *SEGMENTED, *EPOCH_MATCHED, *REPLICATES, *CORRECTIVE),
    "clutter": (
        "raw",
        "aug_all",
        "aug_clutter",
        "aug_all_seg",
        "aug_all_ep",
        "aug_all_dart",
        "aug_all_dart_ep",
        "aug_all_drift",
        "aug_all_drift_ep",
        "aug_all_plus_drift",
    ),
}
"""The settings evaluated on each suite (aug_clutter and the clutter suite: amendment 1; the
segmented ones: amendment 5; the epoch-matched ones: amendment 6; the replicates: amendment 8;
the corrective ones: amendments 10, 12 and 14)."""
PRIMARY = [("raw", "aug_all")]
AMENDMENT_1 = [("raw", "aug_clutter"), ("raw", "aug_all"), ("aug_all", "aug_clutter")]
AMENDMENT_5 = [("aug_all", "aug_all_seg"), ("raw", "aug_all_seg")]
"""On every suite; and on the shifted suite ``aug_object_seg`` vs ``aug_object``."""
AMENDMENT_6 = [("raw", "aug_all_ep"), ("aug_all", "aug_all_ep"), ("more_demos_ep", "aug_all_ep")]
"""On every suite (the clutter suite has no ``more_demos_ep``: that pair is left out there)."""
AMENDMENT_10 = [
    ("aug_all", "aug_all_dart"),
    ("raw", "aug_all_dart"),
    ("aug_all_ep", "aug_all_dart_ep"),
    ("raw", "aug_all_dart_ep"),
]
"""On every suite: the change itself and against raw; at matched passes against amendment 6's cell."""
AMENDMENT_12 = [
    ("aug_all_dart", "aug_all_drift"),
    ("aug_all", "aug_all_drift"),
    ("raw", "aug_all_drift"),
    ("aug_all_ep", "aug_all_drift_ep"),
    ("raw", "aug_all_drift_ep"),
]
"""On every suite: the drift against amendment 10's noise, against aug_all and raw; at matched passes."""
AMENDMENT_14 = [
    ("aug_all", "aug_all_plus_drift"),
    ("aug_all_drift", "aug_all_plus_drift"),
    ("raw", "aug_all_plus_drift"),
]
"""On every suite: what the added drift buys, drift beside rather than on the moved objects, and against raw."""
SECONDARY = [
    ("raw", "aug_object"),
    ("raw", "aug_visual"),
    ("aug_object", "aug_all"),
    ("aug_visual", "aug_all"),
    ("more_demos", "aug_all"),
]
PILOT_STEPS = (500, 1000, 2000, 4000)
PILOT_SEED, PILOT_EPISODES = 1000, 30
BAND = (0.15, 0.85)
HINGES = {"pipette/CloseCentrifugeLid-v1", "pipette/CloseSpectrophotometerLid-v1", "pipette/OpenCentrifugeLid-v1"}
"""The candidates whose success is a hinge angle (OpenCentrifugeLid: amendment 2)."""
PLACEMENTS = {"pipette/PlaceTubeOnBalance-v1"}
FAULTS = {
    "pipette/CloseCentrifugeLid-v1": "as run (the code of 8739549), the Panda's wrist starts inside the open lid "
    "on 45 of the 50 suite seeds (up to 69 mm) and shoves it about 10 degrees in the first steps (amendment 4); "
    "every setting faces the same episodes; not comparable with the fixed task (the centrifuge at 0.65 m)",
}
"""Faults of a task as the experiment runs it, found after the plan was frozen: the report states them."""
BATCH, TRAIN_SEED = 8, 1000
T = TypeVar("T")


def say(message: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)


@dataclass(frozen=True)
class Experiment:
    work: Path
    workers: int
    image_size: int
    render_profile: str
    demos: int = DEMOS
    pilot_steps: tuple[int, ...] = PILOT_STEPS
    pilot_episodes: int = PILOT_EPISODES
    max_episodes: int | None = None
    """Smoke runs only: at most this many episodes per evaluation (results.json records it)."""
    jobs: int = 1
    """Tasks run at once, each in its own process (training uses one thread per run)."""
    fewer: tuple[tuple[str, int], ...] = ()
    """Tasks that use fewer demonstrations than ``demos`` (the pilot's step 4), with their count."""
    keep: Path | None = None
    """Where what the report reads is copied as it finishes (plan amendment 7): every evaluation's
    episode logs, the yield reports and lerobot-train's logs, by their path under ``work``. A new
    machine restores them into ``work`` and goes on from the first unfinished setting."""

    def demos_of(self, task: TaskSpec) -> int:
        return dict(self.fewer).get(task.id, self.demos)

    def folder(self, task: TaskSpec, *parts: str) -> Path:
        """``<work>/<task>`` (``<task>@<n>demos`` for a task with fewer demonstrations) / parts."""
        count = self.demos_of(task)
        path = self.work / (task.id.replace("/", "_") + ("" if count == self.demos else f"@{count}demos"))
        for part in parts:
            path = path / part
        return path


PROGRESS_BAR = re.compile(r"Training:\s*\d+%\|[^|\r\n]*\|[^\]\r\n]*\]")
"""One redraw of lerobot-train's progress bar (about 95 % of a log's bytes; no number the report reads)."""


def without_progress_bar(log: str) -> str:
    """lerobot-train's log as kept: its progress-bar redraws and blank lines dropped, every other line
    (the command, the loss lines) as written."""
    lines = PROGRESS_BAR.sub("", log).replace("\r", "\n").split("\n")
    return "".join(line + "\n" for line in lines if line.strip())


def kept(ex: Experiment, *paths: Path) -> None:
    """Copy ``paths`` (files, or folders' files) under ``ex.work`` to the same place under ``ex.keep``
    (training logs without their progress bar)."""
    if ex.keep is None:
        return
    for path in paths:
        for file in [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file()):
            into = ex.keep / file.relative_to(ex.work)
            into.parent.mkdir(parents=True, exist_ok=True)
            if file.suffix == ".log":
                into.write_text(without_progress_bar(file.read_text(errors="replace")))
            else:
                shutil.copy2(file, into)


def restore(ex: Experiment) -> int:
    """Copy into ``ex.work`` every kept file it lacks, training logs aside (a training run on this
    machine writes its own; :func:`training_loss` reads the kept one where there is none); the number
    copied."""
    copied = 0
    for file in sorted(p for p in ex.keep.rglob("*") if p.is_file()) if ex.keep and ex.keep.is_dir() else []:
        into = ex.work / file.relative_to(ex.keep)
        if file.suffix != ".log" and not into.exists():
            into.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(file, into)
            copied += 1
    return copied


def each_task(ex: Experiment, work: Callable[..., T], tasks: list[TaskSpec], *args: Any) -> list[T]:
    """``work(ex, task, *args)`` for every task, ``ex.jobs`` tasks at once (spawned processes)."""
    if ex.jobs <= 1 or len(tasks) <= 1:
        return [work(ex, task, *args) for task in tasks]
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(min(ex.jobs, len(tasks)), mp_context=context) as pool:
        return list(pool.map(work, *zip(*[(ex, task, *args) for task in tasks], strict=True)))


def demonstrations(ex: Experiment, task: TaskSpec, count: int, name: str) -> Path:
    path = ex.folder(task, f"{name}.h5")
    path.parent.mkdir(parents=True, exist_ok=True)
    collect(task, path, episodes=count, seed=0, image_size=ex.image_size, workers=ex.workers)
    return path


def augmented(ex: Experiment, task: TaskSpec, raw: Path, setting: str) -> tuple[Path, dict[str, Any]]:
    out = ex.folder(task, f"{setting}.h5")
    atoms = default_atoms(**(ATOMS | SETTING_ATOMS.get(setting, {})))
    spec = AugmentSpec(variants=make_variants(VARIANTS[setting].split(","), atoms))
    result = augment(task, raw, out, spec, rejected=ex.folder(task, f"{setting}_rejected.h5"), workers=ex.workers)
    say(f"{task.id} {setting}: augmentation kept {result.report['kept']}/{result.report['attempts']}")
    return out, result.report


def data_of(setting: str) -> str:
    """The data setting whose demonstrations ``setting`` trains on (amendments 6 and 8)."""
    return EPOCH_MATCHED.get(setting) or REPLICATES.get(setting, (setting, TRAIN_SEED))[0]


def trained(
    ex: Experiment, task: TaskSpec, setting: str, source: Path, steps: int, save_freq: int, folder: str = "train"
) -> Path:
    """The run folder of ACT trained ``steps`` steps on ``source`` (checkpoints every ``save_freq``),
    under ``<task>/<setting>/<folder>`` (an epoch-matched setting reads its data setting's dataset)."""
    data_setting = data_of(setting)
    seed = REPLICATES.get(setting, (setting, TRAIN_SEED))[1]
    version = DatasetVersion.raw if data_setting in ("raw", "more_demos") else DatasetVersion.augmented
    datasets = ex.folder(task, data_setting, "datasets")
    slug = task.id.replace("/", "_")
    root = datasets / slug / version.value
    if not (root / "meta" / "info.json").is_file():
        convert(
            [source],
            ConvertOptions(
                repo_id=f"local/{slug}_{data_setting}", root=root, video=False, dataset_version=version, overwrite=True
            ),
        )
    # SMALL_ACT names the registered seed; a replicate's seed replaces it (one --seed on the command line)
    flags = SMALL_ACT if seed == TRAIN_SEED else tuple(f for f in SMALL_ACT if not f.startswith("--seed="))
    options = TrainOptions(
        policy=Policy.act,
        dataset_version=version,
        steps=steps,
        batch_size=BATCH,
        device="cpu",
        datasets_root=datasets,
        output_root=ex.folder(task, setting, folder),
        if_exists=IfExists.skip,
        offline=True,
        threads=SMALL_ACT_THREADS,
        extra=(*flags, f"--save_freq={save_freq}", f"--seed={seed}"),
    )
    last = train_checkpoint(task.id, options, on_train=lambda job: say(f"{task.id} {setting}: training {steps} steps"))
    run = last.parents[2]  # <run>/checkpoints/last/pretrained_model -> <run>
    kept(ex, *run.parent.glob("*.log"))
    return run


def checkpoint(run: Path, step: int, total: int) -> Path:
    digits = max(6, len(str(total)))
    path = run / "checkpoints" / f"{step:0{digits}d}" / "pretrained_model"
    if not (path / "config.json").is_file():
        raise SystemExit(f"{run}: no checkpoint at step {step}")
    return path


def evaluated(
    ex: Experiment,
    task: TaskSpec,
    policy: Path,
    label: str,
    folder: Path,
    episodes: list[EpisodePlan],
    suite: RegisteredSuite | None,
) -> dict[str, Any]:
    settings = EvalSettings(
        DecodeConfig.for_policy("act"),
        ex.image_size,
        ex.render_profile,
        label,
        None if suite is None else suite.record(),
    )
    episodes = episodes[: ex.max_episodes] if ex.max_episodes else episodes
    done = evaluate_runs(
        [TaskRun(task, folder, tuple(episodes))], PolicySource(checkpoint=policy), settings, workers=ex.workers
    )
    summary = done.summaries[task.id]
    kept(ex, folder)
    say(f"{task.id} {label} -> {folder.name}: {summary['successes']}/{summary['episodes']}")
    return summary


# ------------------------------------------------------------------------------------------- pilot
def pilot_rates(ex: Experiment, task: TaskSpec) -> dict[int, float]:
    """Raw ACT's success on the pilot seeds at each pilot step count (one run, its checkpoints)."""
    raw = demonstrations(ex, task, ex.demos_of(task), "raw")
    run = trained(ex, task, "raw", raw, max(ex.pilot_steps), min(ex.pilot_steps))
    plan = adhoc_plan(task, ex.pilot_episodes, PILOT_SEED)
    rates = {}
    for steps in ex.pilot_steps:
        policy = checkpoint(run, steps, max(ex.pilot_steps))
        summary = evaluated(ex, task, policy, f"raw@{steps}", ex.folder(task, "pilot", str(steps)), plan, None)
        rates[steps] = summary["successes"] / summary["episodes"]
    return rates


def pilot(ex: Experiment, tasks: list[TaskSpec], docs: Path) -> dict[str, Any]:
    """The plan's pilot, steps 1-4: if no step count meets the rule, the tasks above the band at
    the chosen count are piloted again with half the demonstrations (their first ones), which
    then become their ``raw`` for every setting, and the rule is applied again; where still no
    hinge is in the band, the fallback of amendments 2 and 3 (:func:`with_a_hinge`)."""
    rates = dict(zip([t.id for t in tasks], each_task(ex, pilot_rates, tasks), strict=True))
    choice = choose(rates, ex.pilot_steps)
    first = {"success": dict(rates), **choice}
    above = [t for t in tasks if rates[t.id][choice["steps"]] > BAND[1]] if not choice["rule_met"] else []
    fewer = replace(ex, fewer=tuple((t.id, ex.demos // 2) for t in above))
    for task in above:
        say(f"pilot: {task.id} above the band at {choice['steps']} steps: again with {ex.demos // 2} demonstrations")
    rates.update(zip([t.id for t in above], each_task(fewer, pilot_rates, above), strict=True))
    if above:
        choice = choose(rates, ex.pilot_steps)
    choice = with_a_hinge(rates, choice, ex.pilot_steps)
    data = {
        "seeds": [PILOT_SEED, PILOT_SEED + ex.pilot_episodes - 1],
        "demos": ex.demos,
        "demos_per_task": {t.id: fewer.demos_of(t) for t in tasks},
        "success": rates,
        **choice,
        **({"first_pass": first} if above else {}),
    }
    docs.mkdir(parents=True, exist_ok=True)
    (docs / "pilot.json").write_text(json.dumps(data, indent=2) + "\n")
    say(f"pilot: S = {choice['steps']}, tasks {choice['tasks']}")
    return data


def choose(rates: dict[str, dict[int, float]], counts: tuple[int, ...] = PILOT_STEPS) -> dict[str, Any]:
    """The plan's rule: the smallest step count with >= 4 tasks in the band, a hinge and a placement
    among them; else the count with the most tasks in the band (ties: fewer steps)."""

    def band(steps: int) -> list[str]:
        return [t for t, r in rates.items() if BAND[0] <= r[steps] <= BAND[1]]

    def ok(tasks: list[str]) -> bool:
        return len(tasks) >= 4 and bool(HINGES & set(tasks)) and bool(PLACEMENTS & set(tasks))

    steps = next((s for s in counts if ok(band(s))), None)
    if steps is None:
        steps = max(counts, key=lambda s: (len(band(s)), -s))
    tasks = band(steps)
    return {"steps": steps, "tasks": tasks, "rule_met": ok(tasks)}


def with_a_hinge(
    rates: dict[str, dict[int, float]], choice: dict[str, Any], counts: tuple[int, ...] = PILOT_STEPS
) -> dict[str, Any]:
    """Amendment 2's fallback as amendment 3 resolves it: where the rule is not met and no hinge is
    in the band at S, the candidates below the band at the largest count are dropped first (step 4),
    then the kept hinge with the lowest pilot success at S joins the tasks (ties: the lowest success
    summed over the counts, then the id), marked ``ceiling``."""
    if choice["rule_met"] or HINGES & set(choice["tasks"]):
        return choice
    steps = choice["steps"]
    kept = [t for t in sorted(HINGES & set(rates)) if rates[t][max(counts)] >= BAND[0]]
    if not kept:
        return choice
    hinge = min(kept, key=lambda t: (rates[t][steps], sum(rates[t][c] for c in counts), t))
    return {**choice, "tasks": [*choice["tasks"], hinge], "ceiling": [hinge]}


# --------------------------------------------------------------------------------------------- run
def data(ex: Experiment, task: TaskSpec, settings: list[str]) -> dict[str, Path]:
    """The demonstration file of each setting (recorded or augmented here unless done before);
    each augmentation's yield report goes to ``yield.json``."""
    raw = demonstrations(ex, task, ex.demos_of(task), "raw")
    sources: dict[str, Path] = {"raw": raw}
    path = ex.folder(task, "yield.json")
    reports: dict[str, Any] = json.loads(path.read_text()) if path.is_file() else {}
    for setting in VARIANTS:
        if setting in settings or (setting == "aug_all" and "more_demos" in settings):
            sources[setting], reports[setting] = augmented(ex, task, raw, setting)
    path.write_text(json.dumps(reports, indent=2) + "\n")
    kept(ex, path)
    if "more_demos" in settings:
        sources["more_demos"] = demonstrations(ex, task, len(scan(sources["aug_all"]).episodes), "more_demos")
    return sources


def variant_kind(name: str) -> str:
    """A variant's name without its draw: ``object+light@3`` -> ``object+light``."""
    return name.partition("@")[0]


def yield_by_kind(report: dict[str, Any]) -> dict[str, tuple[int, int]]:
    """(kept, tried) of an augmentation's yield report per kind of variant (:func:`variant_kind`)."""
    found: dict[str, tuple[int, int]] = {}
    for row in report["variants"]:
        kept, tried = found.get(variant_kind(row["variant"]), (0, 0))
        found[variant_kind(row["variant"])] = (kept + row["kept"], tried + row["attempts"])
    return found


def contained(ex: Experiment, task: TaskSpec, outer: str) -> dict[str, Any]:
    """Whether ``outer``'s data hold the setting it contains (:data:`CONTAINS`) unchanged: per variant of
    the inner setting, the same kept count and failures in both yield reports; and, where the inner file
    is on this machine, every kept inner episode found in ``outer`` (same demonstration seed and variant)
    with every array (wall time aside) and image equal byte for byte."""
    inner = CONTAINS[outer]
    reports = json.loads(ex.folder(task, "yield.json").read_text())
    rows = {s: {r["variant"]: (r["kept"], r["failures"]) for r in reports[s]["variants"]} for s in (inner, outer)}
    found: dict[str, Any] = {
        "inner": inner,
        "same_yield": all(rows[outer].get(v) == row for v, row in rows[inner].items()),
    }
    if not ex.folder(task, f"{inner}.h5").is_file():
        return found | {"episodes": None}

    def episodes(setting: str) -> dict[tuple[int, str], EpisodeRef]:
        refs = scan(ex.folder(task, f"{setting}.h5")).episodes
        return {(r.summary.seed, str(read_episode(r).attrs["augment_variant"])): r for r in refs}

    def same(a: np.ndarray, b: np.ndarray) -> bool:  # strings (object arrays) by value, numbers by bytes
        return (
            a.dtype == b.dtype
            and a.shape == b.shape
            and (a.tolist() if a.dtype == object else a.tobytes()) == (b.tolist() if b.dtype == object else b.tobytes())
        )

    def equal(x: Any, y: Any) -> bool:  # wall time is when it ran, not what
        return x.keys() == y.keys() and all(same(x[k], y[k]) for k in x if k != "wall_time")

    theirs, ours = episodes(inner), episodes(outer)
    identical = 0
    for key, ref in theirs.items():
        if key in ours:
            a, b = read_episode(ref, images=True), read_episode(ours[key], images=True)
            identical += equal(a.arrays, b.arrays) and equal(a.images, b.images)
    return found | {"episodes": len(theirs), "identical": identical}


def yield_by_kind_lines(found: dict[str, dict[str, Any]], tasks: list[TaskSpec]) -> list[str]:
    """The yield table's line per kind of variant, for each setting that mixes kinds (amendment 14)."""
    lines = []
    for t in tasks:
        for setting, report in found.get(t.id, {}).items():
            kinds = {k: v for k, v in yield_by_kind(report).items() if k != "original"}
            if len(kinds) > 1:
                lines += [f"| {t.id} {setting}: {kind} | {kept}/{tried} |" for kind, (kept, tried) in kinds.items()]
    return (
        [
            "",
            "By kind of variant, where a setting mixes them:",
            "",
            "| task, setting: variants | kept / tried |",
            "|---|---|",
            *lines,
        ]
        if lines
        else []
    )


def frames_of(ex: Experiment, task: TaskSpec, setting: str) -> int:
    """Control steps (frames) in a setting's demonstration file."""
    return sum(ref.summary.num_steps for ref in scan(ex.folder(task, f"{setting}.h5")).episodes)


def matched_steps(ex: Experiment, task: TaskSpec, setting: str, steps: int, unit: int = 500) -> int:
    """Training steps that give ``setting``'s data as many passes as ``raw``'s get in ``steps``: ``steps``
    times the ratio of their control steps (frames), rounded up to ``unit`` (amendment 6)."""
    frames = [frames_of(ex, task, s) for s in (setting, "raw")]
    return max(steps, -(-steps * frames[0] // (frames[1] * unit)) * unit)


MATCHED_ABOVE = {"aug_all_dart_ep": 1.5, "aug_all_drift_ep": 1.5}
"""Amendment 10: a matched-passes setting trained only where its data hold more than this many times
raw's frames (below it, the S-step setting is already close to matched)."""


def segmented(task: TaskSpec) -> bool:
    """Whether the task's program takes its first target to another object's site, where the
    segmented retargeting differs from one segment (amendment 5)."""
    return bool(task.targets) and hands_over(expert_program(task)[0], task.targets[0])


Evaluation = tuple[str, Path, int | None, list[EpisodePlan], RegisteredSuite]
"""(label, folder, checkpoint step or None for the setting's last, episodes, suite)."""


def evaluations(
    ex: Experiment, task: TaskSpec, setting: str, steps: int, suites: dict[str, RegisteredSuite]
) -> list[Evaluation]:
    """What ``setting`` is evaluated on: each suite that evaluates it and, for raw and aug_all, the
    learning-curve points S/4 and S/2 on the nominal suite."""
    out: list[Evaluation] = []
    for name, suite in suites.items():
        if setting in SUITE_SETTINGS[name]:
            plan = episode_plan(suite.spec, [task.id])[task.id]
            out.append((setting, ex.folder(task, "eval", name, setting), None, plan, suite))
    if setting in ("raw", "aug_all"):
        plan = episode_plan(suites["nominal"].spec, [task.id])[task.id]
        for step in sorted({steps // 4, steps // 2} - {0}):
            label = f"{setting}@{step}"
            out.append((label, ex.folder(task, "eval", "curve", label), step, plan, suites["nominal"]))
    return out


def finished(ex: Experiment, folder: Path, plan: list[EpisodePlan]) -> bool:
    """Whether ``folder`` holds a log for every planned episode (restored ones included)."""
    count = min(len(plan), ex.max_episodes or len(plan))
    return folder.is_dir() and len(list(folder.glob("episode_*.json"))) >= count


def run_task(
    ex: Experiment, task: TaskSpec, steps: int, suites: dict[str, RegisteredSuite], settings: list[str]
) -> None:
    if not segmented(task):
        settings = [s for s in settings if s not in SEGMENTED]
    pending = []
    for setting in settings:
        if all(finished(ex, f, plan) for _, f, _, plan, _ in evaluations(ex, task, setting, steps, suites)):
            say(f"{task.id} {setting}: every evaluation finished before (kept episode logs)")
        else:
            pending.append(setting)
    if not pending:
        return
    quarter = max(1, steps // 4)
    every = min(ex.pilot_steps)
    for setting in pending:  # each setting's data just before it trains: a lost machine loses one setting
        base = data_of(setting)
        source = data(ex, task, [base])[base]
        pilot_run = ex.folder(task, setting, "train")
        if setting == "raw" and quarter % every == 0 and any(pilot_run.glob(f"act/*/checkpoints/{steps:06d}")):
            # the pilot's run: without a learning-rate schedule (ACT has none) and with the same
            # seed, its checkpoints at S/4, S/2 and S are those of an S-step run
            total = max(ex.pilot_steps)
            run = trained(ex, task, setting, source, total, every)
        elif setting in EPOCH_MATCHED:
            ratio = frames_of(ex, task, base) / frames_of(ex, task, "raw")
            if ratio <= MATCHED_ABOVE.get(setting, 0.0):
                say(f"{task.id} {setting}: {base} holds {ratio:.2f} x raw's frames, not above {MATCHED_ABOVE[setting]}")
                continue
            total = matched_steps(ex, task, EPOCH_MATCHED[setting], steps)
            run = trained(ex, task, setting, source, total, total // 4)
        else:  # a new machine has no pilot run: raw's own S-step run (amendment 7)
            folder = "train" if setting != "raw" else f"train_{steps}"
            total = steps
            run = trained(ex, task, setting, source, total, quarter, folder)
        last = total if setting in EPOCH_MATCHED else steps
        for label, into, step, plan, suite in evaluations(ex, task, setting, steps, suites):
            if finished(ex, into, plan):  # kept from a policy trained before, maybe another realization (amendment 11)
                say(f"{task.id} {label} -> {into.parent.name}: finished before (kept episode logs)")
                continue
            evaluated(ex, task, checkpoint(run, step or last, total), label, into, plan, suite)


# --------------------------------------------------------------------------------------- diagnose
RELIANCE_DEMOS = 12


def final_checkpoint(ex: Experiment, task: TaskSpec, setting: str, steps: int) -> Path | None:
    """The setting's policy at ``steps`` (the raw one may sit in the pilot's longer run)."""
    found = sorted(ex.folder(task, setting).glob(f"train*/act/*/checkpoints/{steps:06d}/pretrained_model"))
    return found[0] if found else None


def image_reliance(ex: Experiment, task: TaskSpec, policy: Path) -> dict[str, float]:
    """How much a policy's actions follow its images: the spread (mean over the arm joints of the
    std across episodes) of the joint targets at the end of the chunk it predicts from the first
    frames of the first :data:`RELIANCE_DEMOS` raw demonstrations (demonstration seeds,
    each with the object elsewhere), beside the spread the demonstrations themselves have there. A
    policy that ignores its images predicts one trajectory for every start (ratio near 0)."""
    from pipette_cli.serving.server import LeRobotRunner  # deferred: torch, lerobot

    runner = LeRobotRunner(policy, device="cpu")
    predicted, recorded = [], []
    for ref in scan(ex.folder(task, "raw.h5")).episodes[:RELIANCE_DEMOS]:
        episode = read_episode(ref, images=True)
        obs = {
            f"observation.images.{c}": np.ascontiguousarray(v[0].transpose(2, 0, 1)) for c, v in episode.images.items()
        }
        obs["observation.state"] = episode.arrays["state"][0].astype(np.float32)
        runner.reset()
        chunk = runner.act(obs, task.instruction, chunk=True)
        step = min(len(chunk), len(episode.arrays["action"])) - 1
        predicted.append(chunk[step, :-1])
        recorded.append(episode.arrays["action"][step, :-1])
    spread, demos = float(np.std(predicted, axis=0).mean()), float(np.std(recorded, axis=0).mean())
    return {"predicted_spread": round(spread, 4), "recorded_spread": round(demos, 4), "ratio": round(spread / demos, 3)}


EXCURSIONS = {"aug_all_dart": "corrective noise", "aug_all_drift": "corrective drift"}
"""The settings whose joint noise :func:`noise_excursion` measures, by the name the diagnosis gives it."""


def noise_excursion(ex: Experiment, task: TaskSpec, setting: str = "aug_all_dart", demos: int = 8) -> dict[str, float]:
    """How far a setting's corrective joint noise (amendments 10 and 12) takes the arm off the demonstrated
    path: the first ``demos`` raw demonstrations run again with that noise (no other perturbation), the arm
    joints' and the TCP's deviation from the recorded ones (mean over steps, and the largest), and how many
    still succeed."""
    from pipette_cli.augment.perturb import plan_variant
    from pipette_cli.augment.simulate import Rollout, settle_steps, simulate
    from pipette_cli.augment.specs import VariantSpec
    from pipette_cli.sim.world import World
    from pipette_cli.specs.perturbations import JointNoiseSpec

    noise = JointNoiseSpec(**SETTING_ATOMS[setting]["noise"])
    world = World(task)
    means: list[float] = []
    peaks: list[float] = []
    hand: list[float] = []
    hand_peaks: list[float] = []
    kept = 0
    refs = scan(ex.folder(task, "raw.h5")).episodes[:demos]
    for ref in refs:
        demo = Rollout.from_record(read_episode(ref))
        plan = plan_variant(
            VariantSpec(name="noise", perturbations=[noise]), demo.actions, seed=0, demo_seed=ref.summary.seed
        )
        executed = plan.executed()
        assert executed is not None
        run = simulate(world, ref.summary.seed, demo.states[0], executed, settle_steps=settle_steps(world, 1.0))
        n = min(run.num_steps, demo.num_steps)
        arm = np.abs(run.obs_state[:n, : world.robot.arm_dof] - demo.obs_state[:n, : world.robot.arm_dof])
        means.append(float(arm.mean()))
        peaks.append(float(arm.max()))
        gaps = np.linalg.norm(tcp_path(world, run.states[:n]) - tcp_path(world, demo.states[:n]), axis=1)
        hand.append(float(gaps.mean()))
        hand_peaks.append(float(gaps.max()))
        kept += bool(run.verdict.success)
    return {
        "demos": len(refs),
        "sigma": noise.sigma,
        "window": noise.window,
        "mean_joint_deviation_rad": round(float(np.mean(means)), 5),
        "largest_joint_deviation_rad": round(max(peaks), 4),
        "mean_tcp_deviation_mm": round(1000 * float(np.mean(hand)), 2),
        "largest_tcp_deviation_mm": round(1000 * max(hand_peaks), 2),
        "still_succeed": kept,
    }


def tcp_path(world: Any, states: np.ndarray) -> np.ndarray:
    """The tool centre point's position at each recorded simulator state."""
    import mujoco

    from pipette_cli.demos.recorder import SIM_STATE

    path = []
    for state in states:
        mujoco.mj_setState(world.model, world.data, state, SIM_STATE)
        mujoco.mj_kinematics(world.model, world.data)
        path.append(world.tcp_position())
    return np.array(path)


def diagnose(ex: Experiment, tasks: list[TaskSpec], docs: Path, steps: int) -> str:
    """diagnosis.json in ``docs``: :func:`image_reliance` of every trained setting (no suite seed), and
    :func:`noise_excursion` of each task with raw demonstrations (``<task> corrective noise``)."""
    found: dict[str, dict[str, Any]] = {}
    for task in tasks:
        for setting in (*SETTINGS, *SEGMENTED, *EPOCH_MATCHED, *CORRECTIVE):
            base = EPOCH_MATCHED.get(setting)
            if base is not None and not ex.folder(task, f"{base}.h5").is_file():
                continue
            at = steps if base is None else matched_steps(ex, task, base, steps)
            policy = final_checkpoint(ex, task, setting, at)
            if policy is not None:
                found[f"{task.id} {setting}"] = image_reliance(ex, task, policy)
    excursions = {
        f"{t.id} {name}": noise_excursion(ex, t, setting)
        for t in tasks
        if ex.folder(t, "raw.h5").is_file()
        for setting, name in EXCURSIONS.items()
    }
    docs.mkdir(parents=True, exist_ok=True)
    (docs / "diagnosis.json").write_text(json.dumps(found | excursions, indent=2) + "\n")
    lines = ["| task, setting | predicted spread | recorded spread | ratio |", "|---|---:|---:|---:|"]
    lines += [f"| {k} | {v['predicted_spread']} | {v['recorded_spread']} | {v['ratio']} |" for k, v in found.items()]
    lines += [
        "",
        "| task, noise | mean joint deviation (rad) | largest | mean TCP deviation (mm) | largest | succeed |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {k} | {v['mean_joint_deviation_rad']} | {v['largest_joint_deviation_rad']} | {v['mean_tcp_deviation_mm']} "
        f"| {v['largest_tcp_deviation_mm']} | {v['still_succeed']}/{v['demos']} |"
        for k, v in excursions.items()
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------ report
Cells = dict[tuple[str, str], dict[tuple[str, int], bool]]


def outcomes(folder: Path) -> dict[tuple[str, int], bool]:
    """(task, seed) -> success of every episode logged in ``folder``."""
    return (
        {(log["task"], int(log["seed"])): bool(log["success"]) for log in read_logs(folder)} if folder.is_dir() else {}
    )


def failure_modes(folder: Path) -> dict[str, Any]:
    """Failure reasons, and the mean of each evaluator metric over the failed episodes."""
    failed = [log for log in (read_logs(folder) if folder.is_dir() else []) if not log["success"]]
    keys = set.intersection(*(set(log.get("metrics", {})) for log in failed)) if failed else set()
    return {
        "reasons": dict(Counter(str(log.get("failure_reason")) for log in failed)),
        "mean_metric_at_failure": {
            k: round(sum(log["metrics"][k] for log in failed) / len(failed), 4) for k in sorted(keys)
        },
    }


LOG_FREQ = 20
"""lerobot-train's --log_freq in SMALL_ACT: a loss line every 20 steps."""


def training_log(ex: Experiment, task: TaskSpec, setting: str) -> str:
    """lerobot-train's log of the run ``setting`` used (this machine's, else the kept one; "" without)."""
    logs = sorted(ex.folder(task, setting).glob("train*/act/*.log"))
    if not logs and ex.keep is not None:
        logs = sorted((ex.keep / ex.folder(task, setting).relative_to(ex.work)).glob("train*/act/*.log"))
    return logs[-1].read_text(errors="replace") if logs else ""


def resumed(log: str) -> bool:
    """Whether a training continued from a checkpoint after an interruption (amendment 9)."""
    return "--resume=true" in log


def training_loss(ex: Experiment, task: TaskSpec, setting: str, marks: list[int]) -> dict[str, float | None]:
    """lerobot-train's logged loss near each of ``marks`` (mean of the five lines up to it) for the
    run ``setting`` used; None where the log does not reach it or the run was resumed (its lines
    then no longer say their step)."""
    text = training_log(ex, task, setting)
    if resumed(text):
        return {str(m): None for m in marks}
    losses = [float(v) for v in re.findall(r"step:\S+ smpl:\S+ ep:\S+ epch:\S+ loss:([0-9.]+)", text)]
    out: dict[str, float | None] = {}
    for mark in marks:
        upto = mark // LOG_FREQ
        near = losses[max(0, upto - 5) : upto]
        out[str(mark)] = round(sum(near) / len(near), 4) if near and upto <= len(losses) else None
    return out


def points(share: float | None) -> str:
    """A share as percentage points ("-" when there is none)."""
    return "-" if share is None else f"{100 * share:.0f} pt"


def cell_text(o: dict[tuple[str, int], bool]) -> str:
    k, n = sum(o.values()), len(o)
    if not n:
        return "-"
    lo, hi = wilson_interval(k, n)
    return f"{k}/{n} ({100 * lo:.0f}-{100 * hi:.0f})"


def families(suite: str) -> list[tuple[str, list[tuple[str, str]]]]:
    """The comparisons of a suite by family (amendment 1's on the clutter suite)."""
    extra = AMENDMENT_5 + ([("aug_object", "aug_object_seg")] if suite == "shifted" else [])
    if suite == "clutter":
        return [
            ("amendment 1", AMENDMENT_1),
            ("amendment 5", extra),
            ("amendment 6", AMENDMENT_6[:2]),
            ("amendment 10", AMENDMENT_10),
            ("amendment 12", AMENDMENT_12),
            ("amendment 14", AMENDMENT_14),
        ]
    return [
        ("primary", PRIMARY),
        ("secondary", SECONDARY),
        ("amendment 5", extra),
        ("amendment 6", AMENDMENT_6),
        ("amendment 10", AMENDMENT_10),
        ("amendment 12", AMENDMENT_12),
        ("amendment 14", AMENDMENT_14),
    ]


def comparisons(cells: Cells, tasks: list[str], suite: str = "nominal") -> list[dict[str, Any]]:
    """The plan's tests on one suite: McNemar exact per task and pooled over tasks (where both
    settings have two tasks or more: pooled over one it is that task's test again), Holm-adjusted
    (primary: per task over the tasks, the pooled test alone; every other family: over all its
    tests)."""
    rows: list[dict[str, Any]] = []
    for family, pairs in families(suite):
        found = []
        for a, b in pairs:
            both = [t for t in tasks if cells.get((t, a)) and cells.get((t, b))]
            for task in [*tasks, "pooled"] if len(both) > 1 else tasks:  # pooled over one task: the same test
                group = tasks if task == "pooled" else [task]
                left = {k: v for t in group for k, v in cells.get((t, a), {}).items()}
                right = {k: v for t in group for k, v in cells.get((t, b), {}).items()}
                if left and set(left) == set(right):
                    row = compare(left, right).as_dict()
                    detectable = smallest_significant(row["n_a"], row["only_a"] + row["only_b"])
                    found.append(
                        {"family": family, "comparison": f"{b} vs {a}", "task": task, **row, "detectable": detectable}
                    )
        groups = [[r for r in found if r["task"] != "pooled"], [r for r in found if r["task"] == "pooled"]]
        for group in groups if family == "primary" else [groups[0] + groups[1]]:
            for row, p in zip(group, holm([r["p_value"] for r in group]), strict=True):
                rows.append({**row, "p_holm": p, "significant": p < ALPHA})
    return rows


EARLIER = {
    "pipette/PickUpTestTube-v1 aug_all": {"nominal": 6, "shifted": 6, "clutter": 6},
    "pipette/PickUpTestTube-v1 aug_object": {"nominal": 14, "shifted": 3},
    "pipette/PlaceTubeOnBalance-v1 aug_all": {"nominal": 9, "shifted": 1, "clutter": 4},
}
"""Amendment 8: the lost first run's counts (of 50) where they differ from the re-run's: PickUpTestTube's
sets were made by the code before 3360bdc (the same setting, its data different in the last bits);
PlaceTubeOnBalance's cause is not known. Counts only (their episodes were lost): no paired test."""


def replicate_rows(cells: Cells, tasks: list[str], setting: str = "aug_all") -> list[dict[str, Any]]:
    """Amendment 8 (``aug_all``) or 16 (``aug_all_plus_drift``) on one suite, per task: raw's and the
    setting's successes at each training seed, every seed of the setting against every raw seed, and
    McNemar exact on the seed-matched episode pairs (Holm over the tasks)."""
    rows: list[dict[str, Any]] = []
    for task in tasks:
        runs = {
            base: [cells.get((task, s), {}) for s in (base, *(f"{base}_seed{n}" for n in REPLICATE_SEEDS))]
            for base in ("raw", setting)
        }
        found = runs["raw"] + runs[setting]
        if not all(found) or any(set(o) != set(found[0]) for o in found):
            continue  # a seed not run yet, or not every episode of it
        counts = {base: [sum(o.values()) for o in found] for base, found in runs.items()}
        crossed = [a - r for a in counts[setting] for r in counts["raw"]]
        left, right = ({(f"{i}:{t}", e): v for i, o in enumerate(runs[b]) for (t, e), v in o.items()} for b in runs)
        test = compare(left, right).as_dict()
        rows.append(
            {
                "task": task,
                "seeds": [TRAIN_SEED, *REPLICATE_SEEDS],
                "setting": setting,
                "raw": counts["raw"],
                setting: counts[setting],
                "episodes": len(runs["raw"][0]),
                "mean_difference": (fmean(counts[setting]) - fmean(counts["raw"])) / len(runs["raw"][0]),
                "crossed_differences": crossed,
                "same_sign": all(d > 0 for d in crossed) or all(d < 0 for d in crossed),
                "p_value": test["p_value"],
            }
        )
    for row, p in zip(rows, holm([r["p_value"] for r in rows]), strict=True):
        row["p_holm"], row["significant"] = p, p < ALPHA
    return rows


def replicate_section(name: str, rows: list[dict[str, Any]], family: str = "amendment 8") -> list[str]:
    setting = REPLICATED[family]
    lines = [
        f"### Training-seed replicates, {name} suite ({family}: {setting})",
        "",
        "| task | raw (seeds "
        + ", ".join(map(str, (TRAIN_SEED, *REPLICATE_SEEDS)))
        + f") | {setting} | mean difference "
        f"| {setting} - raw, every seed pair | same sign | p (McNemar, seed-matched) | p (Holm) |",
        "|---|---|---|---:|---|---|---:|---:|",
    ]
    lines += [
        f"| {r['task']} | {', '.join(map(str, r['raw']))} | {', '.join(map(str, r[setting]))} "
        f"| {100 * r['mean_difference']:+.0f} pt | {min(r['crossed_differences']):+d} to {max(r['crossed_differences']):+d} "
        f"| {'yes' if r['same_sign'] else 'no'} | {r['p_value']:.3g} | {r['p_holm']:.3g}{' *' if r['significant'] else ''} |"
        for r in rows
    ]
    earlier = [
        f"- {key}: {found[name]}/50" for key, found in EARLIER.items() if name in found and family == "amendment 8"
    ]
    if earlier:
        lines += ["", "The lost first run's counts of the same settings (another realization; no paired test):", ""]
        lines += earlier
    return [*lines, ""]


def cell_table(cells: Cells, tasks: list[str], settings: Sequence[str]) -> list[str]:
    """Successes / episodes (95 % Wilson interval) per task and setting; a cell with fewer episodes
    than its task's raw cell is still being evaluated and says so (no test reads it)."""
    full = {t: len(cells.get((t, "raw"), {})) for t in tasks}

    def text(t: str, s: str) -> str:
        found = cells.get((t, s), {})
        return cell_text(found) + (" (running)" if found and len(found) < full[t] else "")

    return [
        "| task | " + " | ".join(settings) + " |",
        "|---" * (len(settings) + 1) + "|",
        *(f"| {t} | " + " | ".join(text(t, s) for s in settings) + " |" for t in tasks),
    ]


def suite_section(name: str, cells: Cells, tasks: list[str], rows: list[dict[str, Any]]) -> list[str]:
    settings = SUITE_SETTINGS[name]
    registered = [s for s in settings if s in SETTINGS]
    added = [s for s in settings if s not in SETTINGS and any(cells.get((t, s)) for t in tasks)]
    lines = [f"### {name.capitalize()} suite", "", *cell_table(cells, tasks, registered), ""]
    if added:
        lines += ["Settings added by amendments (5: *_seg, 6: *_ep, 8: *_seed*):", ""]
        lines += [*cell_table(cells, tasks, added), ""]
    lines += [
        "",
        "| comparison | task | difference | discordant (b only / a only) | p | p (Holm) | significant from |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {r['comparison']} ({r['family']}) | {r['task']} | {100 * r['difference']:+.0f} pt | {r['only_b']} / {r['only_a']} "
        f"| {r['p_value']:.3g} | {r['p_holm']:.3g}{' *' if r['significant'] else ''} "
        f"| {points(r['detectable'])} |"
        for r in rows
    ]
    return [*lines, ""]


def failure_section(name: str, modes: dict[str, dict[str, Any]]) -> list[str]:
    """Each evaluated cell's failures of one suite: the evaluator's reasons, counted, and the mean of
    each of its metrics over the failed episodes (the plan's failure modes)."""
    rows = [(key, found) for key, found in modes.items() if found["reasons"]]
    if not rows:
        return []
    lines = [
        f"Failures on the {name} suite (reasons counted; the evaluator's metrics, mean over the failed episodes):",
        "",
        "| task, setting | reasons | metrics at failure |",
        "|---|---|---|",
    ]
    lines += [
        f"| {key} | {', '.join(f'{r} {n}' for r, n in sorted(found['reasons'].items(), key=lambda kv: -kv[1]))} "
        f"| {', '.join(f'{k} {v:g}' for k, v in found['mean_metric_at_failure'].items())} |"
        for key, found in rows
    ]
    return [*lines, ""]


def task_notes(ids: list[str], ceiling: list[str]) -> dict[str, list[str]]:
    """What the report says beside each task's rows: at the pilot's ceiling (amendment 3), its
    known faults (:data:`FAULTS`)."""
    notes: dict[str, list[str]] = {}
    for task in ids:
        said = ["at the ceiling in the pilot (amendment 3): only a loss could be seen"] if task in ceiling else []
        said += [FAULTS[task]] if task in FAULTS else []
        if said:
            notes[task] = said
    return notes


def made_by(status: DatasetStatus) -> list[str]:
    """The code that made a dataset's episodes, described, sorted."""
    return sorted(describe_code(version) for version in recorded_code(status))


def data_code(ex: Experiment, task: TaskSpec) -> dict[str, list[str]]:
    """The code that made each of ``task``'s datasets, by file: a setting whose data another commit than
    the run's made shows here (amendment 8). What the work folder's files say joins what is kept in
    ``data_code.json`` (restored from the kept folder), so a file lost with a machine (amendments 7 and
    11) is still listed with the code that made it, and a file made again lists both."""
    record = ex.folder(task, "data_code.json")
    found: dict[str, list[str]] = json.loads(record.read_text()) if record.is_file() else {}
    for path in sorted(ex.folder(task).glob("*.h5")):
        found[path.name] = sorted({*found.get(path.name, []), *made_by(scan(path))})
    found = dict(sorted(found.items()))
    if found:
        record.write_text(json.dumps(found, indent=2) + "\n")
        kept(ex, record)
    return found


def array_digest(name: str, value: np.ndarray) -> str:
    """SHA-256 of one HDF5 array with its name, dtype and shape (strings by their text, not their
    object pointers)."""
    if value.dtype.kind == "O":
        value = np.array([v.decode() if isinstance(v, bytes) else str(v) for v in np.ravel(value)])
    value = np.ascontiguousarray(value)
    return hashlib.sha256(f"{name}\0{value.dtype}\0{value.shape}\0".encode() + value.tobytes()).hexdigest()


def datasets_in(f: h5py.File) -> list[str]:
    """The names of every array in an HDF5 file, sorted."""
    names: list[str] = []
    f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
    return sorted(names)


def data_hashes(ex: Experiment, task: TaskSpec, sample: int = 6) -> dict[str, Any]:
    """Every dataset of ``task`` in the work folder: one hash over all its arrays but wall time, the
    number of arrays, the hashes of its first ``sample`` actions and main views, and the code that
    made it; with the machine's CPU (two machines' files say whether their datasets differ)."""
    files: dict[str, Any] = {}
    for path in sorted(ex.folder(task).glob("*.h5")):
        status = scan(path)
        if status.pending:  # being made now: its parts are not in the file yet
            files[path.name] = {"in_progress": True}
            continue
        with h5py.File(path, "r") as f:
            names = [n for n in datasets_in(f) if not n.endswith("wall_time")]
            digests = {n: array_digest(n, f[n][()]) for n in names}
        whole = hashlib.sha256("".join(digests.values()).encode()).hexdigest()
        some = [n for n in digests if n.endswith(("/action", "images/main"))][: 2 * sample]
        files[path.name] = {
            "sha256_of_arrays": whole,
            "arrays": len(digests),
            "some_arrays": {n: digests[n][:16] for n in some},
            "made_by": made_by(status),
        }
    return {
        "machine": cpu_field("model name") or platform.machine(),
        "avx512f": "avx512f" in cpu_flags(),
        "files": files,
    }


SPEED_RUNS = {
    "shared": ROOT / "docs" / "benchmarks" / "bench_train.json",
    "idle": ROOT / "docs" / "benchmarks" / "bench_train_idle.json",
}
"""benchmarks/bench_train.py runs, each "before" and "after" side by side in one run: on cores
other work shares (as the experiment's trainings ran, two at a time) and on an idle machine."""


def training_speed(runs: dict[str, Path] = SPEED_RUNS) -> tuple[dict[str, Any], list[str]]:
    """The training step before and after the speed work (plan.md, "Training speed"): each run's
    seconds per step for both presets, the ratio, its commit and load; and the table's lines."""
    found: dict[str, Any] = {}
    lines = [
        "### Training step, before and after (benchmarks/bench_train.py, side by side in one run)",
        "",
        "| machine | before s/step | after s/step | before / after | commit | load average |",
        "|---|---:|---:|---:|---|---|",
    ]
    for name, path in runs.items():
        if not path.is_file():
            continue
        run = json.loads(path.read_text())
        before, after = run["rows"]["before"], run["rows"]["after"]
        loads = [x for row in run["rows"].values() for x in row.get("load", [])]
        found[name] = {
            "file": str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path),
            "commit": run["settings"]["git_commit"],
            "before_s_per_step": before["s_per_step"],
            "after_s_per_step": after["s_per_step"],
            "speedup": before["s_per_step"] / after["s_per_step"],
            "before": before["what"],
            "after": after["what"],
            "load_average": [min(loads), max(loads)] if loads else None,
        }
        row = found[name]
        load = "-" if not loads else f"{min(loads):.1f}-{max(loads):.1f}"
        lines.append(
            f"| {name} | {row['before_s_per_step']:.3f} | {row['after_s_per_step']:.3f} | "
            f"{row['speedup']:.2f}x | {row['commit'][:7]} | {load} |"
        )
    return found, [*lines, ""]


def report(ex: Experiment, tasks: list[TaskSpec], docs: Path, steps: int, ceiling: Sequence[str] = ()) -> str:
    """results.json and table.md in ``docs`` from the episode logs under ``ex.work``."""
    ids = [t.id for t in tasks]
    notes = task_notes(ids, list(ceiling))
    results: dict[str, Any] = {"steps": steps, "tasks": ids, "notes": notes, "suites": {}}
    lines = ["### Notes on the tasks", ""] + [f"- {t}: {n}" for t, said in notes.items() for n in said] + [""]
    for name, settings in SUITE_SETTINGS.items():
        cells = {(t.id, s): outcomes(ex.folder(t, "eval", name, s)) for t in tasks for s in settings}
        rows = comparisons(cells, ids, name)
        lines += suite_section(name, cells, ids, rows)
        replicated = {f: replicate_rows(cells, ids, s) if name != "clutter" else [] for f, s in REPLICATED.items()}
        lines += [line for f, found in replicated.items() if found for line in replicate_section(name, found, f)]
        modes = {f"{t.id} {s}": failure_modes(ex.folder(t, "eval", name, s)) for t in tasks for s in settings}
        lines += failure_section(name, modes)
        results["suites"][name] = {
            "cells": {f"{t} {s}": {"successes": sum(o.values()), "episodes": len(o)} for (t, s), o in cells.items()},
            "comparisons": rows,
            "replicates": replicated["amendment 8"],
            "replicates_amendment_16": replicated["amendment 16"],
            "failure_modes": modes,
        }
    marks = [steps // 4, steps // 2]
    curve = {
        f"{t.id} {s}": {str(m): cell_text(outcomes(ex.folder(t, "eval", "curve", f"{s}@{m}"))) for m in marks}
        | {str(steps): cell_text(outcomes(ex.folder(t, "eval", "nominal", s)))}
        for t in tasks
        for s in ("raw", "aug_all")
    }
    loss = {f"{t.id} {s}": training_loss(ex, t, s, [*marks, steps]) for t in tasks for s in (*SETTINGS, *SEGMENTED)}
    lines += [
        "### Learning curves (nominal suite; lerobot-train's loss beside each)",
        "",
        "| task, setting | " + " | ".join(f"{m} steps" for m in [*marks, steps]) + " |",
        "|---" * 4 + "|",
    ]
    lines += [
        f"| {key} | "
        + " | ".join(v + ("" if loss[key][m] is None else f", loss {loss[key][m]:.3f}") for m, v in row.items())
        + " |"
        for key, row in curve.items()
    ]
    results["learning_curves"] = curve
    results["training_loss"] = loss
    settings_run = sorted({s for found in SUITE_SETTINGS.values() for s in found})
    results["resumed"] = [f"{t.id} {s}" for t in tasks for s in settings_run if resumed(training_log(ex, t, s))]
    lines += [
        "",
        "Trainings resumed from a checkpoint after an interruption (amendment 9): "
        + (", ".join(results["resumed"]) or "none")
        + ".",
    ]
    results["yield"] = {
        t.id: json.loads(ex.folder(t, "yield.json").read_text()) if ex.folder(t, "yield.json").is_file() else {}
        for t in tasks
    }
    lines += [
        "",
        "### Augmentation yield (kept / tried)",
        "",
        "| task | " + " | ".join(VARIANTS) + " |",
        "|---" * (len(VARIANTS) + 1) + "|",
    ]
    for t in tasks:
        found = results["yield"][t.id]
        lines.append(
            f"| {t.id} | "
            + " | ".join(f"{found[s]['kept']}/{found[s]['attempts']}" if s in found else "-" for s in VARIANTS)
            + " |"
        )
    lines += yield_by_kind_lines(results["yield"], tasks)
    results["contained"] = {
        t.id: json.loads(ex.folder(t, "contained.json").read_text())
        for t in tasks
        if ex.folder(t, "contained.json").is_file()
    }
    for t, found in results["contained"].items():
        for outer, c in found.items():
            same = "have its yield, variant by variant" if c["same_yield"] else "do NOT have its yield"
            arrays = (
                f"; no array check ({c['inner']}.h5 was not on the machine)"
                if c["episodes"] is None
                else f"; {c['identical']} of its {c['episodes']} episodes identical array for array"
            )
            lines += ["", f"{t} {outer}: {c['inner']}'s replays inside it {same}{arrays}."]
    results["training_speed"], speed_lines = training_speed()
    lines += ["", *speed_lines]
    results["data_code"] = {t.id: data_code(ex, t) for t in tasks}
    results["earlier_run"] = EARLIER
    commit, dirty = git_state()
    results["settings"] = {
        "git_commit": commit,
        "git_dirty": dirty,
        "command": " ".join(sys.argv),
        "demos": ex.demos,
        "demos_per_task": {t.id: ex.demos_of(t) for t in tasks},
        "max_episodes": ex.max_episodes,
        "atoms": ATOMS,
        "setting_atoms": SETTING_ATOMS,
        "variants": VARIANTS,
        "act_flags": list(SMALL_ACT),
        "train_threads": SMALL_ACT_THREADS,
        "batch_size": BATCH,
        "suites": {"nominal": NOMINAL, "shifted": SHIFTED, "clutter": CLUTTER},
    }
    docs.mkdir(parents=True, exist_ok=True)
    (docs / "results.json").write_text(json.dumps(results, indent=2) + "\n")
    text = "\n".join(lines) + "\n"
    (docs / "table.md").write_text(text)
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("stage", choices=("data", "pilot", "run", "report", "diagnose", "hashes", "contained"))
    parser.add_argument("--work", type=Path, default=Path("runs/augmentation"))
    parser.add_argument("--docs", type=Path, default=ROOT / "docs" / "reproduction" / "augmentation")
    parser.add_argument(
        "--tasks", default=None, help="Comma-separated task ids (default: the pilot's, or the suite's)."
    )
    parser.add_argument("--settings", default=",".join(SETTINGS), help="Data settings to run.")
    parser.add_argument("--steps", type=int, default=None, help="Training steps (default: the pilot's S).")
    parser.add_argument("--workers", type=int, default=1, help="Processes per collection, augmentation, evaluation.")
    parser.add_argument("--jobs", type=int, default=1, help="Tasks run at once (pilot and run stages).")
    parser.add_argument(
        "--keep",
        type=Path,
        default=None,
        help="Copy finished episode logs, yield reports and training logs here, and restore them at start.",
    )
    smoke = parser.add_argument_group("smoke runs only (never for results)")
    smoke.add_argument("--demos", type=int, default=DEMOS)
    smoke.add_argument("--pilot-steps", default=",".join(map(str, PILOT_STEPS)))
    smoke.add_argument("--pilot-episodes", type=int, default=PILOT_EPISODES)
    smoke.add_argument("--max-episodes", type=int, default=None)
    args = parser.parse_args()
    registry = load_registry()
    found = load_suites(registry)
    suites = {"nominal": found.get(NOMINAL), "shifted": found.get(SHIFTED), "clutter": found.get(CLUTTER)}
    nominal = suites["nominal"].spec
    ex = Experiment(
        args.work,
        args.workers,
        nominal.image_size or 64,
        nominal.render_profile,
        args.demos,
        tuple(int(s) for s in args.pilot_steps.split(",")),
        args.pilot_episodes,
        args.max_episodes,
        args.jobs,
        keep=args.keep,
    )
    pilot_file = args.docs / "pilot.json"
    chosen = json.loads(pilot_file.read_text()) if pilot_file.is_file() else {}
    if args.stage != "pilot":  # the pilot starts from every candidate with all its demonstrations
        ex = replace(ex, fewer=tuple((t, n) for t, n in chosen.get("demos_per_task", {}).items() if n != ex.demos))
    candidates = [e.task for e in nominal.tasks]  # the pilot starts from all; later stages from the pilot's choice
    default = candidates if args.stage == "pilot" else chosen.get("tasks") or candidates
    tasks = [registry.get(n) for n in (args.tasks.split(",") if args.tasks else default)]
    if args.stage == "pilot":
        pilot(ex, tasks, args.docs)
        return
    if args.stage == "hashes":
        for task in tasks:
            if not any(ex.folder(task).glob("*.h5")):
                continue  # nothing made yet
            into = (ex.keep or args.docs) / ex.folder(task).name / "data_hashes.json"
            into.parent.mkdir(parents=True, exist_ok=True)
            into.write_text(json.dumps(data_hashes(ex, task), indent=1) + "\n")
            say(f"{task.id}: {into}")
        return
    if args.stage == "contained":  # amendment 14: the data that hold another setting's replays, checked
        for task in tasks:
            checked = {s: contained(ex, task, s) for s in CONTAINS if ex.folder(task, f"{s}.h5").is_file()}
            if checked:
                ex.folder(task, "contained.json").write_text(json.dumps(checked, indent=1) + "\n")
                kept(ex, ex.folder(task, "contained.json"))
                say(f"{task.id}: {checked}")
        return
    if args.stage == "data":  # what does not depend on training: demonstrations and augmentation
        for task in tasks:
            data(ex, task, [s for s in args.settings.split(",") if s])
        return
    steps = args.steps or chosen.get("steps")
    if steps is None:
        raise SystemExit("no training steps: run the pilot first or pass --steps")
    if args.stage == "diagnose":
        print(diagnose(ex, tasks, args.docs, steps))
        return
    if ex.keep is not None:
        say(f"restored {restore(ex)} kept files from {ex.keep} into {ex.work}")
    if args.stage == "run":
        each_task(ex, run_task, tasks, steps, suites, [s for s in args.settings.split(",") if s])
    print(report(ex, tasks, args.docs, steps, chosen.get("ceiling", [])))


if __name__ == "__main__":
    main()
