"""``pipette convert`` (HDF5 episodes -> LeRobot dataset) and ``pipette data stats`` (its summary)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pipette_cli.cli.common import err_console, out_console, print_json, show_progress, spec_default, spec_help
from pipette_cli.cli.data import app as data_app
from pipette_cli.cli.listing import Column, Listing
from pipette_cli.demos.store import scan
from pipette_cli.errors import DatasetError, plural
from pipette_cli.lerobot.convert import ConvertOptions, DatasetVersion, default_root, slug
from pipette_cli.lerobot.convert import convert as run_convert
from pipette_cli.lerobot.frames import FrameFilter
from pipette_cli.lerobot.stats import dataset_stats


def convert(
    inputs: Annotated[list[Path], typer.Argument(help="HDF5 files written by `pipette collect` (or augmentation).")],
    repo_id: Annotated[
        str | None,
        typer.Option("--repo-id", help="LeRobot repo id OWNER/NAME (default local/<task>_<version>); never pushed."),
    ] = None,
    root: Annotated[
        Path | None, typer.Option("--root", help="Dataset folder to create (default datasets/<task>/<version>).")
    ] = None,
    fps: Annotated[int, typer.Option("--fps", min=1, help=spec_help(ConvertOptions, "fps"))] = spec_default(
        ConvertOptions, "fps"
    ),
    frame_filter: Annotated[
        FrameFilter, typer.Option("--frame-filter", help=spec_help(ConvertOptions, "frame_filter"))
    ] = spec_default(ConvertOptions, "frame_filter"),
    video: Annotated[bool, typer.Option("--video/--images", help=spec_help(ConvertOptions, "video"))] = spec_default(
        ConvertOptions, "video"
    ),
    dataset_version: Annotated[
        str, typer.Option("--dataset-version", help=spec_help(ConvertOptions, "dataset_version"))
    ] = spec_default(ConvertOptions, "dataset_version").value,
    include_failed: Annotated[
        bool, typer.Option("--include-failed", help=spec_help(ConvertOptions, "include_failed"))
    ] = spec_default(ConvertOptions, "include_failed"),
    allow_mixed: Annotated[
        bool, typer.Option("--allow-mixed", help=spec_help(ConvertOptions, "allow_mixed"))
    ] = spec_default(ConvertOptions, "allow_mixed"),
    allow_mixed_robots: Annotated[
        bool, typer.Option("--allow-mixed-robots", help=spec_help(ConvertOptions, "allow_mixed_robots"))
    ] = spec_default(ConvertOptions, "allow_mixed_robots"),
    overwrite: Annotated[bool, typer.Option("--overwrite", help=spec_help(ConvertOptions, "overwrite"))] = spec_default(
        ConvertOptions, "overwrite"
    ),
    vcodec: Annotated[str, typer.Option("--vcodec", help=spec_help(ConvertOptions, "vcodec"))] = spec_default(
        ConvertOptions, "vcodec"
    ),
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable result.")] = False,
) -> None:
    """Convert recorded episodes into a LeRobot dataset (written with LeRobot's own API, offline).

    Keeps successful episodes, one frame per fresh camera frame (10 Hz), with the three camera
    views, the state, the action and the instruction. The dataset is built beside --root and
    renamed into place only when complete.

    Example: pipette convert tube.h5   (-> datasets/pipette_PickUpTestTube-v1/raw, where `pipette train` looks)
    """
    try:
        version = DatasetVersion(dataset_version)
    except ValueError:
        raise DatasetError(f"--dataset-version must be raw or augmented, not {dataset_version!r}") from None
    if repo_id is None or root is None:
        first = scan(inputs[0]).info
        if first is None:
            raise DatasetError(f"{inputs[0]}: no such file")
        repo_id = repo_id or f"local/{slug(first.task_id).replace('/', '_')}_{version.value}"
        root = root or default_root(first.task_id, version)
    options = ConvertOptions(
        repo_id=repo_id,
        root=root,
        fps=fps,
        frame_filter=frame_filter,
        video=video,
        dataset_version=version,
        include_failed=include_failed,
        allow_mixed=allow_mixed,
        allow_mixed_robots=allow_mixed_robots,
        overwrite=overwrite,
        vcodec=vcodec,
    )
    with show_progress("convert", "episodes") as progress:

        def planned(plan) -> None:
            progress.start(len(plan.episodes))
            if plan.skipped:
                progress.print(f"skipping {len(plan.skipped)} failed episodes (--include-failed keeps them)")

        result = run_convert(
            inputs, options, on_plan=planned, on_episode=lambda done, total: progress.update(done, total=total)
        )
    report = {
        "root": str(result.root),
        "repo_id": result.repo_id,
        "dataset_version": version.value,
        "episodes": result.episodes,
        "frames": result.frames,
        "skipped_failed": result.skipped,
        "seconds": round(result.seconds, 3),
        "frames_per_s": round(result.frames_per_s, 2),
    }
    if as_json:
        print_json(report)
        return
    out_console.print(
        f"{result.root}: {plural(result.episodes, 'episode')}, {plural(result.frames, 'frame')} at {fps} Hz "
        f"({plural(result.skipped, 'failed episode')} skipped), {result.frames_per_s:.1f} frames/s"
    )


def _values(values: list[float] | None) -> str:
    """Per-dimension values, three significant digits each (``-`` for none)."""
    return "-" if values is None else " ".join(f"{x:.3g}" for x in values)


@data_app.command("stats")
def stats(
    root: Annotated[Path, typer.Argument(help="LeRobot dataset folder (the --root of `pipette convert`).")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Show a LeRobot dataset's episodes, frames, per-feature ranges and success provenance.

    Example: pipette data stats datasets/pipette_PickUpTestTube-v1/raw --json
    """
    report = dataset_stats(root)
    if as_json:
        print_json(report)
        return
    out_console.print(
        f"{root}: {plural(report['episodes'], 'episode')}, {plural(report['frames'], 'frame')} at {report['fps']} Hz "
        f"(episode length {report['episode_length']['min']}..{report['episode_length']['max']}), "
        f"{'video' if report['video'] else 'images'}, robot {report['robot_type']}"
    )
    columns = [
        Column("feature"),
        Column("dtype"),
        Column("shape"),
        Column("min", wrap=True, min_width=12),
        Column("max", wrap=True, min_width=12),
    ]
    vectors = {name: f for name, f in report["features"].items() if len(f.get("names") or ()) > 1}
    rows = [
        [name, f["dtype"], "x".join(map(str, f["shape"]))]
        + (["per dimension below"] * 2 if name in vectors else [_values(f.get("min")), _values(f.get("max"))])
        for name, f in report["features"].items()
    ]
    out_console.print(Listing("features", columns, rows))
    if vectors:  # one row per dimension, named: readable at any width
        dims = [Column("feature"), Column("dim"), Column("name"), Column("min"), Column("mean"), Column("max")]
        out_console.print(
            Listing(
                "dimensions",
                dims,
                [
                    [
                        name,
                        str(i),
                        dim,
                        *(_values(None if f.get(k) is None else [f[k][i]]) for k in ("min", "mean", "max")),
                    ]
                    for name, f in vectors.items()
                    for i, dim in enumerate(f["names"])
                ],
            )
        )
    prov = report.get("provenance")
    if prov:
        reasons = ", ".join(f"{k} {v}" for k, v in prov["failure_reasons"].items())
        sources = ", ".join(f"{k} {v}" for k, v in prov["sources"].items())
        perturbed, originals = prov["perturbed"], prov["originals"]
        variants = (
            f"{plural(perturbed, 'perturbed variant')} and {plural(originals, 'unperturbed original')} (re-rendered); "
            if perturbed or originals
            else ""
        )
        out_console.print(
            f"{prov['dataset_version']} dataset: {prov['successful']} successful, {prov['failed']} failed"
            f"{f' ({reasons})' if reasons else ''}; {plural(prov['skipped_failed'], 'failed episode')} left out; "
            f"sources: {sources}; {variants}from {plural(len(prov['files']), 'file')}"
        )
    else:
        err_console.print("no meta/pipette.json: not converted by Pipette, success provenance unknown")
