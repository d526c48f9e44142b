"""``pipette data``: inspect, edit and replay recorded HDF5 episode files."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.text import Text

from pipette_cli.cli.common import STATE, err_console, out_console, print_json
from pipette_cli.cli.listing import Column, Listing
from pipette_cli.demos.embodiment import on_robot
from pipette_cli.demos.replay import replay_episode
from pipette_cli.demos.store import delete_episode as delete
from pipette_cli.demos.store import episode_arrays, file_size, parts_dir, scan, writing
from pipette_cli.demos.store import pack as pack_parts
from pipette_cli.demos.video import write_episode_video
from pipette_cli.errors import DatasetError, plural
from pipette_cli.registry import load_registry
from pipette_cli.sim.views import AnimationFormat

app = typer.Typer(
    help="Inspect, edit and replay recorded episode files.\n\nExample: pipette data inspect tube.h5",
    no_args_is_help=True,
)


@app.command("inspect")
def inspect(
    file: Annotated[Path, typer.Argument(help="HDF5 file written by `pipette collect`.")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Show a file's task, image size and episodes (seed, steps, outcome), pending parts included.

    Never modifies the file.

    Example: pipette data inspect tube.h5 --json
    """
    status = scan(file)
    if status.info is None:
        raise DatasetError(f"{file}: no such file")
    info = status.info
    episodes: list[dict[str, Any]] = [
        {
            "index": ref.index,
            "seed": ref.summary.seed,
            "source": ref.summary.source,
            "variant": ref.summary.variant,
            "steps": ref.summary.num_steps,
            "success": ref.summary.success,
            "reason": ref.summary.reason,
            "metrics": ref.summary.metrics,
            "pending": ref.pending,
        }
        for ref in status.episodes
    ]
    successes = sum(e["success"] for e in episodes)
    first = episode_arrays(status.episodes[0]) if status.episodes else {}  # every episode holds the same arrays
    arrays = {name: {"shape": list(shape), "dtype": dtype} for name, (shape, dtype) in first.items()}
    varied = any(e["variant"] for e in episodes)
    report = {
        "file": str(file),
        "task_id": info.task_id,
        "embodiment": info.embodiment,
        "instruction": info.instruction,
        "image_size": [info.image_height, info.image_width],
        "cameras": list(info.cameras),
        "control_hz": info.control_hz,
        "vision_hz": info.vision_hz,
        "num_episodes": len(episodes),
        "pending": len(status.pending),
        "successes": successes,
        "success_rate": successes / len(episodes) if episodes else 0.0,
        "steps": sum(e["steps"] for e in episodes),
        "size_mb": round(file_size(file) / 1e6, 3),
        "arrays": arrays,
        "action": (", ".join(info.action_names) if info.action_names else f"{info.action_dim - 1} joint targets (rad)")
        + " (joint targets in rad; gripper 1 open, 0 closed)",
        "episodes": episodes,
    }
    if as_json:
        print_json(report)
        return
    columns = [
        Column("episode", justify="right"),
        Column("seed", justify="right"),
        Column("source"),
        *([Column("variant")] if varied else []),
        Column("steps", justify="right"),
        Column("outcome", wrap=True, min_width=20),
        Column("note"),
    ]
    rows = [
        [
            str(e["index"]),
            str(e["seed"]),
            e["source"],
            *([e["variant"] or "-"] if varied else []),
            str(e["steps"]),
            Text("success", "green") if e["success"] else Text.assemble(("failed", "red"), f" {e['reason']}"),
            "pending" if e["pending"] else "",
        ]
        for e in episodes
    ]
    size = f"{info.image_height}x{info.image_width}"
    out_console.print(
        Listing(f"{file}: {info.task_id} ({info.embodiment}, {size}, {report['size_mb']} MB)", columns, rows)
    )
    err_console.print(
        f"{plural(len(episodes), 'episode')}, {successes} successful, {plural(report['steps'], 'control step')}"
    )
    if arrays:  # what a training or a script reads (docs/data_format.md)
        shapes = ", ".join(
            f"{n} {tuple(a['shape'])} {a['dtype']}" for n, a in arrays.items() if not n.startswith("final")
        )
        err_console.print(f"arrays of episode 0: {shapes}; action = {report['action']}", soft_wrap=True, markup=False)
    if status.pending:
        pending = len(status.pending)
        err_console.print(
            f"{plural(pending, 'episode')} of an interrupted run {'is' if pending == 1 else 'are'} pending in "
            f"{parts_dir(file)}; "
            f"`pipette data pack {file}` (or rerunning collect) moves {'it' if pending == 1 else 'them'} into the file",
            soft_wrap=True,
        )


@app.command("delete-episode")
def delete_episode(
    file: Annotated[Path, typer.Argument(help="HDF5 episode file.")],
    index: Annotated[int, typer.Argument(min=0, help="Episode index (later episodes move down by one).")],
) -> None:
    """Delete one episode; the file is rewritten atomically (unchanged if anything fails).

    Example: pipette data delete-episode tube.h5 3
    """
    summary = delete(file, index)
    err_console.print(f"deleted episode {index} (seed {summary.seed}) from {file}", soft_wrap=True)


@app.command("pack")
def pack(file: Annotated[Path, typer.Argument(help="HDF5 episode file.")]) -> None:
    """Move the episodes an interrupted `pipette collect` left in FILE.parts into the file.

    Example: pipette data pack tube.h5
    """
    with writing(file):
        if scan(file).info is None:
            raise DatasetError(f"{file}: no such file")
        packed = pack_parts(file)
    err_console.print(f"packed {plural(packed, 'pending episode')} into {file}", soft_wrap=True)


@app.command("video")
def video(
    file: Annotated[Path, typer.Argument(help="HDF5 episode file.")],
    episode: Annotated[
        list[int] | None, typer.Option("--episode", "-e", help="Episode index (repeatable; default 0).")
    ] = None,
    all_episodes: Annotated[bool, typer.Option("--all", help="Every episode of the file.")] = False,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="A .gif or .mp4 file (one episode), or a folder (default: the current one) for "
            "<file>_episode_NNNN.<format>.",
        ),
    ] = None,
    video_format: Annotated[
        AnimationFormat, typer.Option("--format", help="The videos' format when --out is a folder.")
    ] = AnimationFormat.gif,
    camera: Annotated[
        list[str] | None,
        typer.Option("--camera", "-c", help="A view to show: top, main or wrist (repeatable; default every one)."),
    ] = None,
    fps: Annotated[float, typer.Option("--fps", help="Frames per second, played in real time.")] = 10.0,
    scale: Annotated[
        int, typer.Option("--scale", help="Enlarge each view this many times (0: small ones to 128 px).")
    ] = 0,
) -> None:
    """Write recorded episodes as GIF or MP4 videos: the camera views side by side, labelled, in real time.

    Works on raw and augmented files alike (an augmented episode shows its perturbed views). Never
    modifies the file.

    Example: pipette data video tube.h5 --episode 3 --out ep3.mp4
    """
    status = scan(file)
    if status.info is None:
        raise DatasetError(f"{file}: no such file")
    indices = [ref.index for ref in status.episodes] if all_episodes else (episode or [0])
    for index in indices:
        status.episode(index)  # every range checked before anything is written
    to_file = out is not None and out.suffix != ""
    if to_file and len(indices) > 1:
        raise DatasetError(f"--out {out}: one file for {plural(len(indices), 'episode')}; give a folder instead")
    folder = out or Path(".")
    for index in indices:
        target = (
            out if out is not None and to_file else folder / f"{file.stem}_episode_{index:04d}.{video_format.value}"
        )
        written = write_episode_video(status, index, target, cameras=camera or (), fps=fps, scale=scale)
        ref = status.episode(index)
        outcome = "success" if ref.summary.success else f"failed ({ref.summary.reason})"
        variant = f", {ref.summary.variant}" if ref.summary.variant else ""
        out_console.print(f"episode {index} (seed {ref.summary.seed}{variant}, {outcome}) -> {written}", soft_wrap=True)


@app.command("replay")
def replay(
    file: Annotated[Path, typer.Argument(help="HDF5 episode file.")],
    episode: Annotated[int, typer.Option("--episode", "-e", help="Episode index.")] = 0,
    check: Annotated[
        bool, typer.Option("--check", help="Exit 1 unless every state and the outcome are reproduced bit-exactly.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Re-execute an episode's actions from its recorded initial state and compare.

    Resets the task with the episode's seed, restores the recorded simulator state of step 0,
    applies the recorded actions and compares every recorded simulator state byte for byte
    and the final verdict. Never modifies the file.

    Example: pipette data replay tube.h5 --episode 0 --check
    """
    status = scan(file)
    if status.info is None:
        raise DatasetError(f"{file}: no such file")
    status.episode(episode)  # range check before building the scene

    task = on_robot(load_registry(STATE.registry_dirs).get(status.info.task_id), status.info.embodiment)
    report = replay_episode(file, episode, task)
    if report.spec_changed:
        err_console.print(
            f"[yellow]warning:[/yellow] the {task.id} spec changed since episode {episode} was recorded", soft_wrap=True
        )
    if as_json:
        print_json(report.as_dict())
    else:
        states = (
            f"all {plural(report.states_compared, 'state')} bit-exact"
            if report.states_equal
            else f"states differ from step {report.first_mismatch} on (max |diff| {report.max_abs_diff:.3g}"
            + ("" if report.code_changed is None else f"; {report.code_changed}")
            + ")"
        )
        outcome = "same outcome" if report.outcome_equal else f"outcome {report.replayed} != recorded {report.recorded}"
        verdict = "success" if report.replayed.get("success") else f"failed ({report.replayed.get('reason')})"
        out_console.print(
            f"episode {episode} (seed {report.seed}, {plural(report.steps, 'step')}): {verdict}; {states}; {outcome}"
        )
    if check and not report.ok:
        raise DatasetError(f"{file}: episode {episode} does not replay exactly")
