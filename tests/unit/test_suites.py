"""Evaluation suites: the shipped ones, validation with file:line errors, versions, the episode plan."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipette_cli.errors import SpecError, SuiteNotFound
from pipette_cli.evaluation.suites import episode_plan, load_suite_file, load_suites
from pipette_cli.registry import load_registry
from pipette_cli.specs.suite import DEFAULT_EPISODES

FIXTURES = Path(__file__).parents[1] / "fixtures"
REGISTRY = load_registry()
SUITES = load_suites(REGISTRY)


def test_the_shipped_suites_freeze_the_paper_benchmark() -> None:
    paper = SUITES.get("PaperBenchmark").spec
    assert paper.id == "pipette/PaperBenchmark-v1" and paper.version == 1
    assert {t.task for t in paper.tasks} == set(REGISTRY.ids("paper-benchmark"))
    for entry in paper.tasks:  # the paper's protocol: the task's own instruction, 75 seeds
        assert entry.instructions == [REGISTRY.get(entry.task).instruction]
        assert paper.task_seeds(entry) == list(range(100_000, 100_000 + DEFAULT_EPISODES))
    paraphrased = SUITES.get("pipette/PaperBenchmarkParaphrased-v1").spec
    for entry in paraphrased.tasks:  # variant 0 is the task's instruction; seeds pair with the paper suite
        assert len(entry.instructions) == 3 and entry.instructions[0] == REGISTRY.get(entry.task).instruction
        assert paraphrased.task_seeds(entry) == paper.task_seeds(entry)
    assert all(len(s.spec.task_seeds(t)) >= 50 for s in SUITES.suites.values() for t in s.spec.tasks)
    cpu = SUITES.get("CpuReproduction").spec  # benchmarks/reproduce_table.py --preset cpu
    assert (cpu.image_size, [len(cpu.task_seeds(t)) for t in cpu.tasks]) == (64, [50] * 4)


def test_two_plans_of_a_suite_are_identical_and_use_instructions_in_turn() -> None:
    dirs = [FIXTURES / "demos" / "registry", FIXTURES / "eval" / "registry"]
    registry = load_registry(dirs)
    suites = load_suites(registry, dirs)
    first = episode_plan(suites.get("testlab/Tiny-v1").spec)
    again = episode_plan(load_suites(load_registry(dirs), dirs).get("testlab/Tiny-v1").spec)
    assert first == again
    hold = first["testlab/HoldTube-v1"]
    assert [(e.index, e.seed) for e in hold] == [(0, 700), (1, 701), (2, 702), (3, 703)]  # the task's own range
    assert [e.instruction for e in hold] == ["Hold still next to the test tube.", "Stay beside the tube."] * 2
    assert [e.seed for e in first["testlab/StagedHoldTube-v1"]] == [500, 501, 502]  # the suite's range
    assert suites.get("Tiny").spec.id == "testlab/Tiny-v2"  # no version: the latest
    assert [e.seed for e in episode_plan(suites.get("Tiny").spec)["testlab/HoldTube-v1"]] == [11, 3, 7]
    assert list(episode_plan(suites.get("Tiny-v1").spec, ["testlab/StagedHoldTube-v1"])) == [
        "testlab/StagedHoldTube-v1"
    ]
    with pytest.raises(SuiteNotFound, match="task testlab/StagedHoldTube-v1 is not in suite testlab/Tiny-v2"):
        episode_plan(suites.get("Tiny-v2").spec, ["testlab/StagedHoldTube-v1"])
    with pytest.raises(
        SuiteNotFound, match="unknown suite 'Tiyn'; did you mean 'testlab/Tiny-v2' or 'testlab/Tiny-v1'"
    ):
        suites.get("Tiyn")
    assert "testlab/Tiny-v1" not in SUITES.ids()  # fixtures stay out


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "suites" / "s.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_bad_suites_are_refused_with_file_and_line(tmp_path) -> None:
    path = write(
        tmp_path,
        """id: lab/S-v1
name: s
tasks:
  - task: pipette/PickUpTestTube-v1
    instructions: [Pick it up.]
  - task: pipette/PickUpTestTub-v1
    instructions: [Pick it up.]
""",
    )
    with pytest.raises(SpecError) as info:
        load_suite_file(path, REGISTRY)
    [problem] = info.value.problems
    assert problem.startswith(
        f"{path}:6: tasks.1.task: unknown task 'pipette/PickUpTestTub-v1'; did you mean 'pipette/PickUpTestTube-v1'"
    )
    path = write(
        tmp_path,
        """id: lab/S-v1
name: s
seeds: {first: 0, cuont: 3}
tasks:
  - task: pipette/PickUpTestTube
    seeds: [1, 2, 2]
    instructions: []
""",
    )
    with pytest.raises(SpecError) as info:
        load_suite_file(path, REGISTRY)
    problems = "\n".join(info.value.problems)
    assert f"{path}:3: seeds.cuont: unknown key 'cuont'; did you mean 'count'?" in problems
    assert f"{path}:5: tasks.0.task: String should match pattern" in problems  # a suite pins task versions
    assert f"{path}:7: tasks.0.instructions: List should have at least 1 item" in problems


def test_suites_live_beside_tasks_and_duplicates_are_refused(tmp_path) -> None:
    text = "id: lab/S-v1\nname: s\ntasks:\n  - task: pipette/PickUpTestTube-v1\n    instructions: [Pick it up.]\n"
    write(tmp_path, text)
    (tmp_path / "suites" / "copy.yaml").write_text(text)
    registry = load_registry([tmp_path])  # suites/ is not read as tasks
    with pytest.raises(SpecError, match="duplicate suite id 'lab/S-v1'"):
        load_suites(registry, [tmp_path])
    (tmp_path / "suites" / "copy.yaml").unlink()
    assert "lab/S-v1" in load_suites(registry, [tmp_path]).ids()
