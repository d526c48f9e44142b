"""`pipette augment`: bad input refused before any work; a small run prints and writes the yield report."""

from __future__ import annotations

import inspect
import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "augment"))
from raw_demo import raw_demo

from pipette_cli.demos.store import writing

pytestmark = pytest.mark.render
HOLD_REGISTRY = Path(__file__).resolve().parents[1] / "fixtures" / "demos" / "registry"


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--camera-radius", "-0.5"], "radius"),
        (["--speed", "0"], "factor"),
        (["--wrist-radius", "-1"], "wrist_radius"),
        (["--variants", "light,sped"], "did you mean 'speed'"),
        (["--variants", "light,speed", "--noise-corrective"], "has none: add noise to a variant"),
        (
            ["--variants", "light", "--noise-window", "15", "--noise-sigma", "0.01"],
            "--noise-sigma, --noise-window change",
        ),
        (["--variants", "object*3", "--speed", "1.5"], "--speed changes speed variants, and --variants 'object*3' has"),
    ],
)
def test_impossible_parameters_fail_before_any_work(run_cli, tmp_path_factory, tmp_path: Path, args, needle) -> None:
    raw = raw_demo(tmp_path_factory)
    out = tmp_path / "aug.h5"
    result = run_cli("augment", "PickUpTestTube", "--input", raw, "--output", out, *args)
    assert result.exit_code == 1 and needle in result.stderr
    assert not out.exists() and not list(tmp_path.iterdir())


def test_every_perturbation_option_belongs_to_its_atom() -> None:
    from pipette_cli.augment.specs import default_atoms
    from pipette_cli.cli.augment import ATOM_OPTIONS, augment

    params = set(inspect.signature(augment).parameters) - {"ctx"}
    assert set(ATOM_OPTIONS) == set(default_atoms())  # every atom, no other
    assert {n for names in ATOM_OPTIONS.values() for n in names} <= params
    assert {n for n in params if n.split("_")[0] in ("light", "noise", "camera", "object", "table")} <= {
        n for names in ATOM_OPTIONS.values() for n in names
    }


def test_raw_file_of_another_task_is_refused(run_cli, tmp_path_factory, tmp_path: Path) -> None:
    raw = raw_demo(tmp_path_factory)
    result = run_cli("--registry-dir", HOLD_REGISTRY, "augment", "testlab/HoldTube", "-i", raw, "-o", tmp_path / "a.h5")
    assert result.exit_code == 1 and "not testlab/HoldTube-v1" in result.stderr
    assert not list(tmp_path.iterdir())


def test_a_file_another_run_is_writing_is_refused_before_any_work(run_cli, tmp_path_factory, tmp_path: Path) -> None:
    raw = raw_demo(tmp_path_factory)
    rejected = tmp_path / "rejected.h5"
    with writing(rejected):  # as a second augment writing its failures to the same file would
        result = run_cli("augment", "PickUpTestTube", "-i", raw, "-o", tmp_path / "a.h5", "--rejected", rejected)
    assert result.exit_code == 1 and "rejected.h5 is being written by another run (pid" in result.stderr
    assert not list(tmp_path.iterdir())  # nothing made, no lock left behind


def test_demos_replay_on_the_robot_that_recorded_them(run_cli, tmp_path_factory, tmp_path: Path) -> None:
    raw = raw_demo(tmp_path_factory)  # recorded on the task's own robot, the Panda
    result = run_cli("augment", "PickUpTestTube", "-i", raw, "-o", tmp_path / "a.h5", "--robot", "piper")
    assert result.exit_code == 1 and "was recorded on the franka_panda" in result.stderr
    assert not list(tmp_path.iterdir())


def test_small_run_reports_yield_as_json(run_cli, tmp_path_factory, tmp_path: Path) -> None:
    raw = raw_demo(tmp_path_factory)
    out, report = tmp_path / "aug.h5", tmp_path / "yield.json"
    result = run_cli(
        "augment",
        "PickUpTestTube",
        "-i",
        raw,
        "-o",
        out,
        "--variants",
        "light,speed",
        "--speed",
        "6",
        "--workers",
        "1",
        "--json",
        "--report",
        report,
    )
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert data == json.loads(report.read_text())
    rows = {r["variant"]: r for r in data["variants"]}
    assert rows["light"]["kept"] == 1 and rows["light"]["magnitude"] == "s_I=0.8"
    assert rows["speed"]["magnitude"].startswith("s_v=6") and rows["speed"]["kept"] == 0  # 6x too fast to lift
    assert data["kept"] == 1 and out.exists()


def test_the_agent_brings_the_variant_each_perturbation_option_acts_on() -> None:
    # `pipette augment` refuses an atom's option with no variant of that atom; the agent's plan adds it
    from pipette_cli.agent.vocabulary import load_vocabulary
    from pipette_cli.cli.augment import ATOM_OPTIONS

    implies = load_vocabulary().implies["augment"]
    assert implies == {name: {"variants": atom} for atom, names in ATOM_OPTIONS.items() for name in names}


def test_what_the_agent_takes_the_paper_grid_to_hold_is_what_it_holds() -> None:
    from pipette_cli.agent.vocabulary import load_vocabulary
    from pipette_cli.augment.specs import PAPER_GRID

    held = {atom for variant in PAPER_GRID for atom in variant.split("+")}
    assert set(load_vocabulary().contains["variants"]["paper"]) == held
