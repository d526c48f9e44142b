"""``augment``: every demo of a raw file through every variant into a new file, resumably.

Output files are written exactly like ``collect`` writes them: each kept episode becomes a
part ``OUT.h5.parts/episode_XXXXXX.h5`` (``*.tmp``, fsync, rename) and packing moves the
parts into ``OUT.h5`` atomically at the end, on Ctrl-C and on error. A ledger
``OUT.h5.augment.json`` (replaced atomically after each demo's parts are committed) records
each finished demo with its outcomes: a rerun skips them. Parts of a demo that is not in
the ledger (a crash between its parts and the ledger) are deleted and the demo is redone.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py

from pipette_cli.augment.executors import Executor, default_workers, run_jobs
from pipette_cli.augment.pipeline import DemoJob, DemoResult
from pipette_cli.augment.report import yield_report
from pipette_cli.augment.specs import AugmentSpec
from pipette_cli.demos.provenance import mixing_problem, provenance
from pipette_cli.demos.recorder import DatasetInfo, commit_tmp, fsync_dir, write_json_atomic
from pipette_cli.demos.store import clean, pack, part_path, parts_dir, scan, writing
from pipette_cli.errors import DatasetError, PipetteError
from pipette_cli.specs.task import TaskSpec

log = logging.getLogger(__name__)

LEDGER_FORMAT = "pipette.augment"


def ledger_path(out: Path) -> Path:
    return out.with_name(out.name + ".augment.json")


@dataclass
class AugmentResult:
    out: Path
    report: dict[str, Any]
    new_demos: int = 0
    skipped_demos: int = 0
    interrupted: bool = False
    seconds: float = 0.0
    timings: dict[str, float] = field(default_factory=lambda: {"physics": 0.0, "render": 0.0, "write": 0.0})


def _load_ledger(out: Path, task: TaskSpec, spec: AugmentSpec, source: Path) -> dict[str, Any]:
    path = ledger_path(out)
    fresh = {
        "format": LEDGER_FORMAT,
        "task_id": task.id,
        "input": str(source),
        "spec": spec.model_dump(mode="json"),
        "demos": {},
    }
    if not path.exists():
        if out.exists():
            raise DatasetError(
                f"{out} exists but has no {path.name}: it was not made by `pipette augment`; choose another --output"
            )
        return fresh
    try:
        ledger = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path} is unreadable ({exc}); delete it together with {out} to start over") from None
    if ledger.get("format") != LEDGER_FORMAT or ledger.get("task_id") != task.id:
        raise DatasetError(f"{path} belongs to another task or tool; choose another --output")
    if _decisive(ledger.get("spec")) != _decisive(fresh["spec"]):
        raise DatasetError(
            f"{out} was augmented with other parameters (see {path.name}); rerun with the same options or choose another --output"
        )
    return ledger


def _decisive(spec: Any) -> Any:
    """The spec without its execution-only fields (``batch`` gives the same verdicts either way)."""
    if not isinstance(spec, dict):
        return spec
    return {k: v for k, v in spec.items() if k not in AugmentSpec.EXECUTION_ONLY}


def _drop_unledgered(path: Path, done: set[str]) -> int:
    """Delete pending parts whose source demo is not in the ledger (a crash mid-demo)."""
    folder = parts_dir(path)
    dropped = 0
    if not folder.is_dir():
        return 0
    for part in sorted(folder.glob("episode_*.h5")):
        try:
            with h5py.File(part, "r") as f:
                uid = next(str(g.attrs.get("augment_source_uid", "")) for g in f["episodes"].values())
        except (OSError, KeyError, StopIteration):
            uid = ""
        if uid not in done:
            part.unlink()
            dropped += 1
    for leftover in folder.glob("aug_*.tmp"):
        leftover.unlink()
    return dropped


def check_inputs(task: TaskSpec, source: Path, out: Path, rejected: Path | None) -> DatasetInfo:
    """Refuse a raw file of another task, or outputs that clash, before any work."""
    source, out = Path(source), Path(out)
    if source.resolve() == out.resolve() or (
        rejected is not None and Path(rejected).resolve() in (source.resolve(), out.resolve())
    ):
        raise PipetteError("--input, --output and --rejected must be three different files")
    status = scan(source)
    if status.info is None or not status.episodes:
        raise DatasetError(f"{source} holds no episodes")
    if status.info.task_id != task.id:
        raise DatasetError(f"{source} holds episodes of task {status.info.task_id}, not {task.id}")
    return status.info


def check_robot(task: TaskSpec, info: DatasetInfo, source: Path) -> None:
    """Refuse to replay demos on a robot other than the one that recorded them."""
    if info.embodiment != task.embodiment.robot:
        raise DatasetError(
            f"{source} was recorded on the {info.embodiment}, but the task is set up for the "
            f"{task.embodiment.robot}; place the task on the {info.embodiment} (--robot {info.embodiment})"
        )


def augment(
    task: TaskSpec,
    source: Path,
    out: Path,
    spec: AugmentSpec,
    *,
    rejected: Path | None = None,
    workers: int | None = None,
    executor: Executor = "local",
    address: str | None = None,
    render: bool = True,
    on_start: Callable[[int, int], None] | None = None,
    on_demo: Callable[[DemoResult], None] | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> AugmentResult:
    """Augment every successful demo of ``source`` into ``out`` (see the module doc).

    Raises:
        DatasetError: ``source`` is unreadable or of another task; ``out`` was made with other
            parameters or is of another task or image size.
    """
    source, out = Path(source), Path(out)
    started = time.perf_counter()
    outputs = [out] + ([Path(rejected)] if rejected is not None else [])
    with writing(*outputs):  # a second run on these files stops here
        in_info = check_inputs(task, source, out, rejected)
        check_robot(task, in_info, source)
        size = spec.image_size
        info = dataclasses.replace(in_info, image_height=size, image_width=size) if size else in_info
        for path in outputs:
            have = scan(path).info
            if have is not None and (why := have.mismatch(info)) is not None:
                raise DatasetError(f"cannot write to {path}: {why}")
        ledger = _load_ledger(out, task, spec, source)
        done = set(ledger["demos"])
        for path in outputs:
            clean(scan(path))
            if n := _drop_unledgered(path, done):
                log.warning("%s: dropped %d parts of an unfinished demo; it is redone", path, n)
        source_eps = scan(source).episodes
        next_index = {path: len(scan(path).episodes) for path in outputs}
        jobs = [
            DemoJob(ref.index, ref, parts_dir(out), parts_dir(Path(rejected)) if rejected is not None else None)
            for ref in source_eps
            if ref.summary.uid not in done
        ]
        for path in outputs if jobs else []:
            if (have_eps := scan(path)).episodes and (mixing := mixing_problem(have_eps, task)) is not None:
                raise DatasetError(mixing)
        result = AugmentResult(out, {}, skipped_demos=len(source_eps) - len(jobs))
        if on_start is not None:
            on_start(result.skipped_demos, len(jobs))
        kwargs = dict(task=task, spec=spec, info=info, render=render, attrs=dict(provenance(task)))
        try:
            if jobs:
                for path in outputs:
                    parts_dir(path).mkdir(parents=True, exist_ok=True)
                runs = run_jobs(
                    kwargs, jobs, executor=executor, workers=workers or default_workers(), stop=stop, address=address
                )
                try:
                    for _job, outcome in runs:
                        if outcome is None:
                            result.interrupted = True
                            break
                        rejected_to = Path(rejected) if rejected else None
                        for tmps, dest in ((outcome.kept, out), (outcome.rejected, rejected_to)):
                            for tmp in tmps:
                                assert dest is not None
                                commit_tmp(tmp, part_path(dest, next_index[dest]))
                                next_index[dest] += 1
                        ledger["demos"][outcome.uid] = {
                            "position": outcome.position,
                            "seed": outcome.seed,
                            "status": outcome.status,
                            "detail": outcome.detail,
                            "outcomes": [dataclasses.asdict(o) for o in outcome.outcomes],
                        }
                        write_json_atomic(ledger_path(out), ledger)
                        for key, value in outcome.seconds.items():
                            result.timings[key] += value
                        result.new_demos += 1
                        if on_demo is not None:
                            on_demo(outcome)
                finally:
                    runs.close()
        finally:
            for path in outputs:
                clean(scan(path))
                for leftover in parts_dir(path).glob("aug_*.tmp") if parts_dir(path).is_dir() else []:
                    leftover.unlink()
                pack(path)
                fsync_dir(path.parent)
        if not out.exists():  # nothing kept at all: still leave a valid, empty file
            _empty_file(out, info)
        result.report = yield_report(ledger["demos"])
        result.seconds = time.perf_counter() - started
        return result


def _empty_file(path: Path, info: DatasetInfo) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        info.write(f.attrs)
        f.create_group("episodes")
    commit_tmp(tmp, path)
