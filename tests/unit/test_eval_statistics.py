"""Statistics of evaluation results: intervals and tests against published values, run folders
(resume rules, summaries rebuilt from logs), and the report's pairing of raw and augmented."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest

from pipette_cli.errors import DatasetError
from pipette_cli.evaluation.evaluate import EpisodeLog, stage_progress
from pipette_cli.evaluation.report import _label_lines, bar_chart, build_report, load_runs, markdown, to_json
from pipette_cli.evaluation.results import make_manifest, prepare_folder, summarize, write_episode, write_summary
from pipette_cli.evaluation.settings import DecodeConfig
from pipette_cli.evaluation.significance import compare, fisher_exact, holm, mcnemar_exact, wilson_interval
from pipette_cli.evaluation.suites import adhoc_plan
from pipette_cli.registry import load_registry

TASK = load_registry().get("PickUpTestTube")


def test_wilson_interval_matches_published_values() -> None:
    # Brown, Cai & DasGupta (2001) and Newcombe (1998): 81/263 -> (0.2553, 0.3662); 0/10 -> (0, 0.2775)
    assert wilson_interval(81, 263) == pytest.approx((0.2553, 0.3662), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson_interval(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)
    assert wilson_interval(7, 10) == pytest.approx((0.3968, 0.8922), abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_exact_tests_match_hand_computed_values() -> None:
    assert mcnemar_exact(1, 9) == pytest.approx(2 * (1 + 10) / 1024)  # 2 * P(X <= 1), X ~ Bin(10, 1/2)
    assert mcnemar_exact(0, 5) == pytest.approx(2 / 32)
    assert mcnemar_exact(3, 3) == 1.0 and mcnemar_exact(0, 0) == 1.0
    assert fisher_exact(7, 10, 10, 10) == pytest.approx(4 / 19)  # P(table) = C(10,7)C(10,10)/C(20,17) = 2/19, twice
    assert fisher_exact(3, 4, 1, 4) == pytest.approx(0.4857, abs=1e-4)  # the tea-tasting table: R's fisher.test
    assert holm([0.01, 0.04, 0.03, 0.5]) == pytest.approx([0.04, 0.09, 0.09, 0.5])


def test_compare_pairs_the_same_episodes_and_falls_back_to_fisher() -> None:
    raw = {(s, "i"): s < 3 for s in range(10)}  # seeds 0-2 succeed
    aug = {(s, "i"): s < 9 for s in range(10)}  # seeds 0-8 succeed: 6 discordant pairs, all for augmented
    paired = compare(raw, aug)
    assert (paired.test, paired.only_a, paired.only_b) == ("mcnemar_exact", 0, 6)
    assert paired.p_value == pytest.approx(2 / 64) and paired.significant and paired.difference == pytest.approx(0.6)
    unpaired = compare(raw, {(s + 100, "i"): v for (s, _), v in aug.items()})  # other seeds: independent samples
    assert unpaired.test == "fisher_exact" and unpaired.p_value == pytest.approx(fisher_exact(3, 10, 9, 10))
    assert compare((3, 10), (9, 10)).p_value == unpaired.p_value


def test_stage_progress_comes_from_a_sequence_criterion_only() -> None:
    assert stage_progress({"stage": 1.0, "stages": 4.0}) == 0.25
    assert stage_progress({"height_gain": 0.01}) is None and stage_progress({"stage": 1.0}) is None


def episode(
    index: int, seed: int, success: bool, *, instruction: str = TASK.instruction, stage: int | None = None
) -> EpisodeLog:
    metrics = {"stage": float(stage), "stages": 3.0} if stage is not None else {}
    return EpisodeLog(
        TASK.id,
        index,
        seed,
        instruction,
        success,
        None if success else "not_lifted",
        1.0,
        7.0,
        210,
        30.0,
        70,
        10.0,
        0,
        False,
        "act",
        {"open": 0.5, "stay_open": 0.5},
        metrics,
        stage_progress(metrics),
    )


def run_folder(
    folder: Path, outcomes: list[bool], *, version: str = "raw", seed: int = 100, stages: list[int] | None = None
) -> Path:
    plan = adhoc_plan(TASK, len(outcomes), seed)
    manifest = make_manifest(
        TASK,
        plan,
        suite=None,
        image_size=64,
        render_profile="fast",
        policy={"kind": "server", "endpoints": ["tcp://a:1"]},
        config=DecodeConfig.for_policy("act"),
        dataset_version=version,
    )
    prepare_folder(folder, manifest)
    for e, ok in zip(plan, outcomes, strict=True):
        write_episode(folder, episode(e.index, e.seed, ok, stage=None if stages is None else stages[e.index]))
    return folder


def test_a_run_folder_resumes_only_the_same_plan(tmp_path) -> None:
    folder = run_folder(tmp_path / "r", [True, False, True])
    plan = adhoc_plan(TASK, 3, 100)

    def manifest(**change):
        base = dict(
            suite=None,
            image_size=64,
            render_profile="fast",
            policy={"kind": "server", "endpoints": ["tcp://b:2"]},
            config=DecodeConfig.for_policy("act"),
            dataset_version="raw",
        )
        return make_manifest(TASK, change.pop("plan", plan), **{**base, **change})

    assert sorted(prepare_folder(folder, manifest())) == [0, 1, 2]  # another endpoint serving the same policy: fine
    assert sorted(prepare_folder(folder, manifest(plan=adhoc_plan(TASK, 5, 100)))) == [0, 1, 2]  # more episodes: fine
    assert sorted(prepare_folder(folder, manifest(plan=adhoc_plan(TASK, 2, 100)))) == [0, 1, 2]  # and fewer again
    assert len(json.loads((folder / "run.json").read_text())["episodes"]) == 5  # the longer plan is kept
    with pytest.raises(DatasetError, match="other settings \\(image_size: 64 -> 96\\)"):
        prepare_folder(folder, manifest(image_size=96))
    with pytest.raises(DatasetError, match="other settings \\(episodes: other seeds or instructions\\)"):
        prepare_folder(folder, manifest(plan=adhoc_plan(TASK, 5, 200)))
    with pytest.raises(DatasetError, match="other settings \\(decode\\."):
        prepare_folder(folder, manifest(config=DecodeConfig.for_policy("pi0")))
    (folder / "episode_0001.json.tmp").write_text('{"torn')  # a write cut short by a crash
    stray = json.loads((folder / "episode_0002.json").read_text())
    (folder / "episode_0009.json").write_text(json.dumps({**stray, "episode": 9, "seed": 7}))
    with pytest.raises(DatasetError, match="episode_0009.json is not episode 0009 of this run's plan"):
        prepare_folder(folder, manifest())
    assert not (folder / "episode_0001.json.tmp").exists()


def test_summaries_are_rebuilt_from_logs_with_intervals_and_stage_progress(tmp_path) -> None:
    folder = run_folder(tmp_path / "staged", [False, True, False, False], stages=[1, 3, 0, 2])
    summary = write_summary(folder, stopped={"message": "gone"})
    assert summary == json.loads((folder / "summary.json").read_text())
    assert (summary["episodes"], summary["successes"], summary["planned"], summary["complete"]) == (4, 1, 4, True)
    assert summary["success_ci95"] == pytest.approx([round(x, 4) for x in wilson_interval(1, 4)])
    assert summary["mean_progress"] == pytest.approx((1 + 3 + 0 + 2) / 12)
    assert summary["final_stage_counts"] == {"0": 1, "1": 1, "2": 1, "3": 1}
    assert summary["failures"] == {"not_lifted": 3} and summary["stopped"] == {"message": "gone"}
    plain = summarize(run_folder(tmp_path / "plain", [True]))
    assert plain["mean_progress"] is None and plain["final_stage_counts"] is None
    with pytest.raises(DatasetError, match="no episode logs"):
        summarize(tmp_path / "nothing")


def test_report_pairs_runs_on_the_same_seeds_and_reads_logs_without_summaries(tmp_path) -> None:
    run_folder(tmp_path / "raw", [s < 3 for s in range(10)])
    run_folder(tmp_path / "aug", [s < 9 for s in range(10)], version="augmented")
    run_folder(tmp_path / "other" / "raw", [True] * 4)  # a second cell, but the same task/policy/version
    assert not list(tmp_path.rglob("summary.json"))
    with pytest.raises(DatasetError, match="both hold act on raw data for pipette/PickUpTestTube-v1"):
        load_runs([tmp_path])
    report = build_report(load_runs([tmp_path / "raw", tmp_path / "aug"]))
    [comparison] = to_json(report)["comparisons"]
    assert comparison["test"] == "mcnemar_exact" and comparison["only_a"] == 0 and comparison["only_b"] == 6
    assert comparison["p_value"] == pytest.approx(2 / 64) and comparison["significant_holm"]
    text = markdown(report)
    assert (
        "| 3/10 (30 %, 11-60) | 9/10 (90 %, 60-98) | +60 pt | McNemar p = 0.0312 (Holm 0.0312), 0 vs 6 discordant | yes |"
        in text
    )
    bar_chart(report, tmp_path / "chart.png")
    assert (tmp_path / "chart.png").stat().st_size > 0


def test_chart_labels_keep_whole_task_names_cut_between_words() -> None:
    assert _label_lines("pipette/CloseSpectrophotometerLid-v1") == ["Close", "Spectrophotometer", "Lid"]
    assert _label_lines("pipette/RemovePetriDishFromIncubator-v1") == ["RemovePetriDish", "FromIncubator"]
    assert _label_lines("testlab/HoldTube-v2") == ["HoldTube"]


def test_an_incomplete_run_is_marked_in_the_report(tmp_path) -> None:
    folder = run_folder(tmp_path / "raw", [True, False])
    plan = adhoc_plan(TASK, 5, 100)
    manifest = json.loads((folder / "run.json").read_text())
    (folder / "run.json").write_text(json.dumps({**manifest, "episodes": [[e.seed, e.instruction] for e in plan]}))
    text = markdown(build_report(load_runs([folder])))
    assert "| 1/2 (50 %, 9-91)* |" in text and "* incomplete run" in text
    assert asdict(episode(0, 1, True))["progress"] is None


def test_logs_written_before_run_json_keep_their_summary_label(tmp_path) -> None:
    folder = run_folder(tmp_path / "old", [True, True, False])
    (folder / "run.json").unlink()
    (folder / "summary.json").write_text(
        json.dumps(
            {
                "task": TASK.id,
                "policy_type": "act",
                "dataset_version": "augmented",
                "episodes": 3,
                "success_rate": 2 / 3,
            }
        )
    )
    [run] = load_runs([tmp_path])
    assert run.key == (TASK.id, "act", "augmented") and run.summary["successes"] == 2 and run.outcomes is not None
