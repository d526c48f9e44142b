"""``pipette augment``: success-verified simulation augmentation of recorded demos (paper A.7)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from pipette_cli.augment.specs import AugmentSpec, default_atoms, make_variants
from pipette_cli.cli.common import (
    RobotOption,
    err_console,
    load_task,
    out_console,
    print_json,
    show_progress,
    spec_default,
    spec_help,
)
from pipette_cli.demos.collect import deferred_interrupt
from pipette_cli.demos.embodiment import resolve_robot
from pipette_cli.errors import PipetteError, SpecError, plural
from pipette_cli.specs.perturbations import (
    CameraPoseSpec,
    DistractorSpec,
    JointNoiseSpec,
    LightingSpec,
    ObjectPoseSpec,
    SpeedSpec,
    SurfaceColorSpec,
)


def _table(report: dict) -> Table:
    table = Table(title=f"yield: {report['kept']}/{report['attempts']} kept ({report['yield']:.0%})")
    for col in ("variant", "magnitude", "attempts", "kept", "yield", "failures"):
        table.add_column(col, justify="right" if col in ("attempts", "kept", "yield") else "left", overflow="fold")
    for row in report["variants"]:
        failures = ", ".join(f"{k} {v}" for k, v in row["failures"].items())
        if row.get("failed_at_stage"):
            failures += " (at stage " + ", ".join(f"{k}: {v}" for k, v in row["failed_at_stage"].items()) + ")"
        table.add_row(
            row["variant"], row["magnitude"], str(row["attempts"]), str(row["kept"]), f"{row['yield']:.0%}", failures
        )
    return table


ATOM_OPTIONS = {
    "light": ("light_scale", "light_jitter"),
    "speed": ("speed", "rho", "interpolation"),
    "noise": ("noise_sigma", "noise_clip", "noise_window", "noise_corrective"),
    "cam": ("camera", "camera_radius", "wrist_radius"),
    "object": ("object_xy", "object_yaw", "object_range"),
    "table": ("table_blend",),
    "clutter": ("distractors",),
}
"""The options of ``augment`` that set each atom's perturbation."""


def _given_options(ctx: typer.Context) -> dict[str, list[str]]:
    """Atom -> the flags of its options this command line gives."""
    flags = {p.name: p.opts[0] for p in ctx.command.params}
    given = {
        atom: [flags[n] for n in names if getattr(ctx.get_parameter_source(n), "name", None) == "COMMANDLINE"]
        for atom, names in ATOM_OPTIONS.items()
    }
    return {atom: found for atom, found in given.items() if found}


def augment(
    ctx: typer.Context,
    task_id: Annotated[str, typer.Argument(help="Task id, e.g. PickUpTestTube.")],
    input: Annotated[Path, typer.Option("--input", "-i", help="Raw demos (HDF5 from `pipette collect`).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Augmented file to create or resume.")],
    variants: Annotated[
        str,
        typer.Option(
            "--variants",
            help="Comma list: paper (light, speed, light+speed, each +cam), original, or atoms joined by + from light, speed, noise, cam, object, table, clutter; NAME*N: N variants of NAME, each its own draw.",
        ),
    ] = "paper",
    light_scale: Annotated[float, typer.Option("--light-scale", help=spec_help(LightingSpec, "scale"))] = spec_default(
        LightingSpec, "scale"
    ),
    light_jitter: Annotated[
        float, typer.Option("--light-jitter", help=spec_help(LightingSpec, "jitter"))
    ] = spec_default(LightingSpec, "jitter"),
    speed: Annotated[float, typer.Option("--speed", help=spec_help(SpeedSpec, "factor"))] = spec_default(
        SpeedSpec, "factor"
    ),
    rho: Annotated[float, typer.Option("--rho", help=spec_help(SpeedSpec, "rho"))] = spec_default(SpeedSpec, "rho"),
    interpolation: Annotated[str, typer.Option("--interpolation", help="catmull_rom or linear.")] = spec_default(
        SpeedSpec, "interpolation"
    ),
    noise_sigma: Annotated[
        float, typer.Option("--noise-sigma", help=spec_help(JointNoiseSpec, "sigma"))
    ] = spec_default(JointNoiseSpec, "sigma"),
    noise_clip: Annotated[float, typer.Option("--noise-clip", help=spec_help(JointNoiseSpec, "bound"))] = spec_default(
        JointNoiseSpec, "bound"
    ),
    noise_window: Annotated[
        int, typer.Option("--noise-window", min=1, help=spec_help(JointNoiseSpec, "window"))
    ] = spec_default(JointNoiseSpec, "window"),
    noise_corrective: Annotated[
        bool, typer.Option("--noise-corrective", help=spec_help(JointNoiseSpec, "corrective"))
    ] = spec_default(JointNoiseSpec, "corrective"),
    camera: Annotated[
        str,
        typer.Option(
            "--camera", help=spec_help(CameraPoseSpec, "camera", "Camera to jitter: random, all, top, main or wrist")
        ),
    ] = spec_default(CameraPoseSpec, "camera"),
    camera_radius: Annotated[
        float, typer.Option("--camera-radius", help=spec_help(CameraPoseSpec, "radius", "Ball radius for top/main"))
    ] = spec_default(CameraPoseSpec, "radius"),
    wrist_radius: Annotated[
        float,
        typer.Option(
            "--wrist-radius", help=spec_help(CameraPoseSpec, "wrist_radius", "Ball radius for the wrist camera")
        ),
    ] = spec_default(CameraPoseSpec, "wrist_radius"),
    object_xy: Annotated[
        float,
        typer.Option("--object-xy", help=spec_help(ObjectPoseSpec, "xy", "Object shift range for the object variant")),
    ] = spec_default(ObjectPoseSpec, "xy"),
    object_yaw: Annotated[
        float,
        typer.Option(
            "--object-yaw", help=spec_help(ObjectPoseSpec, "yaw_deg", "Object yaw range (deg) for the object variant")
        ),
    ] = spec_default(ObjectPoseSpec, "yaw_deg"),
    object_range: Annotated[
        float | None,
        typer.Option("--object-range", help=spec_help(ObjectPoseSpec, "task_range", "e.g. 1.0: the task's own range")),
    ] = spec_default(ObjectPoseSpec, "task_range"),
    table_blend: Annotated[
        float, typer.Option("--table-blend", help=spec_help(SurfaceColorSpec, "blend"))
    ] = spec_default(SurfaceColorSpec, "blend"),
    distractors: Annotated[
        int | None, typer.Option("--distractors", min=1, max=6, help=spec_help(DistractorSpec, "count", "atom clutter"))
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help=spec_help(AugmentSpec, "seed", "Base seed"))] = spec_default(
        AugmentSpec, "seed"
    ),
    image_size: Annotated[
        int, typer.Option("--image-size", min=0, help="Square image side (0: the input's).")
    ] = spec_default(AugmentSpec, "image_size"),
    rejected: Annotated[
        Path | None, typer.Option("--rejected", help="Also write the failed variants to this file.")
    ] = None,
    workers: Annotated[
        int | None, typer.Option("--workers", "-w", min=1, help="Worker processes (default: all cores).")
    ] = None,
    executor: Annotated[str, typer.Option("--executor", help="local (process pool) or ray.")] = "local",
    address: Annotated[str | None, typer.Option("--address", help="Ray cluster address (--executor ray).")] = None,
    report: Annotated[Path | None, typer.Option("--report", help="Write the yield report JSON here.")] = None,
    target_yield: Annotated[
        float | None,
        typer.Option(
            "--target-yield",
            help="Shrink all magnitudes (x0.7 per round, physics only, first 3 demos) until this fraction of variants passes.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the yield report as JSON.")] = False,
    robot: RobotOption = None,
) -> None:
    """Replay every demo under perturbations (lighting, speed, joint noise, camera pose, object
    pose), re-simulate without rendering, keep only variants the task's evaluator passes, then
    render the kept ones from their recorded states. Resumable; Ctrl-C safe (docs/augmentation.md).

    The demos replay on the robot that recorded them (the input file's); --robot, when given,
    must name that robot.

    Example: pipette augment PickUpTestTube --input raw.h5 --output aug.h5 --workers 4
    """
    # deferred: the augmentation pipeline (~35 ms: multiprocessing, mujoco.rollout, 12 modules), out of `pipette --help`
    from pipette_cli.augment.calibrate import calibrate
    from pipette_cli.augment.run import augment as run_augment
    from pipette_cli.augment.run import check_inputs

    if executor not in ("local", "ray"):
        raise PipetteError(f"--executor must be local or ray, not {executor!r}")
    atoms = default_atoms(
        light={"scale": light_scale, "jitter": light_jitter},
        speed={"factor": speed, "rho": rho, "interpolation": interpolation},
        noise={"sigma": noise_sigma, "bound": noise_clip, "window": noise_window, "corrective": noise_corrective},
        cam={"camera": camera, "radius": camera_radius, "wrist_radius": wrist_radius},
        object={"xy": object_xy, "yaw_deg": object_yaw, "task_range": object_range},
        table={"blend": table_blend},
        clutter={"count": distractors},
    )
    names = [n.strip() for n in variants.split(",") if n.strip()]
    if not names:
        raise SpecError("--variants is empty")
    spec = AugmentSpec(variants=make_variants(names, atoms), seed=seed, image_size=image_size)
    for atom, given in _given_options(ctx).items():  # "--noise-window 15 --variants light" would change nothing
        if not any(v.get(type(atoms[atom])) for v in spec.variants):
            raise SpecError(
                f"{', '.join(given)} {'changes' if len(given) == 1 else 'change'} {atom} variants, and --variants "
                f"{variants!r} has none: add {atom} to a variant (e.g. --variants original,{atom}*5 or object+{atom})"
            )

    recorded = check_inputs(load_task(task_id), input, output, rejected).embodiment
    if robot is not None and resolve_robot(robot).name != recorded:
        raise PipetteError(
            f"--robot {robot}: {input} was recorded on the {recorded}; augmentation replays demos on the "
            "robot that recorded them (record new ones with `pipette collect --robot`)"
        )
    task = load_task(task_id, recorded)
    if target_yield is not None:
        found = calibrate(task, input, spec, target_yield)
        for row in found.rounds:
            err_console.print(
                f"calibration: magnitudes x{row['factor']:.2f} -> yield {row['yield']:.0%} ({int(row['kept'])}/{int(row['attempts'])})"
            )
        spec = found.spec
    progress = show_progress(f"augment {task.short_name}", "demos")
    kept = tried = 0

    def started(skipped: int, todo: int) -> None:
        if skipped:
            err_console.print(f"{output}: {plural(skipped, 'demo')} already augmented; {todo} to go", soft_wrap=True)
        progress.start(todo)

    def finished(result) -> None:
        nonlocal kept, tried
        kept += sum(o.kept for o in result.outcomes)
        tried += len(result.outcomes)
        if result.status != "ok":
            err_console.print(f"demo {result.position} skipped: {result.detail}", soft_wrap=True)
        progress.update(advance=1, note=f"[green]{kept} kept[/green] of {tried}")

    try:
        with deferred_interrupt() as interrupted:
            result = run_augment(
                task,
                input,
                output,
                spec,
                rejected=rejected,
                workers=workers,
                executor=executor,  # type: ignore[arg-type]
                address=address,
                on_start=started,
                on_demo=finished,
                stop=interrupted,
            )
    finally:
        progress.stop()
    data = {**result.report, "output": str(output), "seconds": round(result.seconds, 2)}
    if report is not None:
        report.write_text(json.dumps(data, indent=2))
    if as_json:
        print_json(data)
    else:
        out_console.print(_table(result.report))
        skipped = result.report["demos_skipped"]
        if skipped:
            out_console.print(f"demos skipped: {', '.join(f'{k} {v}' for k, v in skipped.items())}")
        out_console.print(
            f"{output}: {plural(result.report['kept'], 'episode')} kept ({plural(result.new_demos, 'demo')} augmented now)"
        )
    if result.interrupted:
        err_console.print("interrupted; run the same command again to resume", soft_wrap=True)
        raise typer.Exit(interrupted.exit_code)
