"""The augmentation experiment's pre-registered rules (docs/reproduction/plan.md): the pilot's
choice of training steps and tasks, and the paired tests on synthetic outcomes."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest

PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "augmentation_experiment.py"
spec = importlib.util.spec_from_file_location("augmentation_experiment", PATH)
assert spec is not None and spec.loader is not None
experiment = importlib.util.module_from_spec(spec)
sys.modules["augmentation_experiment"] = experiment
spec.loader.exec_module(experiment)

HINGE, PLACE = "pipette/CloseCentrifugeLid-v1", "pipette/PlaceTubeOnBalance-v1"
PICK, LIFT, OTHER = "pipette/PickUpTestTube-v1", "pipette/OpenWaterBathLid-v1", "pipette/RemoveTubeFromBalance-v1"


def test_the_pilot_picks_the_fewest_steps_with_four_tasks_in_the_band_a_hinge_and_a_placement() -> None:
    rates = {
        HINGE: {500: 0.9, 1000: 0.5, 2000: 0.9, 4000: 1.0},
        PLACE: {500: 0.0, 1000: 0.1, 2000: 0.3, 4000: 0.6},
        PICK: {500: 0.2, 1000: 0.3, 2000: 0.5, 4000: 0.7},
        LIFT: {500: 0.3, 1000: 0.5, 2000: 0.6, 4000: 0.9},
        OTHER: {500: 0.1, 1000: 0.2, 2000: 0.4, 4000: 0.8},
    }
    # 1000: four in the band but no placement; 2000: four with the placement but no hinge (0.9):
    # no count meets the rule, so the most tasks in the band, fewer steps first
    assert experiment.choose(rates) == {"steps": 1000, "tasks": [HINGE, PICK, LIFT, OTHER], "rule_met": False}
    rates[HINGE][2000] = 0.85  # the band is closed: 85 % is in it
    assert experiment.choose(rates) == {"steps": 2000, "tasks": [HINGE, PLACE, PICK, LIFT, OTHER], "rule_met": True}


def test_without_a_qualifying_count_the_most_tasks_in_the_band_win_then_fewer_steps() -> None:
    rates = {HINGE: {500: 0.5, 1000: 0.5}, PICK: {500: 0.5, 1000: 0.5}, LIFT: {500: 1.0, 1000: 0.0}}
    assert experiment.choose(rates, (500, 1000)) == {"steps": 500, "tasks": [HINGE, PICK], "rule_met": False}


def test_with_no_hinge_in_the_band_the_least_saturated_kept_hinge_joins_amendments_2_and_3() -> None:
    close_spec, open_lid = "pipette/CloseSpectrophotometerLid-v1", "pipette/OpenCentrifugeLid-v1"
    rates = {  # the pilot of 2026-11-27 (the closes re-piloted with 15 demonstrations)
        PICK: {500: 6 / 30, 1000: 9 / 30, 2000: 13 / 30, 4000: 9 / 30},
        PLACE: {500: 1 / 30, 1000: 0.0, 2000: 9 / 30, 4000: 8 / 30},
        OTHER: {500: 0.0, 1000: 14 / 30, 2000: 20 / 30, 4000: 27 / 30},
        HINGE: {500: 1.0, 1000: 28 / 30, 2000: 1.0, 4000: 1.0},
        close_spec: {500: 1.0, 1000: 1.0, 2000: 1.0, 4000: 1.0},
        open_lid: {500: 0.0, 1000: 0.0, 2000: 0.0, 4000: 2 / 30},
    }
    choice = experiment.choose(rates)
    assert choice == {"steps": 2000, "tasks": [PICK, PLACE, OTHER], "rule_met": False}
    # the open lid is below the band at 4000 (dropped, step 4); of the two closes at 30/30, the one
    # with the lower success summed over the counts
    assert experiment.with_a_hinge(rates, choice) == {
        **choice,
        "tasks": [PICK, PLACE, OTHER, HINGE],
        "ceiling": [HINGE],
    }
    met = experiment.choose({**rates, HINGE: {500: 0.5, 1000: 0.5, 2000: 0.5, 4000: 0.5}})
    assert met["rule_met"] and experiment.with_a_hinge(rates, met) == met  # the rule met: nothing added


def outcomes(task: str, successes: list[int]) -> dict[tuple[str, int], bool]:
    return {(task, 100_000 + i): bool(s) for i, s in enumerate(successes)}


def test_paired_tests_per_task_and_pooled_with_holm() -> None:
    cells = {
        (PICK, "raw"): outcomes(PICK, [0] * 10 + [1] * 10),
        (PICK, "aug_all"): outcomes(PICK, [1] * 8 + [0] * 2 + [1] * 10),  # 8 discordant, all for aug_all
        (HINGE, "raw"): outcomes(HINGE, [1] * 20),
        (HINGE, "aug_all"): outcomes(HINGE, [1] * 19 + [0]),
        (HINGE, "aug_object"): outcomes(HINGE, [1] * 20),
    }
    rows = experiment.comparisons(cells, [PICK, HINGE])
    primary = {r["task"]: r for r in rows if r["family"] == "primary"}
    assert set(primary) == {PICK, HINGE, "pooled"}
    assert (primary[PICK]["only_b"], primary[PICK]["only_a"]) == (8, 0) and primary[PICK]["p_value"] == pytest.approx(
        2 / 2**8
    )
    assert primary[PICK]["p_holm"] == pytest.approx(2 * primary[PICK]["p_value"])  # Holm over the two tasks
    pooled = primary["pooled"]  # 40 paired episodes: 8 for aug_all, 1 for raw
    assert (pooled["n_a"], pooled["only_b"], pooled["only_a"]) == (40, 8, 1) and pooled["p_holm"] == pooled["p_value"]
    assert pooled["difference"] == pytest.approx(7 / 40) and pooled["significant"]
    secondary = [r for r in rows if r["family"] == "secondary"]
    assert [(r["comparison"], r["task"]) for r in secondary] == [  # only complete pairs: no pooled test
        ("aug_object vs raw", HINGE),
        ("aug_all vs aug_object", HINGE),
    ]
    text = "\n".join(experiment.suite_section("nominal", cells, [PICK, HINGE], rows))
    assert "| pipette/PickUpTestTube-v1 | 10/20 (30-70) | 18/20 (70-97) |" in text and "+40 pt" in text
    assert primary[PICK]["detectable"] == pytest.approx(
        8 / 20
    )  # of 8 discordant pairs only 8-0 is significant (7-1: p=0.07)
    assert primary[HINGE]["detectable"] is None  # one discordant pair can never be significant
    cells[(PICK, "aug_all_seed1001")] = outcomes(PICK, [1] * 5)  # 5 of 20 episodes evaluated so far
    text = "\n".join(experiment.suite_section("nominal", cells, [PICK, HINGE], rows))
    assert "| pipette/PickUpTestTube-v1 | 5/5 (57-100) (running) |" in text  # amendments' settings apart
    assert "aug_all_seg" not in text  # no cell of it yet: no column


class Task:
    def __init__(self, id: str) -> None:
        self.id = id


def test_tasks_above_the_band_are_piloted_again_with_half_the_demonstrations(tmp_path, monkeypatch) -> None:
    full = {  # 30 demonstrations: both hinges at the ceiling, so no count meets the rule
        HINGE: {500: 0.9, 1000: 1.0},
        "pipette/CloseSpectrophotometerLid-v1": {500: 1.0, 1000: 1.0},
        PLACE: {500: 0.3, 1000: 0.5},
        PICK: {500: 0.2, 1000: 0.4},
        LIFT: {500: 0.1, 1000: 0.05},  # below the band: not piloted again, not chosen
    }
    half = {HINGE: {500: 0.5, 1000: 0.8}, "pipette/CloseSpectrophotometerLid-v1": {500: 0.9, 1000: 0.9}}
    seen: list[tuple[str, int, str]] = []

    def rates(ex, task):
        seen.append((task.id, ex.demos_of(task), ex.folder(task).name))
        return (half if ex.demos_of(task) < ex.demos else full)[task.id]

    monkeypatch.setattr(experiment, "pilot_rates", rates)
    ex = experiment.Experiment(tmp_path, 1, 64, "fast", pilot_steps=(500, 1000))
    data = experiment.pilot(ex, [Task(t) for t in full], tmp_path / "docs")
    # first pass: 500 steps has the most tasks in the band (hinge 0.9 is above it); the two hinges
    # above the band at 500 are piloted again with 15 demonstrations, in their own folders
    assert seen[5:] == [
        (HINGE, 15, "pipette_CloseCentrifugeLid-v1@15demos"),
        ("pipette/CloseSpectrophotometerLid-v1", 15, "pipette_CloseSpectrophotometerLid-v1@15demos"),
    ]
    assert data["first_pass"]["steps"] == 500 and not data["first_pass"]["rule_met"]
    assert (data["steps"], data["tasks"], data["rule_met"]) == (500, [HINGE, PLACE, PICK], False)
    assert data["demos_per_task"][HINGE] == 15 and data["demos_per_task"][PICK] == 30
    assert experiment.json.loads((tmp_path / "docs" / "pilot.json").read_text())["success"][HINGE] == {
        "500": 0.5,
        "1000": 0.8,
    }
    full[LIFT], full[HINGE] = {500: 0.2, 1000: 0.3}, {500: 0.5, 1000: 1.0}
    seen.clear()
    met = experiment.pilot(ex, [Task(t) for t in full], tmp_path / "docs")
    assert met["rule_met"] and met["steps"] == 500 and len(seen) == 5  # the rule met: nothing again
    assert "first_pass" not in met and set(met["demos_per_task"].values()) == {30}


def test_training_loss_is_read_from_the_lerobot_log_near_each_mark(tmp_path) -> None:
    ex = experiment.Experiment(tmp_path, 1, 64, "fast")
    task = Task(PICK)
    log = ex.folder(task, "raw", "train", "act")
    log.mkdir(parents=True)
    lines = [f"INFO step:{20 * i} smpl:{160 * i} ep:1 epch:0.1 loss:{1 / i:.4f} grdn:1.0" for i in range(1, 101)]
    (log / "run.log").write_text("\n".join(lines))
    loss = experiment.training_loss(ex, task, "raw", [100, 2000, 4000])
    assert loss["100"] == pytest.approx(sum(1 / i for i in range(1, 6)) / 5, abs=1e-4)
    assert loss["2000"] == pytest.approx(sum(1 / i for i in range(96, 101)) / 5, abs=1e-4)
    assert loss["4000"] is None  # the log stops at 2000
    (log / "run.log").write_text("\n".join([*lines, "--resume=true"]))
    assert set(experiment.training_loss(ex, task, "raw", [100]).values()) == {None}


def test_a_training_continued_from_a_checkpoint_is_named_as_resumed(tmp_path) -> None:
    ex = experiment.Experiment(tmp_path / "work", 1, 64, "fast", keep=tmp_path / "kept")
    task = Task(PICK)
    assert experiment.training_log(ex, task, "raw") == "" and not experiment.resumed("")
    kept = ex.keep / ex.folder(task, "raw", "train", "act").relative_to(ex.work)
    kept.mkdir(parents=True)
    (kept / "run.log").write_text("lerobot-train --steps=2000 --resume=true\nINFO step:1K loss:0.5")
    assert experiment.resumed(experiment.training_log(ex, task, "raw"))  # read from the kept copy
    here = ex.folder(task, "raw", "train", "act")
    here.mkdir(parents=True)
    (here / "run.log").write_text("lerobot-train --steps=2000\nINFO step:20 loss:0.5")
    assert not experiment.resumed(experiment.training_log(ex, task, "raw"))  # this machine's run first


def test_a_kept_training_log_loses_its_progress_bar_and_keeps_every_loss_line(tmp_path) -> None:
    ex = experiment.Experiment(tmp_path / "work", 1, 64, "fast", keep=tmp_path / "keep")
    task = Task(PICK)
    log = ex.folder(task, "raw", "train", "act", "run.log")
    log.parent.mkdir(parents=True)
    bar = "Training:  {p}%|{b}| {i}/2000 [00:{s:02d}<53:04,  1.61s/step]"
    text = "# pipette train: lerobot-train --steps=2000\nWARNING: could not load libtorchcodec\n"
    for i in range(1, 101):
        redraws = "".join("\r" + bar.format(p=i // 20, b="#" * (i // 10), i=20 * i - k, s=k) for k in range(19, -1, -1))
        text += redraws + f"INFO step:{20 * i} smpl:{160 * i} ep:1 epch:0.1 loss:{1 / i:.4f} grdn:1.0\n"
    log.write_text(text + "\r" + bar.format(p=100, b="#" * 10, i=2000, s=0) + "\n")
    marks = [100, 1000, 2000]
    before = experiment.training_loss(ex, task, "raw", marks)

    experiment.kept(ex, log)
    copy = ex.keep / log.relative_to(ex.work)
    assert "Training:" not in copy.read_text() and len(copy.read_text()) < len(text) / 10
    assert copy.read_text().splitlines()[:2] == text.splitlines()[:2]  # the command and the warnings stay
    log.unlink()
    assert experiment.training_loss(ex, task, "raw", marks) == before  # read from the kept copy
    assert before["2000"] == pytest.approx(sum(1 / i for i in range(96, 101)) / 5, abs=1e-4)


def test_amendment_1_compares_clutter_augmentation_on_the_clutter_suite_in_its_own_family() -> None:
    cells = {
        (PICK, "raw"): outcomes(PICK, [0] * 10 + [1] * 10),
        (PICK, "aug_all"): outcomes(PICK, [0] * 12 + [1] * 8),
        (PICK, "aug_clutter"): outcomes(PICK, [1] * 20),
    }
    rows = experiment.comparisons(cells, [PICK], "clutter")
    assert {r["family"] for r in rows} == {"amendment 1"}
    assert [(r["comparison"], r["task"]) for r in rows] == [  # one task: no pooled test (it would be the same)
        ("aug_clutter vs raw", PICK),
        ("aug_all vs raw", PICK),
        ("aug_clutter vs aug_all", PICK),
    ]
    holm = experiment.holm([r["p_value"] for r in rows])  # Holm over the family's three tests together
    assert [r["p_holm"] for r in rows] == pytest.approx(holm) and rows[0]["p_holm"] == pytest.approx(
        2 * rows[0]["p_value"]
    )
    cells[(PLACE, "raw")] = outcomes(PLACE, [0] * 20)
    cells[(PLACE, "aug_all")] = outcomes(PLACE, [0] * 20)
    cells[(PLACE, "aug_clutter")] = outcomes(PLACE, [1] * 20)
    rows = experiment.comparisons(cells, [PICK, PLACE], "clutter")
    pooled = [r for r in rows if r["task"] == "pooled"]
    assert [r["comparison"] for r in pooled] == ["aug_clutter vs raw", "aug_all vs raw", "aug_clutter vs aug_all"]
    assert [r["p_holm"] for r in rows] == pytest.approx(experiment.holm([r["p_value"] for r in rows]))  # all nine
    assert experiment.SUITE_SETTINGS["clutter"][:3] == ("raw", "aug_all", "aug_clutter")  # then amendment 5
    assert "aug_clutter" not in experiment.SUITE_SETTINGS["nominal"]  # the pre-registered families stay as they were


def test_the_report_states_the_ceiling_and_the_faults_found_after_the_plan_was_frozen() -> None:
    notes = experiment.task_notes([PICK, HINGE, PLACE], ceiling=[HINGE])
    assert list(notes) == [HINGE]  # the others have nothing said beside them
    ceiling, fault = notes[HINGE]
    assert "amendment 3" in ceiling and "only a loss" in ceiling
    assert "amendment 4" in fault and "45 of the 50 suite seeds" in fault


def test_amendment_5_runs_the_segmented_settings_only_where_the_program_hands_over() -> None:
    from pipette_cli.registry import load_registry

    registry = load_registry()
    assert experiment.segmented(registry.get(PLACE))  # place_on balance/pan_center
    assert not any(experiment.segmented(registry.get(t)) for t in (PICK, OTHER, HINGE))
    assert experiment.VARIANTS["aug_all_seg"] == experiment.VARIANTS["aug_all"]  # same data spec, newer code
    shifted = dict(experiment.families("shifted"))["amendment 5"]
    assert ("aug_all", "aug_all_seg") in shifted and ("aug_object", "aug_object_seg") in shifted
    assert ("aug_object", "aug_object_seg") not in dict(experiment.families("nominal"))["amendment 5"]


def test_amendment_6_trains_the_augmented_data_for_as_many_passes_as_raw_gets(tmp_path) -> None:
    from pipette_cli.demos.recorder import EpisodeSummary
    from pipette_cli.demos.store import EpisodeRef

    ex = experiment.Experiment(tmp_path, 1, 64, "fast", 30, (500,), 30, None, 1)
    lengths = {"raw": [134] * 30, "aug_all": [134] * 175}  # 5.8 times the frames

    def scan(path):
        refs = [
            EpisodeRef(i, path, "", EpisodeSummary(i, i, "scripted", n, True, "", {}, ""), False)
            for i, n in enumerate(lengths[path.stem])
        ]
        return type("Status", (), {"episodes": refs})()

    task = type("Task", (), {"id": PICK})()
    original, experiment.scan = experiment.scan, scan
    try:
        assert experiment.matched_steps(ex, task, "aug_all", 2000) == 12000  # 2000 x 5.83, up to 500s
        assert experiment.matched_steps(ex, task, "raw", 2000) == 2000
    finally:
        experiment.scan = original
    assert experiment.EPOCH_MATCHED["aug_all_ep"] == "aug_all"
    pairs = dict(experiment.families("nominal"))["amendment 6"]
    assert ("raw", "aug_all_ep") in pairs and ("more_demos_ep", "aug_all_ep") in pairs
    assert ("more_demos_ep", "aug_all_ep") not in dict(experiment.families("clutter"))["amendment 6"]


def test_amendment_10_is_aug_all_with_corrective_noise_compared_in_its_own_family() -> None:
    from pipette_cli.augment.specs import default_atoms, make_variants
    from pipette_cli.specs.perturbations import JointNoiseSpec, ObjectPoseSpec

    dart = experiment.VARIANTS["aug_all_dart"]
    assert dart == experiment.VARIANTS["aug_all"].replace("table*5", "table+noise*5")
    atoms = default_atoms(**(experiment.ATOMS | experiment.SETTING_ATOMS["aug_all_dart"]))
    variants = make_variants(dart.split(","), atoms)
    assert [v.name for v in variants][:2] == ["original", "object+light+cam+table+noise@1"] and len(variants) == 6
    noise, moved = variants[1].get(JointNoiseSpec), variants[1].get(ObjectPoseSpec)
    assert isinstance(noise, JointNoiseSpec) and isinstance(moved, ObjectPoseSpec)
    default = JointNoiseSpec()
    assert noise.corrective and (noise.sigma, noise.bound) == (default.sigma, default.bound)
    assert moved.task_range == experiment.ATOMS["object"]["task_range"]  # the rest as aug_all's
    assert experiment.EPOCH_MATCHED["aug_all_dart_ep"] == "aug_all_dart" and experiment.MATCHED_ABOVE["aug_all_dart_ep"]
    for suite in ("nominal", "shifted", "clutter"):
        assert {"aug_all_dart", "aug_all_dart_ep"} <= set(experiment.SUITE_SETTINGS[suite])
        pairs = dict(experiment.families(suite))["amendment 10"]
        assert ("aug_all", "aug_all_dart") in pairs and ("raw", "aug_all_dart") in pairs
    cells = {
        (PICK, "raw"): outcomes(PICK, [0] * 10 + [1] * 10),
        (PICK, "aug_all"): outcomes(PICK, [0] * 16 + [1] * 4),
        (PICK, "aug_all_dart"): outcomes(PICK, [1] * 20),
    }
    rows = [r for r in experiment.comparisons(cells, [PICK], "shifted") if r["family"] == "amendment 10"]
    assert [r["comparison"] for r in rows] == ["aug_all_dart vs aug_all", "aug_all_dart vs raw"]
    assert [r["p_holm"] for r in rows] == pytest.approx(experiment.holm([r["p_value"] for r in rows]))


def test_amendment_12_drifts_the_corrective_noise_and_compares_it_with_amendment_10s() -> None:
    from pipette_cli.augment.specs import default_atoms, make_variants
    from pipette_cli.specs.perturbations import JointNoiseSpec

    assert experiment.VARIANTS["aug_all_drift"] == experiment.VARIANTS["aug_all_dart"]
    atoms = default_atoms(**(experiment.ATOMS | experiment.SETTING_ATOMS["aug_all_drift"]))
    noise = make_variants(experiment.VARIANTS["aug_all_drift"].split(","), atoms)[1].get(JointNoiseSpec)
    assert isinstance(noise, JointNoiseSpec)
    assert (noise.sigma, noise.bound, noise.window, noise.corrective) == (0.01, 0.03, 15, True)
    assert experiment.EPOCH_MATCHED["aug_all_drift_ep"] == "aug_all_drift"
    for suite in ("nominal", "shifted", "clutter"):
        pairs = dict(experiment.families(suite))["amendment 12"]
        assert ("aug_all_dart", "aug_all_drift") in pairs and ("raw", "aug_all_drift") in pairs
        assert "aug_all_drift" in experiment.SUITE_SETTINGS[suite]


def test_amendment_14_holds_aug_alls_variants_followed_by_drift_on_the_demonstrated_placement() -> None:
    from pipette_cli.augment.specs import default_atoms, make_variants
    from pipette_cli.specs.perturbations import JointNoiseSpec, ObjectPoseSpec

    atoms = default_atoms(**(experiment.ATOMS | experiment.SETTING_ATOMS["aug_all_plus_drift"]))
    plus = make_variants(experiment.VARIANTS["aug_all_plus_drift"].split(","), atoms)
    alone = make_variants(experiment.VARIANTS["aug_all"].split(","), default_atoms(**experiment.ATOMS))
    assert plus[: len(alone)] == alone and len(plus) == len(alone) + 5  # the same names, so the same draws
    for added in plus[len(alone) :]:
        noise = added.get(JointNoiseSpec)
        assert isinstance(noise, JointNoiseSpec) and added.get(ObjectPoseSpec) is None  # objects where shown
        assert noise.model_dump(include=set(experiment.DRIFT)) == experiment.DRIFT
    assert experiment.SETTING_ATOMS["aug_all_drift"]["noise"] == experiment.DRIFT  # amendment 12's drift
    assert experiment.CONTAINS["aug_all_plus_drift"] == "aug_all"
    assert "aug_all_plus_drift" not in experiment.EPOCH_MATCHED  # no matched-passes cell
    for suite in ("nominal", "shifted", "clutter"):
        assert "aug_all_plus_drift" in experiment.SUITE_SETTINGS[suite]
        pairs = dict(experiment.families(suite))["amendment 14"]
        assert pairs == [
            ("aug_all", "aug_all_plus_drift"),
            ("aug_all_drift", "aug_all_plus_drift"),
            ("raw", "aug_all_plus_drift"),
        ]


def test_a_setting_that_mixes_kinds_of_variant_gets_a_yield_line_per_kind() -> None:
    def row(variant: str, kept: int) -> dict[str, Any]:
        return {"variant": variant, "kept": kept, "attempts": 30}

    report = {"variants": [row("original", 30), row("object+cam@1", 20), row("object+cam@2", 10), row("noise@1", 25)]}
    assert experiment.yield_by_kind(report) == {"original": (30, 30), "object+cam": (30, 60), "noise": (25, 30)}
    task = type("Task", (), {"id": PICK})()
    lines = experiment.yield_by_kind_lines(
        {PICK: {"mixed": report, "one": {"variants": report["variants"][:3]}}}, [task]
    )
    assert [line for line in lines if line.startswith(f"| {PICK}")] == [
        f"| {PICK} mixed: object+cam | 30/60 |",
        f"| {PICK} mixed: noise | 25/30 |",
    ]
    assert experiment.yield_by_kind_lines({PICK: {"one": {"variants": report["variants"][:3]}}}, [task]) == []


def pick_and_suites() -> tuple[Any, dict[str, Any]]:
    """PickUpTestTube and the experiment's three registered suites, by name."""
    from pipette_cli.evaluation.suites import load_suites
    from pipette_cli.registry import load_registry

    registry = load_registry()
    found = load_suites(registry)
    names = {"nominal": experiment.NOMINAL, "shifted": experiment.SHIFTED, "clutter": experiment.CLUTTER}
    return registry.get(PICK), {name: found.get(suite) for name, suite in names.items()}


def test_amendment_7_a_new_machine_restores_the_kept_logs_and_runs_only_unfinished_settings(
    tmp_path, monkeypatch
) -> None:
    task, suites = pick_and_suites()
    ex = experiment.Experiment(tmp_path / "work", 1, 64, "fast", keep=tmp_path / "keep")
    raw = experiment.evaluations(ex, task, "raw", 2000, suites)
    # raw: the three suites and its learning curve at S/4 and S/2, each of the suite's 50 episodes
    assert [label for label, *_ in raw] == ["raw", "raw", "raw", "raw@500", "raw@1000"]
    assert [step for _, _, step, _, _ in raw] == [None, None, None, 500, 1000]
    for _, folder, _, plan, _ in raw:
        folder.mkdir(parents=True)
        for i in range(len(plan)):
            (folder / f"episode_{i:04d}.json").write_text(
                f'{{"episode": {i}, "seed": {plan[i].seed}, "success": true}}'
            )
        experiment.kept(ex, folder)
    log = ex.folder(task, "raw", "train_2000", "act", "run.log")
    log.parent.mkdir(parents=True)
    log.write_text("INFO step:20 smpl:160 ep:1 epch:0.1 loss:0.5000 grdn:1.0\n")
    experiment.kept(ex, log)
    half = ex.folder(task, "eval", "nominal", "aug_object")  # an evaluation stopped half way: not kept
    half.mkdir(parents=True)
    (half / "episode_0000.json").write_text("{}")

    experiment.shutil.rmtree(ex.work)  # a new machine: only the kept files are left
    assert experiment.restore(ex) == sum(len(plan) for _, _, _, plan, _ in raw)  # the logs, not the training log
    assert not log.exists() and experiment.training_loss(ex, task, "raw", [20]) == {"20": 0.5}
    assert all(experiment.finished(ex, folder, plan) for _, folder, _, plan, _ in raw)
    assert not experiment.finished(ex, half, raw[0][3])

    built: list[list[str]] = []

    def data(ex, task, settings):
        built.append(settings)
        raise RuntimeError("stop before recording")

    monkeypatch.setattr(experiment, "data", data)
    experiment.run_task(ex, task, 2000, suites, ["raw"])  # finished: nothing recorded, nothing trained
    assert built == []
    with pytest.raises(RuntimeError, match="stop before recording"):
        experiment.run_task(ex, task, 2000, suites, ["raw", "aug_object"])
    assert built == [["aug_object"]]

    # a setting trained again with some of its evaluations kept (amendment 11): only the others are evaluated
    evaluated: list[str] = []
    monkeypatch.setattr(experiment, "data", lambda ex, task, settings: {settings[0]: tmp_path / "raw.h5"})
    monkeypatch.setattr(experiment, "trained", lambda *args, **kwargs: tmp_path / "run")
    monkeypatch.setattr(experiment, "checkpoint", lambda run, step, total: run / str(step))
    monkeypatch.setattr(
        experiment, "evaluated", lambda ex, task, policy, label, into, plan, suite: evaluated.append(str(into))
    )
    ex.folder(task, "eval", "curve", "raw@500").joinpath("episode_0000.json").unlink()  # one evaluation unfinished
    experiment.run_task(ex, task, 2000, suites, ["raw"])
    assert evaluated == [str(ex.folder(task, "eval", "curve", "raw@500"))]


def test_amendment_8_replicates_train_the_same_data_with_other_seeds_and_are_read_across_seeds(
    tmp_path, monkeypatch
) -> None:
    task, suites = pick_and_suites()
    ex = experiment.Experiment(tmp_path / "work", 1, 64, "fast")
    # evaluated on the nominal and shifted suites, with no learning curve
    assert [
        (label, f.parent.name) for label, f, *_ in experiment.evaluations(ex, task, "aug_all_seed1001", 2000, suites)
    ] == [
        ("aug_all_seed1001", "nominal"),
        ("aug_all_seed1001", "shifted"),
    ]
    trained = []

    def train_checkpoint(task_id, options, on_train):
        trained.append(options)
        return options.output_root / "act" / "run" / "checkpoints" / "last" / "pretrained_model"

    monkeypatch.setattr(experiment, "train_checkpoint", train_checkpoint)
    monkeypatch.setattr(experiment, "convert", lambda sources, options: pytest.fail("aug_all's dataset is converted"))
    dataset = ex.folder(task, "aug_all", "datasets", PICK.replace("/", "_"), "augmented", "meta", "info.json")
    dataset.parent.mkdir(parents=True)
    dataset.write_text("{}")
    for setting, seed in (("aug_all", 1000), ("aug_all_seed1002", 1002)):
        run = experiment.trained(ex, task, setting, ex.folder(task, "aug_all.h5"), 2000, 500)
        options = trained[-1]
        assert options.datasets_root == ex.folder(task, "aug_all", "datasets")  # the same data
        assert {f for f in options.extra if f.startswith("--seed=")} == {f"--seed={seed}"} and options.steps == 2000
        assert run == ex.folder(task, setting, "train", "act", "run")  # its own run

    # read across seeds: every aug_all seed against every raw seed, and the seed-matched pairs pooled
    cells = {}
    for i, (raw, aug) in enumerate([(5, 9), (7, 8), (4, 12)]):
        suffix = "" if i == 0 else f"_seed{experiment.REPLICATE_SEEDS[i - 1]}"
        cells[(PICK, f"raw{suffix}")] = outcomes(PICK, [1] * raw + [0] * (20 - raw))
        cells[(PICK, f"aug_all{suffix}")] = outcomes(PICK, [1] * aug + [0] * (20 - aug))
    cells[(HINGE, "raw")] = cells[(HINGE, "aug_all")] = outcomes(HINGE, [1] * 20)  # its replicates not run yet
    rows = experiment.replicate_rows(cells, [PICK, HINGE])
    assert [r["task"] for r in rows] == [PICK]
    row = rows[0]
    assert row["raw"] == [5, 7, 4] and row["aug_all"] == [9, 8, 12] and row["seeds"] == [1000, 1001, 1002]
    assert min(row["crossed_differences"]) == 1 and max(row["crossed_differences"]) == 8 and row["same_sign"]
    assert row["mean_difference"] == pytest.approx((29 - 16) / 3 / 20)
    # 60 seed-matched pairs: aug_all alone succeeds on 13 (4 + 1 + 8), raw alone on none
    assert row["p_value"] == pytest.approx(2 / 2**13) and row["significant"]
    cells[(PICK, "raw_seed1002")] = outcomes(PICK, [1] * 10 + [0] * 10)  # one seed pair now goes the other way
    assert not experiment.replicate_rows(cells, [PICK])[0]["same_sign"]
    cells[(PICK, "aug_all_seed1002")] = outcomes(PICK, [1] * 12 + [0] * 3)  # still being evaluated: not read yet
    assert experiment.replicate_rows(cells, [PICK]) == []
    text = "\n".join(experiment.replicate_section("nominal", rows))
    assert "| 5, 7, 4 | 9, 8, 12 | +22 pt | +1 to +8 | yes |" in text
    assert "PickUpTestTube-v1 aug_object: 14/50" in text  # the lost run's realization beside it


def test_amendment_16_replicates_aug_all_plus_drift_and_reads_it_against_raws_seeds(tmp_path, monkeypatch) -> None:
    task, suites = pick_and_suites()
    ex = experiment.Experiment(tmp_path / "work", 1, 64, "fast")
    assert experiment.data_of("aug_all_plus_drift_seed1001") == "aug_all_plus_drift"
    assert [
        f.parent.name for _, f, *_ in experiment.evaluations(ex, task, "aug_all_plus_drift_seed1002", 2000, suites)
    ] == [
        "nominal",
        "shifted",
    ]
    cells = {}
    for i, (raw, aug, drift) in enumerate([(6, 2, 14), (8, 3, 9), (5, 9, 13)]):
        suffix = "" if i == 0 else f"_seed{experiment.REPLICATE_SEEDS[i - 1]}"
        for setting, k in (("raw", raw), ("aug_all", aug), ("aug_all_plus_drift", drift)):
            cells[(PICK, f"{setting}{suffix}")] = outcomes(PICK, [1] * k + [0] * (20 - k))
    rows = experiment.replicate_rows(cells, [PICK], "aug_all_plus_drift")
    assert rows[0]["setting"] == "aug_all_plus_drift" and rows[0]["aug_all_plus_drift"] == [14, 9, 13]
    assert min(rows[0]["crossed_differences"]) == 1 and rows[0]["same_sign"]
    assert not experiment.replicate_rows(cells, [PICK])[0]["same_sign"]  # amendment 8's aug_all: 9 - 8 > 0 > 2 - 6
    text = "\n".join(experiment.replicate_section("shifted", rows, "amendment 16"))
    assert "(amendment 16: aug_all_plus_drift)" in text and "| 6, 8, 5 | 14, 9, 13 |" in text
    assert "aug_object: 14/50" not in text  # the lost run's counts are amendment 8's
    del cells[(PICK, "aug_all_plus_drift_seed1002")]  # a seed not run yet: no row
    assert experiment.replicate_rows(cells, [PICK], "aug_all_plus_drift") == []


def test_data_hashes_follow_the_arrays_but_not_wall_time_or_string_pointers(tmp_path, monkeypatch) -> None:
    import h5py
    import numpy as np

    ex = experiment.Experiment(tmp_path, 1, 64, "fast")
    task, _ = pick_and_suites()
    folder = ex.folder(task)
    folder.mkdir(parents=True)

    def write(name: str, action: float, wall: float) -> None:
        with h5py.File(folder / name, "w") as f:
            g = f.create_group("episodes/episode_000000")
            g["action"] = np.full((3, 8), action)
            g["wall_time"] = np.full(3, wall)
            g["instruction"] = np.array([b"pick up the tube"] * 3, dtype=object)

    write("a.h5", 0.5, 1.0)
    write("b.h5", 0.5, 2.0)  # another wall time only
    write("c.h5", np.nextafter(0.5, 1.0), 1.0)  # one action one ulp apart
    monkeypatch.setattr(experiment, "scan", lambda path: type("Status", (), {"episodes": [], "pending": []})())
    found = experiment.data_hashes(ex, task)
    files = found["files"]
    assert files["a.h5"]["arrays"] == 2 and "avx512f" in found and found["machine"]
    assert files["a.h5"]["sha256_of_arrays"] == files["b.h5"]["sha256_of_arrays"]
    assert files["a.h5"]["sha256_of_arrays"] != files["c.h5"]["sha256_of_arrays"]
    assert list(files["a.h5"]["some_arrays"]) == ["episodes/episode_000000/action"]


def test_the_report_holds_the_training_step_before_and_after_from_the_side_by_side_runs(tmp_path) -> None:
    import json

    def run(before: float, after: float, loads: list[float]) -> dict:
        rows = {
            "before": {"what": "old preset", "s_per_step": before, "load": loads[:1]},
            "after": {"what": "new preset", "s_per_step": after, "load": loads[1:]},
        }
        return {"settings": {"git_commit": "abc1234def"}, "rows": rows}

    (tmp_path / "shared.json").write_text(json.dumps(run(4.0, 0.5, [7.0, 3.5])))
    (tmp_path / "idle.json").write_text(json.dumps(run(0.37, 0.45, [0.2, 1.7])))
    found, lines = experiment.training_speed(
        {"shared": tmp_path / "shared.json", "idle": tmp_path / "idle.json", "absent": tmp_path / "none.json"}
    )
    assert set(found) == {"shared", "idle"}  # a run that is not there is left out, not invented
    assert found["shared"]["speedup"] == pytest.approx(8.0) and found["idle"]["speedup"] == pytest.approx(0.37 / 0.45)
    assert found["shared"]["load_average"] == [3.5, 7.0]
    assert "| idle | 0.370 | 0.450 | 0.82x | abc1234 | 0.2-1.7 |" in lines
    assert all(path.is_file() for path in experiment.SPEED_RUNS.values())  # the committed runs the report reads


def test_failures_are_counted_by_reason_with_the_metrics_of_the_failed_episodes(tmp_path) -> None:
    import json

    def log(i: int, success: bool, reason: str | None, gain: float) -> None:
        entry = {"task": PICK, "episode": i, "seed": 100000 + i, "success": success, "failure_reason": reason}
        (tmp_path / f"episode_{i:04d}.json").write_text(json.dumps(entry | {"metrics": {"height_gain": gain}}))

    log(0, True, None, 0.1)  # a success's metrics are not a failure's
    log(1, False, "not_lifted", 0.002)
    log(2, False, "tilted", 0.004)
    log(3, False, "not_lifted", 0.0)
    modes = experiment.failure_modes(tmp_path)
    assert modes == {"reasons": {"not_lifted": 2, "tilted": 1}, "mean_metric_at_failure": {"height_gain": 0.002}}
    text = "\n".join(experiment.failure_section("nominal", {f"{PICK} raw": modes, f"{PICK} aug_all": {"reasons": {}}}))
    assert f"| {PICK} raw | not_lifted 2, tilted 1 | height_gain 0.002 |" in text
    assert "aug_all" not in text  # a cell without failures (or not run) has no row


def test_the_code_that_made_a_dataset_lost_with_its_machine_stays_listed(tmp_path, monkeypatch) -> None:
    work, keep = tmp_path / "work", tmp_path / "keep"
    ex = experiment.Experiment(work, 1, 64, "fast", 30, (500,), 30, None, 1, keep=keep)
    task = type("Task", (), {"id": PICK})()
    folder = ex.folder(task)
    folder.mkdir(parents=True)
    (folder / "data_code.json").write_text('{"aug_all.h5": ["old run"], "more_demos.h5": ["old run"]}')
    (folder / "aug_all.h5").write_bytes(b"")  # made again on this machine
    monkeypatch.setattr(experiment, "scan", lambda path: path)
    monkeypatch.setattr(experiment, "made_by", lambda status: ["this run"])
    code = experiment.data_code(ex, task)
    assert code == {"aug_all.h5": ["old run", "this run"], "more_demos.h5": ["old run"]}  # lost file still listed
    kept = keep / folder.name / "data_code.json"
    assert kept.is_file() and experiment.json.loads(kept.read_text()) == code  # the next machine restores it
