"""CLI options bound to a spec field (or to a library function's parameter) have its default, and
show its description: each default lives once, so the CLI and the library cannot drift apart."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import pytest
import typer

from pipette_cli.augment.specs import AugmentSpec
from pipette_cli.cli.common import spec_default, spec_help
from pipette_cli.cli.main import app
from pipette_cli.demos.collect import collect
from pipette_cli.evaluation.runner import PolicySource
from pipette_cli.evaluation.settings import EvalSettings
from pipette_cli.lerobot.convert import ConvertOptions
from pipette_cli.lerobot.train import TrainOptions
from pipette_cli.serving.server import LeRobotRunner, PolicyServer
from pipette_cli.specs.perturbations import (
    CameraPoseSpec,
    JointNoiseSpec,
    LightingSpec,
    ObjectPoseSpec,
    SpeedSpec,
    SurfaceColorSpec,
)

# (command, option) -> (spec, field): the option's default and help come from the field
BOUND: dict[tuple[str, str], tuple[type, str]] = {
    ("augment", "--light-scale"): (LightingSpec, "scale"),
    ("augment", "--speed"): (SpeedSpec, "factor"),
    ("augment", "--rho"): (SpeedSpec, "rho"),
    ("augment", "--interpolation"): (SpeedSpec, "interpolation"),
    ("augment", "--noise-sigma"): (JointNoiseSpec, "sigma"),
    ("augment", "--noise-clip"): (JointNoiseSpec, "bound"),
    ("augment", "--camera"): (CameraPoseSpec, "camera"),
    ("augment", "--camera-radius"): (CameraPoseSpec, "radius"),
    ("augment", "--wrist-radius"): (CameraPoseSpec, "wrist_radius"),
    ("augment", "--object-xy"): (ObjectPoseSpec, "xy"),
    ("augment", "--object-yaw"): (ObjectPoseSpec, "yaw_deg"),
    ("augment", "--object-range"): (ObjectPoseSpec, "task_range"),
    ("augment", "--light-jitter"): (LightingSpec, "jitter"),
    ("augment", "--table-blend"): (SurfaceColorSpec, "blend"),
    ("augment", "--seed"): (AugmentSpec, "seed"),
    ("augment", "--image-size"): (AugmentSpec, "image_size"),
    **{
        ("convert", f"--{name.replace('_', '-')}"): (ConvertOptions, name)
        for name in (
            "fps",
            "frame_filter",
            "dataset_version",
            "include_failed",
            "allow_mixed",
            "allow_mixed_robots",
            "overwrite",
            "vcodec",
        )
    },
    ("convert", "--video"): (ConvertOptions, "video"),
    **{
        ("train", f"--{name.replace('_', '-')}"): (TrainOptions, name)
        for name in (
            "dataset_version",
            "steps",
            "batch_size",
            "device",
            "datasets_root",
            "output_root",
            "if_exists",
            "pretrained_path",
            "vlm_path",
            "act_backbone_weights",
            "offline",
            "threads",
        )
    },
    ("eval", "--dataset-version"): (EvalSettings, "dataset_version"),
    ("eval", "--image-size"): (EvalSettings, "image_size"),
    ("eval", "--device"): (PolicySource, "device"),
    ("eval", "--dead-after"): (PolicySource, "dead_after_s"),
}

# (command, option) -> (function, parameter): options whose default is a library function's
SIGNATURE: dict[tuple[str, str], tuple[Callable[..., Any], str]] = {
    ("collect", "--seed"): (collect, "seed"),
    ("collect", "--workers"): (collect, "workers"),
    ("collect", "--profile"): (collect, "render_profile"),
    ("serve", "--bind"): (PolicyServer, "endpoint"),
    ("serve", "--device"): (LeRobotRunner, "device"),
}


def _option(command: str, flag: str) -> Any:
    group = typer.main.get_command(app)
    cmd = group.get_command(group.make_context("pipette", [command, "--help"], resilient_parsing=True), command)
    return next(p for p in cmd.params if flag in p.opts)


def _plain(value: Any) -> Any:
    return value.value if isinstance(value, Enum) else str(value) if isinstance(value, Path) else value


def _drift(option: Any, field: tuple[type, str]) -> list[str]:
    """What of ``option`` differs from ``field``: its default, its help (where the field has a
    description; otherwise the CLI keeps its own help)."""
    drift = []
    if _plain(option.default) != _plain(spec_default(*field)):
        drift.append(f"default {option.default!r} != {spec_default(*field)!r}")
    if spec_help(*field).rstrip(".") not in (option.help or ""):
        drift.append("help lacks the field's description")
    return drift


@pytest.mark.parametrize(("where", "field"), BOUND.items(), ids=[" ".join(k) for k in BOUND])
def test_a_bound_option_has_its_fields_default_and_description(where: tuple[str, str], field: tuple[type, str]) -> None:
    assert _drift(_option(*where), field) == []


@pytest.mark.parametrize(("where", "parameter"), SIGNATURE.items(), ids=[" ".join(k) for k in SIGNATURE])
def test_an_option_has_its_library_functions_default(where: tuple[str, str], parameter: tuple[Any, str]) -> None:
    function, name = parameter
    assert _option(*where).default == inspect.signature(function).parameters[name].default


def test_the_drift_check_sees_a_restated_default() -> None:
    restated = typer.Typer(add_completion=False)

    @restated.command()
    def convert(fps: Annotated[int, typer.Option("--fps", help="Dataset frame rate.")] = 11) -> None: ...

    option = next(p for p in typer.main.get_command(restated).params if "--fps" in p.opts)
    assert _drift(option, (ConvertOptions, "fps")) == ["default 11 != 10", "help lacks the field's description"]
