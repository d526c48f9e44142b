"""Every listing at 80 and 120 columns: no line wider than the terminal, every row's id whole and its
instruction, name or outcome in full (wrapped whitespace allowed), as a table or stacked per row."""

from __future__ import annotations

import io
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import pytest
from rich.cells import cell_len
from rich.console import Console

from pipette_cli.cli import convert as convert_cli
from pipette_cli.cli.common import out_console
from pipette_cli.cli.listing import Column, Listing
from pipette_cli.demos.collect import collect
from pipette_cli.errors import plural
from pipette_cli.registry import load_registry

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
sys.path.insert(0, str(FIXTURES / "demos"))
import demo_experts  # noqa: E402

WIDTHS = (80, 120)
LONG_ID = "mylab/PickUpTheSkirtedConicalTubeFromTheRackBesideTheBalance-v1"
LONG_INSTRUCTION = (
    "Pick up the skirted 50 mL conical tube from the second row of the rack beside the balance, "
    "holding it upright so that the sample does not spill, and lift it clear of the rack."
)


@pytest.fixture
def columns(monkeypatch: pytest.MonkeyPatch) -> Callable[[int], None]:
    """Make stdout's console this many columns wide (as a terminal of that width would)."""

    def set_width(width: int) -> None:
        monkeypatch.setattr(out_console, "_width", width)

    return set_width


def _table_rows(lines: list[str]) -> list[list[str]]:
    """The body rows of a rich table: each column's cell lines joined (a row starts where its first
    cell, never wrapped, is filled in)."""
    rows: list[list[list[str]]] = []
    for line in lines:
        if not line.startswith("│"):
            continue
        cells = [cell.strip() for cell in line.rstrip()[1:-1].split("│")]
        if cells[0] or not rows:
            rows.append([[cell] for cell in cells])
        else:
            for parts, cell in zip(rows[-1], cells, strict=True):
                parts.append(cell)
    return [[" ".join(part for part in parts if part) for parts in row] for row in rows]


def _in_order(cells: list[str], row: list[str]) -> bool:
    found = iter(row)
    return all(cell in found for cell in cells)


def assert_listed(stdout: str, width: int, rows: list[list[str]]) -> None:
    """No line of ``stdout`` is wider than ``width``; the cells of each of ``rows`` are printed in full
    and in order: in one row of the table, or (stacked) separated by whitespace and labels only."""
    lines = stdout.splitlines()
    widest = max(lines, key=cell_len)
    assert cell_len(widest) <= width, f"{cell_len(widest)} columns: {widest!r}"
    if any(line.startswith("│") for line in lines):
        printed = _table_rows(lines)
        for row in rows:
            assert any(_in_order([" ".join(cell.split()) for cell in row if cell], p) for p in printed), row
        return
    flat = " ".join(stdout.split())
    for row in rows:
        at = 0
        for cell in (" ".join(cell.split()) for cell in row if cell):
            found = re.compile(rf"(?<!\S){re.escape(cell)}(?!\S)").search(flat, at)
            assert found, f"{cell!r} of {row} (after {flat[at - 60 : at]!r})"
            at = found.end()


@pytest.mark.parametrize("width", WIDTHS)
def test_tasks_list_fits(run_cli, columns, width: int) -> None:
    rows = json.loads(run_cli("tasks", "list", "--json").stdout)
    columns(width)
    result = run_cli("tasks", "list")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith(f"{len(rows)} tasks")
    evaluators = [
        f"{r['evaluator']} ({plural(len(r['stages']), 'stage')})" if r["stages"] else r["evaluator"] for r in rows
    ]
    expected = [[r["id"], r["embodiment"], e, r["instruction"]] for r, e in zip(rows, evaluators, strict=True)]
    assert_listed(result.stdout, width, expected)


@pytest.mark.parametrize("width", WIDTHS)
def test_a_long_user_task_with_a_tag_fits(run_cli, columns, width: int, tmp_path: Path) -> None:
    """The case of issue 36: ``--registry-dir DIR --tag pick`` printed the instruction one letter a line."""
    text = (FIXTURES / "tasks" / "valid_pick.yaml").read_text()
    text = text.replace("testlab/PickUpMicrotube-v1", LONG_ID).replace("tags: [test]", "tags: [mylab_pick]")
    (tmp_path / "long.yaml").write_text(text.replace("Pick up the microtube.", LONG_INSTRUCTION))
    columns(width)
    result = run_cli("--registry-dir", tmp_path, "tasks", "list", "--tag", "mylab_pick")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith("1 task\n")
    assert_listed(result.stdout, width, [[LONG_ID, "franka_panda", "lift_and_hold", LONG_INSTRUCTION]])
    assert len(result.stdout.splitlines()) <= 12


@pytest.mark.parametrize("width", WIDTHS)
def test_tasks_suites_fits(run_cli, columns, width: int) -> None:
    suites = json.loads(run_cli("tasks", "suites", "--json").stdout)
    columns(width)
    result = run_cli("tasks", "suites")
    assert result.exit_code == 0, result.stderr
    assert_listed(
        result.stdout,
        width,
        [[s["id"], str(len(s["tasks"])), s["name"], ", ".join(p["type"] for p in s["perturbations"])] for s in suites],
    )


@pytest.mark.parametrize("width", WIDTHS)
def test_assets_list_fits(run_cli, columns, width: int) -> None:
    assets = json.loads(run_cli("assets", "list", "--json").stdout)
    columns(width)
    result = run_cli("assets", "list")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith(f"{len(assets)} assets (tools ")
    assert_listed(result.stdout, width, [[a["category"], a["id"]] for a in assets])


LONG_REASON = "timeout: the tube slipped out of the fingers halfway up and fell back into the rack"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("listings") / "rec.h5"
    task = load_registry([FIXTURES / "demos" / "registry"]).get("testlab/HoldTube-v1")
    collect(task, out, episodes=2, seed=0, image_size=16, expert_factory=demo_experts.Wiggle)
    with h5py.File(out, "r+") as f:
        f["episodes/episode_000001"].attrs["reason"] = LONG_REASON
    return out


@pytest.mark.render
@pytest.mark.parametrize("width", WIDTHS)
def test_data_inspect_fits(run_cli, columns, width: int, recorded: Path) -> None:
    episodes = json.loads(run_cli("data", "inspect", recorded, "--json").stdout)["episodes"]
    assert [e["reason"] for e in episodes] == ["not_lifted", LONG_REASON]
    columns(width)
    result = run_cli("data", "inspect", recorded)
    assert result.exit_code == 0, result.stderr
    rows = [[str(e["index"]), str(e["seed"]), e["source"], str(e["steps"]), f"failed {e['reason']}"] for e in episodes]
    assert_listed(result.stdout, width, rows)
    assert "2 episodes, 0 successful" in result.stderr


def _stats_report() -> dict[str, Any]:
    """What `dataset_stats` gives for an augmented dataset of 60 episodes: 40 perturbed variants and
    20 re-rendered originals, three cameras, an 8-dimensional state and action."""
    state = {
        "dtype": "float32",
        "shape": [8],
        "min": [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973, 0],
    }
    state["max"] = [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973, 1]
    camera = {"dtype": "video", "shape": [3, 96, 96], "min": [0.0, 0.0, 0.0], "max": [0.996, 0.992, 1.0]}
    features = {f"observation.images.{c}": camera for c in ("top", "main", "wrist")}
    features |= {
        "observation.state": state,
        "action": state,
        "stage": {"dtype": "int64", "shape": [1], "min": [0], "max": [1]},
    }
    provenance = {
        "dataset_version": "augmented",
        "successful": 60,
        "failed": 0,
        "failure_reasons": {},
        "skipped_failed": 1,
        "sources": {"augmented": 60},
        "perturbed": 40,
        "originals": 20,
        "files": ["/data/tube_aug.h5"],
    }
    return {
        "episodes": 60,
        "frames": 1800,
        "fps": 10,
        "episode_length": {"min": 28, "max": 31},
        "video": True,
        "robot_type": "franka_panda",
        "features": features,
        "provenance": provenance,
    }


@pytest.mark.parametrize("width", WIDTHS)
def test_data_stats_fits(run_cli, columns, width: int, monkeypatch: pytest.MonkeyPatch) -> None:
    report = _stats_report()
    monkeypatch.setattr(convert_cli, "dataset_stats", lambda root: report)
    columns(width)
    result = run_cli("data", "stats", "datasets/pipette_PickUpTestTube-v1/augmented")
    assert result.exit_code == 0, result.stderr
    rows = [
        [
            name,
            f["dtype"],
            "x".join(map(str, f["shape"])),
            *(" ".join(f"{x:.3g}" for x in f[k]) for k in ("min", "max")),
        ]
        for name, f in report["features"].items()
    ]
    listing = result.stdout[result.stdout.index("features\n") : result.stdout.index("augmented dataset:")]
    assert_listed(listing, width, rows)
    said = " ".join(result.stdout.split())
    assert "60 episodes, 1800 frames at 10 Hz" in said
    assert (
        "1 failed episode left out; sources: augmented 60; 40 perturbed variants and 20 unperturbed originals" in said
    )


def test_the_layout_follows_the_width() -> None:
    rows = [["pipette/PickUpTestTube-v1", "Pick up the test tube from the rack and hold it still above the rack."]]
    listing = Listing("1 task", [Column("id"), Column("instruction", wrap=True)], rows)
    for width, table in ((80, True), (60, False), (20, False)):
        console = Console(width=width, record=True, file=io.StringIO())
        console.print(listing)
        printed = console.export_text()
        assert ("┃ instruction" in printed) is table and listing.fits_table(width) is table
        assert all(cell_len(line) <= width for line in printed.splitlines()), printed
    assert printed.splitlines()[2:5] == ["    instruction", "pipette/PickUpTestTu", "be-v1"]


def test_output_to_a_file_or_pipe_cuts_no_id(run_cli, monkeypatch: pytest.MonkeyPatch) -> None:
    """Written to a log or a pipe (no terminal, no COLUMNS), a table is as wide as its cells: rich's
    80 columns there had cut ids ("generated/CloseMicrocentrifu…") in the agent's and the experts' tables."""
    monkeypatch.delenv("COLUMNS", raising=False)
    result = run_cli("agent", "which tasks involve the centrifuge?")
    assert result.exit_code == 0, result.stderr
    assert "generated/CloseMicrocentrifugeLid-v1" in result.stdout and "…" not in result.stdout
    monkeypatch.setenv("COLUMNS", "80")  # a width given is kept
    narrow = run_cli("agent", "which tasks involve the centrifuge?")
    assert max(map(cell_len, narrow.stdout.splitlines())) <= 80 and "…" not in narrow.stdout
