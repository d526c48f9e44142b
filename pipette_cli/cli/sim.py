"""``pipette sim``: render a task's three views, measure step and render rates, view it."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from pipette_cli.cli.common import RobotOption, err_console, load_task, out_console, print_json, spec_default
from pipette_cli.errors import PipetteError
from pipette_cli.sim.env import PipetteEnv
from pipette_cli.sim.render import PROFILES
from pipette_cli.sim.views import views_sheet
from pipette_cli.sim.world import World
from pipette_cli.specs.task import CamerasSpec

IMAGE_SIZE_HELP = f"Square image side in pixels (default: the task's cameras, {spec_default(CamerasSpec, 'width')})."

app = typer.Typer(
    help="Build, render and time task scenes.\n\nExample: pipette sim render PickUpTestTube --out views.png",
    no_args_is_help=True,
)


def save_png(image: np.ndarray, path: Path) -> None:
    from PIL import Image  # deferred: PIL (~15 ms)

    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(image).save(path)


@app.command("render")
def render(
    task_id: Annotated[str, typer.Argument(help="Task id.")],
    seed: Annotated[int, typer.Option("--seed", help="Episode seed (initial-state randomisation).")] = 0,
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG to write.")] = Path("views.png"),
    image_size: Annotated[int | None, typer.Option("--image-size", help=IMAGE_SIZE_HELP)] = None,
    profile: Annotated[str, typer.Option("--profile", help=f"Render profile: {' or '.join(PROFILES)}.")] = "full",
    settle: Annotated[int, typer.Option("--settle", help="Control steps to hold still before rendering.")] = 0,
    robot: RobotOption = None,
) -> None:
    """Render the top, main and wrist views of a task side by side, each labelled with its name.

    Example: pipette sim render pipette/OpenCentrifugeLid-v1 --robot ur5e_2f85 --seed 3 --out docs/views.png
    """
    spec = load_task(task_id, robot)
    env = PipetteEnv(spec, image_size=image_size, render_profile=profile)  # type: ignore[arg-type]
    try:
        env.reset(seed)
        hold = np.append(env.world.arm_qpos(), 1.0 if spec.embodiment.gripper == "open" else 0.0)
        for _ in range(settle):
            env.step(hold)
        save_png(views_sheet(env.render_views()), out)
    finally:
        env.close()
    err_console.print(f"wrote {out}")


@app.command("step-rate")
def step_rate(
    task_id: Annotated[str, typer.Argument(help="Task id.")],
    steps: Annotated[int, typer.Option("--steps", help="Control steps to time.")] = 60,
    image_size: Annotated[int | None, typer.Option("--image-size", help=IMAGE_SIZE_HELP)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
    robot: RobotOption = None,
) -> None:
    """Physics real-time factor and 3-camera render rate per profile.

    Example: pipette sim step-rate PickUpTestTube --robot piper --steps 90
    """
    spec = load_task(task_id, robot)
    results: dict[str, float] = {}
    env = PipetteEnv(spec, render=False)
    env.reset(0)
    hold = np.append(env.world.arm_qpos(), 1.0)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(hold)
    elapsed = time.perf_counter() - start
    results["physics_real_time_factor"] = steps * env.world.control_dt / elapsed
    results["control_steps_per_s"] = steps / elapsed
    for profile in PROFILES:
        renv = PipetteEnv(spec, image_size=image_size, render_profile=profile)  # type: ignore[arg-type]
        try:
            renv.reset(0)
            renv.render_views()  # warm up the GL context
            n = max(3, steps // 10)
            start = time.perf_counter()
            for _ in range(n):
                renv.render_views()
            results[f"render_{profile}_3view_per_s"] = n / (time.perf_counter() - start)
        finally:
            renv.close()
    if as_json:
        print_json({"task": spec.id, **results})
        return
    table = Table(title=f"{spec.id}")
    table.add_column("measure", overflow="fold")
    table.add_column("value", justify="right", overflow="fold")
    for key, value in results.items():
        table.add_row(key, f"{value:.2f}")
    out_console.print(table)


@app.command("view")
def view(
    task_id: Annotated[str, typer.Argument(help="Task id.")],
    seed: Annotated[int, typer.Option("--seed", help="Episode seed.")] = 0,
    robot: RobotOption = None,
) -> None:
    """Open the interactive MuJoCo viewer on a task (needs a display).

    Example: pipette sim view PickUpTestTube
    """
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise PipetteError("no display: `pipette sim view` needs one (try `pipette sim render` instead)")
    import mujoco.viewer  # deferred: glfw (~30 ms; needs a display)

    world = World(load_task(task_id, robot))
    world.reset(seed)
    mujoco.viewer.launch(world.model, world.data)
