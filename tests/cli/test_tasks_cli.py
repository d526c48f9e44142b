"""``pipette tasks ...`` end to end, in-process."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from pipette_cli.registry import load_registry, load_task_file

FIXTURES = Path(__file__).parents[1] / "fixtures" / "tasks"


def test_list_json_has_the_twelve_tasks_with_robot_and_evaluator(run_cli) -> None:
    result = run_cli("tasks", "list", "--json")
    assert result.exit_code == 0, result.stderr
    rows = json.loads(result.stdout)
    assert len([r for r in rows if "paper-benchmark" in r["tags"]]) == 12
    assert len(rows) == len(load_registry().tasks)  # plus the tasks `pipette new-task` added
    assert all(row["id"].count("/") == 1 and row["embodiment"] and row["evaluator"] for row in rows)
    shaker = next(r for r in rows if r["id"] == "pipette/PlaceFlaskOnShaker-v1")
    assert (shaker["embodiment"], shaker["evaluator"]) == ("agilex_piper", "region_hold")


def test_list_filters_by_tag(run_cli) -> None:
    rows = json.loads(run_cli("tasks", "list", "--tag", "hatch_control", "--json").stdout)
    assert {r["category"] for r in rows} == {"hatch_control"}
    assert sorted(r["id"] for r in rows if "paper-benchmark" in r["tags"]) == [
        "pipette/CloseCentrifugeLid-v1",
        "pipette/CloseSpectrophotometerLid-v1",
        "pipette/OpenCentrifugeLid-v1",
        "pipette/OpenWaterBathLid-v1",
    ]


def test_list_filters_by_an_asset_the_scene_places(run_cli) -> None:
    rows = json.loads(run_cli("tasks", "list", "--asset", "thermal_cycler", "--json").stdout)
    assert [r["id"] for r in rows] == ["generated/CloseThermalCyclerLid-v1", "protocols/RunThermalCycler-v1"]
    unknown = run_cli("tasks", "list", "--asset", "thermal_cycle")
    assert unknown.exit_code != 0 and "did you mean 'thermal_cycler'" in unknown.stderr


def test_list_table_prints_every_task(run_cli) -> None:
    result = run_cli("tasks", "list")
    assert result.exit_code == 0 and f"{len(load_registry().tasks)} tasks" in result.stdout
    assert "PlaceFlaskOnShaker" in result.stdout


def test_show_prints_the_file_with_comments_and_json(run_cli) -> None:
    result = run_cli("tasks", "show", "PickUpTestTube")
    assert result.exit_code == 0 and "# paper A.8: z_t > z_0 + 0.02 m" in result.stdout
    data = json.loads(run_cli("tasks", "show", "pipette/PickUpTestTube-v1", "--json").stdout)
    assert data["success"]["min_height_gain"] == 0.02 and data["path"].endswith("pick_up_test_tube.yaml")


def test_show_and_list_give_a_protocols_stages_with_their_instructions(run_cli) -> None:
    result = run_cli("tasks", "show", "protocols/SpinMicrotube-v1")
    assert result.exit_code == 0, result.stderr
    assert (
        "# 4 stages" in result.stdout
        and "#   4. Press the start button to spin the tube.  [instrument_state]" in result.stdout
    )
    data = json.loads(run_cli("tasks", "show", "protocols/SpinMicrotube-v1", "--json").stdout)
    assert [s["instruction"] for s in data["stages"]][:2] == [
        "Press the release button to open the microcentrifuge lid.",
        "Put the microtube in a rotor well.",
    ]
    rows = json.loads(run_cli("tasks", "list", "--tag", "protocol", "--json").stdout)
    assert len(rows) >= 5 and all(len(r["stages"]) >= 3 for r in rows)
    assert json.loads(run_cli("tasks", "show", "PickUpTestTube", "--json").stdout)["stages"] == []


def test_unknown_task_exits_1_with_suggestion(run_cli) -> None:
    result = run_cli("tasks", "show", "PickUpTestTub")
    assert result.exit_code == 1
    assert "unknown task 'PickUpTestTub'; did you mean" in result.stderr and "Traceback" not in result.stderr


def test_validate_broken_files_exits_1_with_every_location(run_cli) -> None:
    files = sorted((FIXTURES / "broken").glob("*.yaml"))
    result = run_cli("tasks", "validate", *files)
    assert result.exit_code == 1
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == len(files)
    for path in files:
        assert any(f"{path}:" in line for line in errors), path


def test_validate_reports_duplicate_ids(run_cli) -> None:
    result = run_cli("tasks", "validate", FIXTURES / "dup")
    assert result.exit_code == 1 and "duplicate task id 'testlab/PickUpMicrotube-v1'" in result.stderr


def test_validate_the_registry_and_a_good_file(run_cli) -> None:
    """Every shipped task passes every check, the scene built (reach, interpenetration) included."""
    whole = run_cli("tasks", "validate")
    assert whole.exit_code == 0, whole.stderr
    assert f"{len(load_registry().tasks)} tasks and " in whole.stderr
    assert run_cli("tasks", "validate", FIXTURES / "valid_pick.yaml").exit_code == 0
    folder = run_cli("tasks", "validate", REGISTRY)
    assert folder.exit_code == 0, folder.stderr
    assert folder.stderr.count("ok  ") == len(load_registry().tasks)


REGISTRY = Path(__file__).parents[2] / "registry"
TUBE_YAML = (REGISTRY / "pick_up_test_tube.yaml").read_text()


def _line(path: Path, start: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if line.lstrip().startswith(start))


def _validate_edited(run_cli, tmp_path: Path, registry_file: str, old: str, new: str) -> tuple[Path, Any, str]:
    """``tasks validate`` on a copy of a registry task file (id ``mylab/Edited-v1``) with ``old``
    made ``new``: the copy, the result and its stderr on one line."""
    text = (REGISTRY / registry_file).read_text()
    assert old in text, old
    path = tmp_path / "edited.yaml"
    path.write_text(re.sub(r"(?m)^id: .*$", "id: mylab/Edited-v1", text.replace(old, new), count=1))
    result = run_cli("tasks", "validate", path)
    return path, result, " ".join(result.stderr.split())


def test_validate_refuses_a_copy_whose_id_the_registry_has_naming_both_files(run_cli, tmp_path: Path) -> None:
    copy = tmp_path / "my_tube.yaml"
    copy.write_text(TUBE_YAML)
    result = run_cli("tasks", "validate", copy)
    assert result.exit_code == 1 and "ok  " not in result.stderr
    assert (
        f"error: {copy}:{_line(copy, 'id:')}: id: duplicate task id 'pipette/PickUpTestTube-v1', already defined in "
        f"{REGISTRY / 'pick_up_test_tube.yaml'}" in result.stderr
    )
    # the registry's own file is not its own duplicate; the folders of --registry-dir are joined too
    assert run_cli("tasks", "validate", REGISTRY / "pick_up_test_tube.yaml").exit_code == 0
    (tmp_path / "pack").mkdir()
    mine = TUBE_YAML.replace("pipette/PickUpTestTube-v1", "mylab/Tube-v1")
    (tmp_path / "pack" / "tube.yaml").write_text(mine)
    copy.write_text(mine)
    assert run_cli("tasks", "validate", copy).exit_code == 0
    joined = run_cli("--registry-dir", tmp_path / "pack", "tasks", "validate", copy)
    assert joined.exit_code == 1 and f"already defined in {tmp_path / 'pack' / 'tube.yaml'}" in joined.stderr


def test_validate_refuses_an_object_out_of_reach(run_cli, tmp_path: Path) -> None:
    far = tmp_path / "far_tube.yaml"
    far.write_text(
        TUBE_YAML.replace("pipette/PickUpTestTube-v1", "mylab/FarTube-v1").replace(
            "[0.5, 0.0, 0.55]", "[1.6, 0.0, 0.55]"
        )
    )
    result = run_cli("tasks", "validate", far)
    assert result.exit_code == 1 and "ok  " not in result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and re.fullmatch(
        rf"error: {re.escape(str(far))}:{_line(far, 'pose:')}: scene\.objects\.0\.pose: 'tube' is 1\.[56]\d m from the "
        r"franka_panda base, beyond its 0\.82 m reach",
        errors[0],
    ), errors
    assert run_cli("tasks", "validate", "--no-physics", far).exit_code == 0
    near = tmp_path / "near_tube.yaml"  # where the expert grasps it, too near the base for the arm
    near.write_text(far.read_text().replace("[1.6, 0.0, 0.55]", "[0.2, 0.12, 0.55]"))
    result = run_cli("tasks", "validate", near)
    assert (
        result.exit_code == 1 and f"{near}:{_line(near, 'pose:')}: scene.objects.0.pose: 'tube' is 0.2" in result.stderr
    )
    assert "from the franka_panda base axis, inside its 0.28 m minimum reach" in result.stderr


def test_validate_refuses_objects_that_interpenetrate_at_reset(run_cli, tmp_path: Path) -> None:
    sunk = tmp_path / "sunk_tube.yaml"
    sunk.write_text(
        TUBE_YAML.replace("pipette/PickUpTestTube-v1", "mylab/SunkTube-v1").replace(
            "[0.5, 0.0, 0.55]", "[0.5, 0.0, 0.50]"
        )
    )
    result = run_cli("tasks", "validate", sunk)
    assert result.exit_code == 1
    assert (
        f"error: {sunk}:{_line(sunk, 'pose:')}: scene.objects.0.pose: bench and tube interpenetrate by "
        in result.stderr
    )


def test_validate_names_a_criterion_part_the_scene_lacks_at_its_line(run_cli, tmp_path: Path) -> None:
    edit = ("center: balance/pan_center", "center: balance/pan_centre")
    typo, result, said = _validate_edited(run_cli, tmp_path, "place_tube_on_balance.yaml", *edit)
    assert result.exit_code == 1 and "ok  " not in result.stderr
    assert (
        f"error: {typo}:{_line(typo, 'center:')}: success.within.center: asset 'electronic_balance' of 'balance' "
        "has no site, joint or body 'pan_centre'; did you mean 'pan_center'" in said
    )
    assert run_cli("tasks", "validate", "--no-physics", typo).exit_code == 1  # read from the asset, no build


def test_usage_error_exits_2(run_cli) -> None:
    assert run_cli("tasks", "list", "--no-such-option").exit_code == 2
    assert run_cli("tasks", "frobnicate").exit_code == 2


def test_a_global_option_after_the_command_gets_a_hint(run_cli) -> None:
    result = run_cli("tasks", "show", "PickUpTestTube", "--debug")
    assert result.exit_code == 2 and "No such option: --debug" in result.stderr
    hint = "hint: --debug is a global option, given before the command: pipette --debug tasks show PickUpTestTube"
    assert hint in " ".join(result.stderr.split())
    moved = run_cli("tasks", "list", "--registry-dir", "extra", "-vv", "--json")
    assert moved.exit_code == 2 and "pipette --registry-dir extra tasks list -vv --json" in moved.stderr
    counted = run_cli("tasks", "list", "-vv")
    assert "hint: -v is a global option, given before the command: pipette -vv tasks list" in counted.stderr
    other = run_cli("tasks", "list", "--no-such-option")
    assert other.exit_code == 2 and "hint:" not in other.stderr  # not a global option: no hint


def test_debug_shows_the_traceback(run_cli) -> None:
    result = run_cli("--debug", "tasks", "show", "Nope")
    assert result.exit_code == 1 and "Traceback" in result.stderr


def test_new_from_each_template_writes_a_valid_task(run_cli, tmp_path: Path) -> None:
    for template in ("pick", "place", "close_lid", "press_button"):
        task_id = f"mylab/Try{template.title().replace('_', '')}-v1"
        result = run_cli("tasks", "new", task_id, "--from", template, "--out", tmp_path)
        assert result.exit_code == 0, result.stderr
        written = next(tmp_path.glob(f"try_{template}.yaml"))
        spec = load_task_file(written)
        assert spec.id == task_id and "VERIFY" in written.read_text()
        assert "check the VERIFY fields, then: pipette tasks validate" in result.stderr
    drafted = run_cli("tasks", "new", "mylab/CloseLid-v1", "--from", "CloseMicrocentrifugeLid", "--out", tmp_path)
    assert drafted.exit_code == 0 and "check the VERIFY fields" in drafted.stderr  # a copy of a drafted task has some


def test_new_by_copying_keeps_comments_and_refuses_overwrite(run_cli, tmp_path: Path) -> None:
    out = tmp_path / "copy.yaml"
    args = ("tasks", "new", "mylab/PickUpTestTube-v2", "--from", "PickUpTestTube", "--out", out)
    first = run_cli(*args)
    assert first.exit_code == 0 and "VERIFY" not in out.read_text()
    assert f"wrote {out}; edit it, then: pipette tasks validate {out}" in first.stderr  # no VERIFY fields to check
    assert load_task_file(out).success.min_height_gain == 0.02
    assert "# paper A.8: z_t > z_0 + 0.02 m" in out.read_text()
    assert "paper-benchmark" not in load_task_file(out).tags  # a copy is not one of the twelve
    again = run_cli(*args)
    assert again.exit_code == 1 and "exists; pass --force" in again.stderr


def test_new_into_a_folder_that_does_not_exist_yet(run_cli, tmp_path: Path) -> None:
    result = run_cli("tasks", "new", "mylab/PickUpCryovial-v1", "--from", "pick", "--out", tmp_path / "packs" / "mylab")
    assert result.exit_code == 0, result.stderr
    assert load_task_file(tmp_path / "packs" / "mylab" / "pick_up_cryovial.yaml").id == "mylab/PickUpCryovial-v1"


def test_new_rejects_bad_ids_and_taken_ids(run_cli, tmp_path: Path) -> None:
    assert "must look like namespace/Name-v1" in run_cli("tasks", "new", "bad id", "--from", "pick").stderr
    taken = run_cli("tasks", "new", "pipette/PickUpTestTube-v1", "--from", "pick", "--out", tmp_path)
    assert taken.exit_code == 1 and "already registered" in taken.stderr
    typo = run_cli("tasks", "new", "mylab/PickUpCryovial-v1", "--from", "pik", "--out", tmp_path)
    assert typo.exit_code == 1 and "unknown template 'pik'" in typo.stderr and "'pick'" in typo.stderr
    assert not list(tmp_path.iterdir())


def test_registry_dir_option_adds_tasks(run_cli) -> None:
    result = run_cli("--registry-dir", FIXTURES / "dup", "tasks", "list", "--json")
    assert result.exit_code == 1 and "duplicate task id" in result.stderr


def test_version(run_cli) -> None:
    result = run_cli("--version")
    assert result.exit_code == 0 and result.stdout.startswith("pipette ")


def test_validate_names_the_seed_whose_randomised_layout_interpenetrates(run_cli, tmp_path: Path) -> None:
    # seed 0's layout is clear; the centrifuge's randomised pose brings the open lid over the
    # Panda's wrist from seed 1 on (the registry task before it moved out to 0.65 m)
    edit = ("pos: [0.65, 0.0, 0.55]", "pos: [0.58, 0.0, 0.55]")
    near, result, said = _validate_edited(run_cli, tmp_path, "close_centrifuge_lid.yaml", *edit)
    assert result.exit_code == 1
    assert f"{near}:{_line(near, 'pose:')}: scene.objects.0.pose: centrifuge and robot interpenetrate by " in said
    assert "on seed 1 (a randomised layout)" in said


def test_a_task_written_outside_the_registry_says_how_to_use_it(run_cli, tmp_path: Path) -> None:
    out = tmp_path / "my_tasks"
    result = run_cli(
        "tasks", "new", "mylab/PickUpCryovial-v1", "--from", "pick", "--asset", "cryovial_2ml", "--out", out
    )
    assert result.exit_code == 0, result.stderr
    hint = f"pipette --registry-dir {out} sim render mylab/PickUpCryovial-v1"
    assert hint in result.stderr and "is not a registry folder" in result.stderr
    shown = run_cli("--registry-dir", out, "sim", "render", "mylab/PickUpCryovial-v1", "--out", tmp_path / "v.png")
    assert shown.exit_code == 0, shown.stderr  # the command it suggests works
    inside = run_cli("--registry-dir", out, "tasks", "new", "mylab/PickUpVial-v1", "--from", "pick", "--out", out)
    assert "--registry-dir" not in inside.stderr.split("then use it")[1]  # already read: no flag needed
