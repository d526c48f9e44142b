"""``pipette new-task`` and ``pipette assets new`` end to end, in-process."""

from __future__ import annotations

import io
import json
import sys

import pytest

from pipette_cli.registry import load_registry, load_task_file

TEXT = "Put the 90 mm petri dish on the orbital shaker"
TASK_ID = "generated/PlacePetriDish90mmOnOrbitalShaker-v1"


def test_new_task_writes_a_valid_registry_file(run_cli, tmp_path) -> None:
    result = run_cli("new-task", TEXT, "--out", tmp_path, "--yes")
    assert result.exit_code == 0, result.stderr
    path = tmp_path / "place_petri_dish90mm_on_orbital_shaker.yaml"
    assert path.is_file() and "instruction: Put the 90 mm petri dish on the orbital shaker." in result.stdout
    assert result.stdout == path.read_text()  # what the user confirmed is what was written
    assert load_task_file(path).id == TASK_ID
    assert run_cli("tasks", "validate", path).exit_code == 0
    listed = json.loads(run_cli("--registry-dir", tmp_path, "tasks", "list", "--json").stdout)
    assert TASK_ID in {row["id"] for row in listed} and len(listed) == len(load_registry().tasks) + 1
    again = run_cli("--registry-dir", tmp_path, "new-task", TEXT, "--out", tmp_path, "--yes")
    assert again.exit_code == 1 and "already registered" in again.stderr


def test_words_the_draft_does_not_use_are_listed_and_yes_does_not_write_it(run_cli, tmp_path) -> None:
    text = "Put the zorbly petri dish on the orbital shaker"
    result = run_cli("new-task", text, "--out", tmp_path, "--yes")
    assert result.exit_code == 1 and not list(tmp_path.iterdir())
    said = " ".join(result.stderr.split())
    assert "not understood: 'zorbly' (the draft above does not use it)" in said
    assert "not written: the request's 'zorbly' is not understood" in said
    assert "instruction: Put the zorbly petri dish" in result.stdout  # the draft is shown
    shown = json.loads(run_cli("new-task", text, "--json", "--dry-run").stdout)
    assert shown["not_understood"] == ["zorbly"] and shown["plan"]["steps"][0]["action"] == "place"
    plain = json.loads(run_cli("new-task", TEXT, "--json", "--dry-run").stdout)
    assert plain["not_understood"] == []


def test_a_sentence_the_default_robot_cannot_do_goes_to_the_first_robot_that_can(run_cli) -> None:
    shown = json.loads(
        run_cli("new-task", "Hold the multichannel pipette above the reagent reservoir", "--json", "--dry-run").stdout
    )
    assert "robot: ur5e_robotiq" in shown["yaml"]
    assert (
        shown["notes"] and "the franka_panda cannot" in shown["notes"][0] and "gripper opens 80 mm" in shown["notes"][0]
    )
    named = run_cli("new-task", "Hold the multichannel pipette above the reagent reservoir with the Panda", "--dry-run")
    assert named.exit_code == 1 and "gripper opens 80 mm" in " ".join(named.stderr.split())  # a named robot is kept
    plate = run_cli("new-task", "Put the 96-well plate on the orbital shaker", "--dry-run")
    said = " ".join(plate.stderr.split())
    assert plate.exit_code == 1 and "no registered robot can do this" in said
    assert all(robot in said for robot in ("franka_panda", "agilex_piper", "ur5e_robotiq"))


def test_check_gate_passes_a_solvable_task(run_cli, tmp_path) -> None:
    result = run_cli(
        "new-task",
        "Close the lid of the thermal cycler",
        "--check",
        "--episodes",
        "2",
        "--dry-run",
        "--id",
        "mylab/ShutCycler-v1",
    )
    assert result.exit_code == 0, result.stderr
    text = " ".join(result.stderr.split())
    assert "check: ok" in text and "expert 'program' solved 2/2 episodes (needs 2)" in text
    assert "nothing written" in text and not list(tmp_path.iterdir())


def test_a_tube_put_on_ice_is_stood_in_the_bucket_not_dropped_into_it(run_cli, tmp_path) -> None:
    # 150 mm of tube over a 130 mm deep bucket: let fall from over the rim it toppled against the
    # wall (0/5); set down on the floor, held above the rim, it stands
    out = tmp_path / "ice.yaml"
    result = run_cli("new-task", "Put the tube on ice", "--check", "--episodes", "2", "-o", out, "--yes")
    assert result.exit_code == 0, result.stderr
    assert "expert 'program' solved 2/2 episodes" in " ".join(result.stderr.split())
    assert "{skill: place_on, object: tube, target: bucket/center}" in out.read_text()


def test_check_failure_names_the_stage_and_writes_nothing_without_force(run_cli, tmp_path, monkeypatch) -> None:
    from pipette_cli.taskgen import check

    monkeypatch.setattr(check, "SOLVE_SHARE", 1.01)  # no expert can pass: the gate must refuse
    result = run_cli("new-task", TEXT, "--check", "--episodes", "1", "--out", tmp_path, "--yes")
    text = " ".join(result.stderr.split())
    assert result.exit_code == 1 and f"--check failed for {TASK_ID}" in text
    assert "Traceback" not in result.stderr and not list(tmp_path.iterdir())
    forced = run_cli("new-task", TEXT, "--check", "--episodes", "1", "--out", tmp_path, "--yes", "--force")
    assert forced.exit_code == 0 and "FAILED (written anyway: --force)" in " ".join(forced.stderr.split())
    assert len(list(tmp_path.iterdir())) == 1


def test_json_has_the_plan_and_the_check(run_cli) -> None:
    data = json.loads(
        run_cli(
            "new-task",
            "Close the spectrophotometer lid",
            "--check",
            "--episodes",
            "1",
            "--dry-run",
            "--json",
            "--id",
            "mylab/ShutSpectro-v1",
        ).stdout
    )
    assert data["id"] == "mylab/ShutSpectro-v1" and data["check"]["ok"] is True
    assert data["steps"] == ["close spectrophotometer"] and data["plan"]["steps"][0]["action"] == "close"
    assert data["check"]["idle_steps"] > 0


def test_multi_step_description_becomes_a_sequence_task(run_cli, tmp_path) -> None:
    result = run_cli(
        "new-task", "Open the PCR machine, load the PCR strip, and then close the lid", "--out", tmp_path, "--yes"
    )
    assert result.exit_code == 0, result.stderr
    path = next(tmp_path.iterdir())
    spec = load_task_file(path)
    assert spec.success.type == "sequence" and len(spec.success.of) == 3
    # the cycler's lid is motorised: opened and closed with its button, one instrument for both
    skills = [s.skill for s in spec.expert]
    assert skills[:2] == ["press", "wait"] and skills[-2:] == ["press", "wait"]
    assert spec.expert[0].button == spec.expert[-2].button and spec.expert[0].button.endswith("/lid_button")
    assert [m.type for m in spec.scene.mechanisms] == ["instrument"]
    assert run_cli("tasks", "validate", path).exit_code == 0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("Put the 15 mL tube in the autoclave", "unknown object 'autoclave'; nearest:"),
        ("Pour the buffer into the beaker", "liquids are not simulated"),
        ("Unscrew the cap of the falcon tube", "screwing caps on or off is not supported"),
        ("Pick up the 1000 mL beaker", "the franka_panda's gripper opens 80 mm"),
    ],
)
def test_refusals_exit_1_with_one_line_and_write_nothing(run_cli, tmp_path, text, message) -> None:
    result = run_cli("new-task", text, "--out", tmp_path, "--yes")
    assert result.exit_code == 1 and message in " ".join(result.stderr.split())
    assert "Traceback" not in result.stderr and not list(tmp_path.iterdir())
    assert len(result.stderr.strip().splitlines()) == 1


def test_answering_no_writes_nothing(run_cli, tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(sys, "stdin", io.StringIO("n\n"))
    result = run_cli("new-task", TEXT, "--out", tmp_path)
    assert result.exit_code == 1 and "not written" in result.stderr and not list(tmp_path.iterdir())
    assert f"write {tmp_path}" in result.stderr and "? [y/N] n\n" in result.stderr  # the prompt, not rich markup
    monkeypatch.setattr(sys, "stdin", io.StringIO(""))
    silent = run_cli("new-task", TEXT, "--out", tmp_path)
    assert silent.exit_code == 1 and "[y/N] no answer (stdin is not a terminal)" in " ".join(silent.stderr.split())
    monkeypatch.setattr(sys, "stdin", io.StringIO("y\n"))
    assert run_cli("new-task", TEXT, "--out", tmp_path).exit_code == 0 and len(list(tmp_path.iterdir())) == 1


def test_unknown_backend_lists_the_known_ones(run_cli) -> None:
    result = run_cli("new-task", TEXT, "--backend", "gpt")
    assert result.exit_code == 1 and "unknown backend 'gpt'" in result.stderr and "openai" in result.stderr


def test_assets_new_writes_a_validated_usd_asset(run_cli, tmp_path) -> None:
    result = run_cli("assets", "new", "a 300 mL Erlenmeyer flask", "--out", tmp_path, "--yes")
    assert result.exit_code == 0, result.stderr
    path = tmp_path / "consumables" / "erlenmeyer_flask_300ml.usda"
    assert path.is_file()
    assert run_cli("assets", "validate", path).exit_code == 0
    show = json.loads(run_cli("assets", "show", path, "--json").stdout)
    assert show["volume_ml"] == 300.0 and 0.083 < show["dimensions"][0] < 0.105  # between the 250 and 500 mL flasks


def test_assets_new_knows_what_the_library_already_has(run_cli, tmp_path) -> None:
    result = run_cli("assets", "new", "a 250 mL Erlenmeyer flask", "--out", tmp_path, "--yes")
    assert result.exit_code == 0 and "already has this asset: erlenmeyer_flask_250ml" in result.stderr
    assert not list(tmp_path.iterdir())


def test_assets_new_says_which_words_it_did_not_use_and_writes_nothing_under_yes(run_cli, tmp_path) -> None:
    result = run_cli("assets", "new", "a tall 300 mL Erlenmeyer flask", "--out", tmp_path, "--yes")
    assert result.exit_code == 1 and "not understood: 'tall'" in result.stderr and "not written" in result.stderr
    assert not list(tmp_path.iterdir())
    existing = run_cli("assets", "new", "a tall 250 mL Erlenmeyer flask", "--out", tmp_path, "--json")
    assert json.loads(existing.stdout)["not_understood"] == ["tall"] and "not understood: 'tall'" in existing.stderr


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("a flux capacitor", "no parametric generator"),
        ("a 90000 mL beaker", "less than or equal to 5000"),
        ("a 384-well plate", "the library has: well_plate_384"),
    ],
)
def test_assets_new_rejects_what_it_cannot_make(run_cli, tmp_path, text, message) -> None:
    result = run_cli("assets", "new", text, "--out", tmp_path, "--yes")
    assert result.exit_code == 1 and message in result.stderr and not list(tmp_path.iterdir())
