"""Training launcher: one ``lerobot-train`` run per task with the paper's defaults (appendix D.1).

Builds the argument list of LeRobot's ``lerobot-train`` console script for each task's dataset
(the ``pipette convert`` layout, ``datasets/<task>/<version>``), plans what to do with existing
output folders (skip, overwrite, continue from the last checkpoint) and runs the commands one
after the other as subprocesses (an argv list, never a shell), their output tee'd to a log file.

Defaults (paper, training-parameter table): ACT batch 32, 15000 steps; SmolVLA batch 8, 20000
steps; pi0 batch 4, 20000 steps, fine-tuned from ``lerobot/pi0_base`` in bfloat16 with gradient
checkpointing, a frozen vision encoder and only the action expert trained. Nothing is pushed to
the Hub (``--policy.push_to_hub=false``).
"""

from __future__ import annotations

import json
import logging
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import IO

from pipette_cli.errors import DatasetError, PipetteError, plural
from pipette_cli.lerobot.convert import DatasetVersion, slug
from pipette_cli.lerobot.layout import LAST_CHECKPOINT
from pipette_cli.lerobot.output import Abridged
from pipette_cli.specs.base import described

logger = logging.getLogger(__name__)

PI0_BASE = "lerobot/pi0_base"
DEFAULT_DATASETS_ROOT = Path("datasets")
DEFAULT_OUTPUT_ROOT = Path("outputs/train")


class TrainError(PipetteError):
    """A training run cannot be planned or failed."""


class Policy(str, Enum):
    act = "act"
    smolvla = "smolvla"
    pi0 = "pi0"


class IfExists(str, Enum):
    """What to do when a task's output folder exists already."""

    skip = "skip"
    overwrite = "overwrite"
    continue_ = "continue"


@dataclass(frozen=True)
class PolicyDefaults:
    batch_size: int
    steps: int


PAPER_DEFAULTS: dict[Policy, PolicyDefaults] = {
    Policy.act: PolicyDefaults(batch_size=32, steps=15_000),
    Policy.smolvla: PolicyDefaults(batch_size=8, steps=20_000),
    Policy.pi0: PolicyDefaults(batch_size=4, steps=20_000),
}


def _per_policy(what: str) -> str:
    """``act 32, smolvla 8, pi0 4``: the paper's default ``what`` for each policy."""
    return ", ".join(f"{p.value} {getattr(d, what)}" for p, d in PAPER_DEFAULTS.items())


@dataclass(frozen=True)
class TrainOptions:
    """How every task of one ``pipette train`` call is trained (each field's description is also the
    help of its ``pipette train`` option).

    Attributes:
        policy: act, smolvla or pi0.
        extra: More ``lerobot-train`` flags, appended last (they win).
    """

    policy: Policy
    dataset_version: DatasetVersion = described(DatasetVersion.raw, "raw or augmented (separate datasets)")
    steps: int | None = described(None, f"Training steps (default: the paper's, D.1: {_per_policy('steps')})")
    batch_size: int | None = described(None, f"Batch size (default: the paper's, D.1: {_per_policy('batch_size')})")
    device: str | None = described(None, "cpu, cuda[:N] or mps (default: LeRobot picks the best available)")
    datasets_root: Path = described(
        DEFAULT_DATASETS_ROOT, "Folder of <task>/<version> datasets (pipette convert's layout)"
    )
    output_root: Path = described(
        DEFAULT_OUTPUT_ROOT, "Runs go to <root>/<policy>/<task>_<version>, logs beside as .log"
    )
    if_exists: IfExists = described(
        IfExists.skip, "Existing output: skip the task, overwrite it, or continue from its last checkpoint"
    )
    pretrained_path: str | None = described(
        None, f"Checkpoint to fine-tune (--policy.path; hub id or local folder). pi0 default: {PI0_BASE}"
    )
    vlm_path: str | None = described(
        None, "SmolVLA backbone (--policy.vlm_model_name): hub id or local folder with config and tokenizer"
    )
    act_backbone_weights: str | None = described(
        None, "torchvision weights for ACT's ResNet, e.g. ResNet18_Weights.IMAGENET1K_V1 (default: none, random init)"
    )
    offline: bool = described(False, "Run with HF_HUB_OFFLINE=1: only local folders and the Hugging Face cache")
    threads: int | None = described(
        None, "CPU threads of the training process (OMP_NUM_THREADS; default: torch's, one per core)"
    )
    extra: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.act_backbone_weights is not None:
            torchvision_weights(self.act_backbone_weights)


TORCHVISION_WEIGHTS = re.compile(r"(?:[A-Za-z0-9]+_Weights\.)?[A-Z][A-Z0-9_]*|null")
"""A torchvision weights enum's name, with or without its class (``ResNet18_Weights.IMAGENET1K_V1``,
``IMAGENET1K_V1``, ``DEFAULT``), or ``null``: what lerobot's ``--policy.pretrained_backbone_weights``
passes on to torchvision."""


def torchvision_weights(value: str) -> str:
    """``value`` if it names torchvision weights (:data:`TORCHVISION_WEIGHTS`; ``pipette train
    --act-backbone-weights`` parses with it).

    Raises:
        TrainError: anything else, such as a file: lerobot loads no backbone from one.
    """
    if not TORCHVISION_WEIGHTS.fullmatch(value):
        raise TrainError(
            f"--act-backbone-weights {value!r}: give a torchvision weights name such as "
            "ResNet18_Weights.IMAGENET1K_V1 (torchvision loads it into its cache), not a file: lerobot reads no "
            "backbone file; a whole policy checkpoint goes to --pretrained-path"
        )
    return value


@dataclass(frozen=True)
class TrainJob:
    """One task's run: what to execute and where it writes.

    Attributes:
        action: ``train``, ``continue`` (resume), ``overwrite`` (delete, then train) or ``skip``.
    """

    task_id: str
    dataset: Path
    repo_id: str
    output_dir: Path
    log_file: Path
    action: str
    argv: tuple[str, ...] = ()
    env: dict[str, str] = field(default_factory=dict)


def dataset_root(task_id: str, version: DatasetVersion, base: Path = DEFAULT_DATASETS_ROOT) -> Path:
    """``<base>/<task>/<version>``, as written by ``pipette convert``."""
    return base / slug(task_id) / version.value


def run_dir(task_id: str, policy: Policy, version: DatasetVersion, output_root: Path = DEFAULT_OUTPUT_ROOT) -> Path:
    """Where ``lerobot-train`` writes one run: ``<output_root>/<policy>/<task>_<version>``; the
    policy to serve or evaluate is its :data:`LAST_CHECKPOINT`."""
    return output_root / policy.value / f"{slug(task_id)}_{version.value}"


def has_dataset(root: Path) -> bool:
    return (root / "meta" / "info.json").is_file()


def lerobot_train_executable() -> str:
    """The ``lerobot-train`` script of this Python environment (else the one on PATH)."""
    beside = Path(sys.executable).parent / "lerobot-train"
    if beside.is_file():
        return str(beside)
    found = shutil.which("lerobot-train")
    if found is None:
        raise TrainError("lerobot-train not found: install lerobot in this environment (pip install lerobot)")
    return found


def policy_flags(options: TrainOptions) -> list[str]:
    """The ``--policy.*`` flags for the chosen policy (paper defaults and offline settings)."""
    p = options.policy
    flags: list[str] = []
    if p is Policy.pi0:
        flags += [
            f"--policy.path={options.pretrained_path or PI0_BASE}",
            "--policy.dtype=bfloat16",
            "--policy.gradient_checkpointing=true",
            "--policy.freeze_vision_encoder=true",
            "--policy.train_expert_only=true",
        ]
    elif options.pretrained_path:
        flags.append(f"--policy.path={options.pretrained_path}")
    else:
        flags.append(f"--policy.type={p.value}")
    if p is Policy.act and not options.pretrained_path:
        flags.append(f"--policy.pretrained_backbone_weights={options.act_backbone_weights or 'null'}")
    if p is Policy.smolvla and options.vlm_path:
        flags.append(f"--policy.vlm_model_name={options.vlm_path}")
    if options.device:
        flags.append(f"--policy.device={options.device}")
    flags.append("--policy.push_to_hub=false")
    return flags


DECODER = "--dataset.video_backend=pyav"
"""PyAV decodes video datasets on every machine (it bundles its FFmpeg), so a training reads the same
frames everywhere. Left unset, LeRobot picks torchcodec where it loads, which needs the system's
FFmpeg libraries, and where they are missing it prints the loader's tracebacks once more before
falling back to PyAV (:mod:`.output` shortens the one it prints anyway). Image datasets (the
default) decode nothing."""


CPU_STEPS = 2000
"""Steps beyond which a training on a CPU is warned about (the CPU presets train 300-2000)."""


def cpu_warning(options: TrainOptions, jobs: Sequence[TrainJob]) -> str | None:
    """A warning when these jobs would train long on a CPU: the device is the CPU, or left to LeRobot
    on a machine with no accelerator (no NVIDIA driver, not Apple silicon)."""
    steps = max((job_steps(j) or 0 for j in jobs), default=0)
    accelerated = Path("/proc/driver/nvidia/version").exists() or shutil.which("nvidia-smi") is not None
    accelerated |= sys.platform == "darwin" and platform.machine() == "arm64"
    on_cpu = options.device == "cpu" or (options.device is None and not accelerated)
    if not on_cpu or steps <= CPU_STEPS:
        return None
    found = "" if options.device == "cpu" else " (no GPU found)"  # asked for, or what LeRobot would pick here
    return (
        f"{plural(len(jobs), 'training')} of {steps} steps on the CPU{found}: at the paper's sizes that takes "
        "hours to days here; give --steps and --batch-size for a CPU run (`pipette demo` trains a small ACT for "
        "300 steps in about 3 minutes), or --device cuda on a machine with a GPU"
    )


def train_argv(
    task_id: str, options: TrainOptions, *, resume: bool = False, executable: str = "lerobot-train"
) -> list[str]:
    """The full ``lerobot-train`` argument list for one task."""
    name = f"{slug(task_id)}_{options.dataset_version.value}"
    output_dir = run_dir(task_id, options.policy, options.dataset_version, options.output_root)
    if resume:
        config = output_dir / LAST_CHECKPOINT / "train_config.json"
        more = [f"--steps={options.steps}"] if options.steps else []
        more += [f"--policy.device={options.device}"] if options.device else []
        return [executable, f"--config_path={config}", "--resume=true", DECODER, *more, *options.extra]
    defaults = PAPER_DEFAULTS[options.policy]
    return [
        executable,
        f"--dataset.repo_id=local/{name}",
        f"--dataset.root={dataset_root(task_id, options.dataset_version, options.datasets_root)}",
        DECODER,
        *policy_flags(options),
        f"--policy.repo_id=local/{options.policy.value}_{name}",
        f"--output_dir={output_dir}",
        f"--job_name={options.policy.value}_{name}",
        f"--batch_size={options.batch_size or defaults.batch_size}",
        f"--steps={options.steps or defaults.steps}",
        "--wandb.enable=false",
        *options.extra,
    ]


def missing_datasets(task_ids: Sequence[str], version: DatasetVersion, datasets_root: Path) -> list[Path]:
    """The dataset folders of ``task_ids`` that hold no LeRobot dataset (yet)."""
    return [root for root in (dataset_root(t, version, datasets_root) for t in task_ids) if not has_dataset(root)]


def resolve_tasks(
    requested: Sequence[str],
    registry_ids: Sequence[str],
    resolve: Callable[[str], str],
    version: DatasetVersion,
    datasets_root: Path,
    *,
    allow_missing: bool = False,
) -> list[str]:
    """Task ids to train: ``all`` = every registered task with a dataset of ``version``.

    ``allow_missing`` keeps named tasks whose dataset does not exist yet (``--dry-run``: the
    commands can be previewed before ``pipette convert``; :func:`missing_datasets` lists them).

    Raises:
        TaskNotFound: an unknown task (from ``resolve``).
        DatasetError: a named task has no dataset (unless ``allow_missing``), or ``all`` finds none.
    """
    if "all" in requested and len(requested) > 1:
        raise TrainError("--tasks all cannot be combined with task ids")
    if list(requested) == ["all"]:
        ids = [t for t in registry_ids if has_dataset(dataset_root(t, version, datasets_root))]
        if not ids:
            raise DatasetError(
                f"no {version.value} datasets under {datasets_root}/<task>/{version.value} for any registered task; "
                "make them with `pipette convert`"
            )
        return ids
    ids = list(dict.fromkeys(resolve(t) for t in requested))
    missing = missing_datasets(ids, version, datasets_root)
    if missing and not allow_missing:
        raise DatasetError(
            f"no LeRobot dataset (meta/info.json) at {', '.join(map(str, missing))}; "
            f"make it with `pipette convert ... --dataset-version {version.value}` or give --datasets-root"
        )
    return ids


def _removable(path: Path) -> bool:
    """Only a LeRobot training output (or an empty folder) is deleted by --if-exists overwrite."""
    return not any(path.iterdir()) or (path / "checkpoints").is_dir() or (path / "train_config.json").is_file()


def plan(task_ids: Sequence[str], options: TrainOptions, *, executable: str = "lerobot-train") -> list[TrainJob]:
    """One job per task, deciding from the existing output folders; all checked before any run.

    Raises:
        TrainError: ``continue`` without a checkpoint, or ``overwrite`` of a folder that is not a
            training output.
    """
    env = {"HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1"} if options.offline else {}
    if options.threads is not None:
        env |= {"OMP_NUM_THREADS": str(options.threads), "MKL_NUM_THREADS": str(options.threads)}
    jobs: list[TrainJob] = []
    problems: list[str] = []
    for task_id in task_ids:
        name = f"{slug(task_id)}_{options.dataset_version.value}"
        output_dir = run_dir(task_id, options.policy, options.dataset_version, options.output_root)
        action = "train"
        if output_dir.exists():
            if options.if_exists is IfExists.skip:
                action = "skip"
            elif options.if_exists is IfExists.overwrite:
                action = "overwrite"
                if not output_dir.is_dir() or not _removable(output_dir):
                    problems.append(f"{output_dir} is not a lerobot-train output; not overwriting it")
            else:
                action = "continue"
                if not (output_dir / LAST_CHECKPOINT / "train_config.json").is_file():
                    problems.append(
                        f"{output_dir}: no checkpoint to continue from ({LAST_CHECKPOINT}/train_config.json)"
                    )
        argv = (
            ()
            if action == "skip"
            else tuple(train_argv(task_id, options, resume=action == "continue", executable=executable))
        )
        jobs.append(
            TrainJob(
                task_id=task_id,
                dataset=dataset_root(task_id, options.dataset_version, options.datasets_root),
                repo_id=f"local/{name}",
                output_dir=output_dir,
                log_file=options.output_root / options.policy.value / f"{name}.log",
                action=action,
                argv=argv,
                env=env,
            )
        )
    if problems:
        raise TrainError("; ".join(problems) + " (use another --if-exists or --output-root)")
    return jobs


@dataclass(frozen=True)
class JobResult:
    task_id: str
    action: str
    returncode: int
    seconds: float
    checkpoint: Path | None


_STEP = re.compile(r"\bstep:(\d+(?:\.\d+)?)([KMB]?)\b")


def logged_step(line: str) -> int | None:
    """The training step of a ``lerobot-train`` log line (``step:20 smpl:160 ... loss:0.93``;
    ``step:1K`` above 999), None for other lines."""
    found = _STEP.search(line)
    if found is None:
        return None
    return int(float(found.group(1)) * {"": 1, "K": 1_000, "M": 1_000_000, "B": 1_000_000_000}[found.group(2)])


def job_steps(job: TrainJob) -> int | None:
    """The ``--steps`` a job trains to, if its command line says (a resumed run may not)."""
    steps = [a.split("=", 1)[1] for a in job.argv if a.startswith("--steps=")]
    return int(steps[-1]) if steps and steps[-1].isdigit() else None


def run_job(job: TrainJob, *, echo: IO[str] | None = None, on_step: Callable[[int], None] | None = None) -> JobResult:
    """Run one job, its stdout+stderr appended to ``job.log_file`` and copied to ``echo``;
    ``on_step`` is called with the step of each progress line ``lerobot-train`` logs
    (every ``--log_freq`` steps).

    Ctrl-C stops the child process (SIGINT, then kill after 30 s) and re-raises.
    """
    if job.action == "skip":
        return JobResult(job.task_id, "skip", 0, 0.0, None)
    if job.action == "overwrite":
        shutil.rmtree(job.output_dir)
        job.log_file.unlink(missing_ok=True)
    job.log_file.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    env = {**os.environ, **job.env, "PYTHONUNBUFFERED": "1"}
    with job.log_file.open("a", encoding="utf-8") as log:
        log.write(f"# pipette train {job.task_id}: {' '.join(job.argv)}\n")
        log.flush()
        proc = subprocess.Popen(
            list(job.argv),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            env=env,
            text=True,
            bufsize=1,
        )
        shown = Abridged(echo) if echo is not None else None  # known library warnings: one line each
        try:
            assert proc.stdout is not None
            for line in proc.stdout:
                log.write(line)
                if shown is not None:
                    shown.write(line)
                    shown.flush()
                if on_step is not None and (step := logged_step(line)) is not None:
                    on_step(step)
            code = proc.wait()
            if shown is not None:
                shown.close()
        except KeyboardInterrupt:
            proc.send_signal(2)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
            raise
    checkpoint = job.output_dir / LAST_CHECKPOINT
    return JobResult(
        job.task_id,
        job.action,
        code,
        time.perf_counter() - start,
        checkpoint if (checkpoint / "config.json").is_file() else None,
    )


def train_checkpoint(
    task_id: str,
    options: TrainOptions,
    *,
    on_train: Callable[[TrainJob], None] | None = None,
    on_step: Callable[[int], None] | None = None,
) -> Path:
    """Train one task with this environment's ``lerobot-train`` (or reuse its finished run) and
    return the last checkpoint.

    With ``if_exists=skip``, a run folder without a checkpoint (stopped before its first save) is
    trained again from scratch, and one stopped between checkpoints continues from its last one
    (lerobot's resume: optimizer and random state restored; the data order after the resume
    differs from an uninterrupted run's). ``on_train`` is called before a run actually starts, ``on_step``
    with each step the run logs (see :func:`run_job`).

    Raises:
        TrainError: the run failed (its log says why) or left no checkpoint.
    """
    executable = lerobot_train_executable()
    [job] = plan([task_id], options, executable=executable)
    if job.action == "skip" and not (job.output_dir / LAST_CHECKPOINT / "config.json").is_file():
        [job] = plan([task_id], replace(options, if_exists=IfExists.overwrite), executable=executable)
    elif job.action == "skip" and options.steps and trained_steps(job.output_dir) < options.steps:
        [job] = plan([task_id], replace(options, if_exists=IfExists.continue_), executable=executable)
    if job.action != "skip":
        if on_train is not None:
            on_train(job)
        result = run_job(job, on_step=on_step)
        if result.returncode != 0 or result.checkpoint is None:
            raise TrainError(f"training {task_id} failed; see {job.log_file}")
    return job.output_dir / LAST_CHECKPOINT


def trained_steps(output_dir: Path) -> int:
    """The step of a run folder's last checkpoint (0 without one)."""
    state = output_dir / LAST_CHECKPOINT.parent / "training_state" / "training_step.json"
    try:
        return int(json.loads(state.read_text())["step"])
    except (OSError, ValueError, KeyError, TypeError):
        return 0
