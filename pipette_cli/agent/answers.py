"""Questions the agent answers itself, from the data: which tasks, how many demos, what score.

Each answer is a typer command of a small app that only the agent's catalog reads (so an
answer is a plan step like any other, checked by the same validator), and a function that
computes the answer in this process: from the task registry, from HDF5 demo files (read with
:mod:`pipette_cli.demos.store`) and from the ``summary.json`` / ``episode_XXXX.json`` files
``pipette eval --out`` writes. They only read.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import typer

from pipette_cli.agent.vocabulary import load_vocabulary
from pipette_cli.demos.store import scan
from pipette_cli.errors import DatasetError, PipetteError, plural
from pipette_cli.registry import Registry, load_registry

app = typer.Typer(add_completion=False)
SEARCH_DEPTH = 4
"""How deep under the working directory the answers look for demo files and evaluation results."""
_SKIP = {".git", ".venv", "venv", "node_modules", "__pycache__", "site-packages", ".cache", "wandb"}


def find_files(root: Path, match: Callable[[str], bool], depth: int = SEARCH_DEPTH) -> list[Path]:
    """Files under ``root`` (at most ``depth`` folders down, hidden and tool folders skipped)
    whose name ``match`` accepts: where `pipette collect`, `eval` and `demo` wrote their output."""
    found: list[Path] = []
    base = len(root.resolve().parts)
    for folder, subfolders, files in os.walk(root):
        here = Path(folder)
        if len(here.resolve().parts) - base >= depth:
            subfolders[:] = []
        subfolders[:] = sorted(d for d in subfolders if d not in _SKIP and not d.startswith("."))
        found += [here / f for f in sorted(files) if match(f)]
    return found


@dataclass(frozen=True)
class Answer:
    """What the agent prints for a question: a sentence, an optional table, and the data."""

    text: str
    columns: list[str] = field(default_factory=list)
    rows: list[list[str]] = field(default_factory=list)
    data: dict[str, Any] = field(default_factory=dict)


@app.command("tasks")
def tasks(
    about: Annotated[
        str | None, typer.Option("--about", help="Words the tasks must match (objects, actions, tags, robots).")
    ] = None,
) -> Answer:
    """Which registered tasks there are (optionally about something).

    Example: answer tasks --about "piper"
    """
    return tasks_in(load_registry(), about)


def tasks_in(registry: Registry, about: str | None = None) -> Answer:
    """The tasks of ``registry`` about ``about`` (every task without it)."""
    # deferred: the task index and the asset vocabulary (~20 ms; `pipette --help` imports this module)
    from pipette_cli.agent.tasks import TaskIndex

    index = TaskIndex(registry, load_vocabulary())
    ids, _ = index.filter(about or "")
    terms = index.filter_words(about or "")
    rows = [[tid, registry.get(tid).embodiment.robot, registry.get(tid).instruction] for tid in ids]
    what = f" about {', '.join(terms)}" if terms else ""
    text = f"{len(ids)} task{'s' if len(ids) != 1 else ''}{what}" if ids else f"no registered task is{what or ' known'}"
    return Answer(text, ["task", "robot", "instruction"], rows, {"count": len(ids), "tasks": ids, "about": terms})


def _demo_files(file: Path | None, task: str | None) -> list[Path]:
    if file is not None:
        if not file.exists() and not Path(f"{file}.parts").is_dir():
            raise DatasetError(f"{file}: no such file")
        return [file]
    found = find_files(Path("."), lambda name: name.endswith((".h5", ".hdf5")))
    if not found:
        raise DatasetError("no demo files under this folder; name the file (`pipette collect --out FILE` writes one)")
    return found


@app.command("demos")
def demos(
    file: Annotated[
        Path | None, typer.Option("--file", help="HDF5 demo file (default: every one under this folder).")
    ] = None,
    task_id: Annotated[str | None, typer.Option("--task", help="Only files of this task.")] = None,
) -> Answer:
    """How many demos a file holds (successful, failed, pending).

    Example: answer demos --file data/PickUpTestTube.h5
    """
    rows: list[list[str]] = []
    files: list[dict[str, Any]] = []
    for path in _demo_files(file, task_id):
        try:
            status = scan(path)
        except PipetteError:
            if file is not None:
                raise
            continue  # a stray file under data/ that is not a Pipette recording
        if status.info is None or (task_id and status.info.task_id != task_id):
            continue
        episodes = status.episodes
        ok = sum(ref.summary.success for ref in episodes)
        failed = [ref.index for ref in episodes if not ref.summary.success]
        files.append(
            {
                "file": str(path),
                "task_id": status.info.task_id,
                "episodes": len(episodes),
                "successful": ok,
                "failed": len(episodes) - ok,
                "failed_episodes": failed,
                "pending": len(status.pending),
                "image_size": status.info.image_height,
            }
        )
        rows.append(
            [
                str(path),
                status.info.task_id,
                str(len(episodes)),
                str(ok),
                str(len(episodes) - ok),
                str(len(status.pending)),
            ]
        )
    if not files:
        raise DatasetError(f"no demo files of {task_id} under this folder" if task_id else "no demo files found")
    total = sum(f["episodes"] for f in files)
    if len(files) == 1:
        f = files[0]
        pending = f", {f['pending']} of them pending" if f["pending"] else ""
        which = (
            f" ({'episode' if f['failed'] == 1 else 'episodes'} {_indices(f['failed_episodes'])})"
            if f["failed"]
            else ""
        )
        text = (
            f"{f['file']} holds {plural(f['episodes'], 'demo')} of {f['task_id']}: {f['successful']} successful, "
            f"{f['failed']} failed{which}{pending}"
        )
    else:
        text = f"{plural(total, 'demo')} in {len(files)} files"
    return Answer(
        text, ["file", "task", "demos", "successful", "failed", "pending"], rows, {"total": total, "files": files}
    )


def _indices(indices: list[int], shown: int = 12) -> str:
    """ "3, 7, 9" (the first ``shown``, then how many more)."""
    more = f" and {len(indices) - shown} more" if len(indices) > shown else ""
    return ", ".join(map(str, indices[:shown])) + more


def _summaries(folder: Path) -> list[dict[str, Any]]:
    """Evaluation results under ``folder``: each summary.json, and folders holding only
    episode_XXXX.json files (an interrupted evaluation), newest first."""
    results = []
    episodes = find_files(folder, lambda name: name.startswith("episode_") and name.endswith(".json"))
    logged = {p.parent for p in episodes}
    for summary in find_files(folder, lambda name: name == "summary.json"):
        try:
            data = json.loads(summary.read_text())
            results.append(
                {
                    "folder": str(summary.parent),
                    "task": data["task"],
                    "policy": data.get("policy_type", "?"),
                    "version": data.get("dataset_version", "raw"),
                    "episodes": int(data["episodes"]),
                    "successes": int(data.get("successes", round(data["success_rate"] * data["episodes"]))),
                    "success_rate": float(data["success_rate"]),
                    "complete": True,
                    "mtime": summary.stat().st_mtime,
                }
            )
        except (OSError, ValueError, KeyError, TypeError) as exc:
            if summary.parent not in logged:
                continue  # another tool's summary.json; an evaluation's sits beside its episode logs
            raise DatasetError(f"{summary}: not an evaluation summary ({exc})") from None
    summarized = {r["folder"] for r in results}
    for parent in logged - {Path(f) for f in summarized}:
        logs = [json.loads(p.read_text()) for p in sorted(parent.glob("episode_*.json"))]
        ok = sum(bool(log.get("success")) for log in logs)
        results.append(
            {
                "folder": str(parent),
                "task": logs[0].get("task", "?"),
                "policy": logs[0].get("policy_type", "?"),
                "version": "?",
                "episodes": len(logs),
                "successes": ok,
                "success_rate": ok / len(logs),
                "complete": False,
                "mtime": max(p.stat().st_mtime for p in parent.glob("episode_*.json")),
            }
        )
    return sorted(results, key=lambda r: -r["mtime"])


@app.command("score")
def score(
    folder: Annotated[
        Path | None,
        typer.Option("--folder", help="Evaluation output folder (default: the newest under this folder)."),
    ] = None,
    task_id: Annotated[str | None, typer.Option("--task", help="Only evaluations of this task.")] = None,
) -> Answer:
    """What the last evaluation scored (success rate, from `pipette eval --out` files).

    Example: answer score --folder evals/PickUpTestTube
    """
    root = folder or Path(".")
    if not root.is_dir():
        raise DatasetError(f"{root}: no such folder; evaluation results are where `pipette eval --out DIR` wrote them")
    results = [r for r in _summaries(root) if not task_id or r["task"] == task_id]
    if not results:
        which = f" of {task_id}" if task_id else ""
        raise DatasetError(
            f"no evaluation results{which} under {root}/ (write them with `pipette eval TASK ... --out DIR`)"
        )
    last = results[0]
    partial = "" if last["complete"] else " (interrupted: episode files only)"
    text = (
        f"{last['folder']}: {last['task']} with {last['policy']} ({last['version']}) scored "
        f"{last['successes']}/{last['episodes']} = {100 * last['success_rate']:.0f} %{partial}"
    )
    rows = [
        [
            r["folder"],
            r["task"],
            r["policy"],
            r["version"],
            f"{r['successes']}/{r['episodes']}",
            f"{100 * r['success_rate']:.0f} %",
        ]
        for r in results[:10]
    ]
    data = {k: v for k, v in last.items() if k != "mtime"}
    return Answer(
        text,
        ["folder", "task", "policy", "data", "successes", "success rate"],
        rows,
        {"last": data, "count": len(results)},
    )


@app.command("robots")
def robots() -> Answer:
    """Which robots tasks can run on (`--robot` of collect, augment, eval; `with the UR5e` in new-task):
    the arm's joints, the gripper's opening, the reach and payload, and how many tasks name each.

    Example: answer robots
    """
    from pipette_cli.specs.robot import load_robot_specs  # deferred: the robot specs (`pipette --help` imports this)

    registry = load_registry()
    named = Counter(registry.get(t).embodiment.robot for t in registry.ids())
    rows, data = [], []
    for name, spec in sorted(load_robot_specs().items()):
        own = named[name]
        item = {
            "robot": name,
            "short_name": spec.aliases[0] if spec.aliases else name,
            "arm_joints": spec.arm_dof,
            "gripper_opening_mm": round(1000 * spec.gripper.max_opening),
            "reach_m": spec.reach,
            "payload_kg": spec.payload_kg,
            "tasks": own,
        }
        data.append(item)
        rows.append(
            [
                name,
                str(item["short_name"]),
                str(spec.arm_dof),
                f"{item['gripper_opening_mm']} mm",
                f"{spec.reach:.2f} m",
                f"{spec.payload_kg:g} kg",
                str(own),
            ]
        )
    text = (
        f"{plural(len(rows), 'robot')}: {', '.join(r[0] for r in rows)}; a task runs on another robot with --robot "
        "(check its expert there first: pipette experts check TASK --robot NAME)"
    )
    return Answer(
        text,
        ["robot", "short", "joints", "opens", "reach", "payload", "tasks"],  # reads at 80 columns
        rows,
        {"robots": data},
    )


ANSWERS = {"answer tasks": tasks, "answer demos": demos, "answer score": score, "answer robots": robots}


def answer(command: str, args: dict[str, Any], registry: Registry | None = None) -> Answer:
    """Compute the answer of a checked plan step (``command`` is ``answer tasks`` etc.);
    ``registry`` is the one the plan was made with (default: the built-in one)."""
    values = {k: Path(v) if k in ("file", "folder") and v is not None else v for k, v in args.items()}
    if command == "answer tasks" and registry is not None:
        return tasks_in(registry, **values)  # type: ignore[arg-type]
    return ANSWERS[command](**values)  # type: ignore[operator]  # each takes its own checked arguments
