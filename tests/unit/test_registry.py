"""The registry: the 12 benchmark tasks, contract tests over every task, search paths."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from pipette_cli.errors import SpecError, TaskNotFound
from pipette_cli.registry import ENTRY_POINT_GROUP, load_registry
from pipette_cli.specs.task import TaskSpec
from pipette_cli.specs.yaml_io import dump_yaml, parse_yaml, read_yaml, to_plain

FIXTURES = Path(__file__).parents[1] / "fixtures" / "tasks"
REGISTRY = load_registry()
TASK_IDS = REGISTRY.ids()

PAPER_TASKS = {
    "pipette/PickUpTestTube-v1": ("franka_panda", "lift_and_hold"),
    "pipette/PipetteToPetriDish-v1": ("franka_panda", "near_target"),
    "pipette/RemovePetriDishFromIncubator-v1": ("franka_panda", "region_hold"),
    "pipette/PlacePetriDishInIncubator-v1": ("franka_panda", "stable_placement"),
    "pipette/CloseCentrifugeLid-v1": ("franka_panda", "joint_threshold"),
    "pipette/OpenCentrifugeLid-v1": ("franka_panda", "mechanism_triggered"),
    "pipette/OpenWaterBathLid-v1": ("franka_panda", "displacement"),
    "pipette/CloseSpectrophotometerLid-v1": ("franka_panda", "joint_threshold"),
    "pipette/PlaceTubeOnBalance-v1": ("franka_panda", "region_hold"),
    "pipette/RemoveTubeFromBalance-v1": ("franka_panda", "displacement"),
    "pipette/PlacePipetteInRack-v1": ("franka_panda", "region_hold"),
    "pipette/PlaceFlaskOnShaker-v1": ("agilex_piper", "region_hold"),
}


def test_the_twelve_benchmark_tasks_are_registered() -> None:
    benchmark = REGISTRY.ids(tag="paper-benchmark")
    assert sorted(benchmark) == sorted(PAPER_TASKS)
    for task_id, (robot, evaluator) in PAPER_TASKS.items():
        spec = REGISTRY.get(task_id)
        assert (spec.embodiment.robot, spec.success.type) == (robot, evaluator), task_id
    categories = [REGISTRY.get(t).category for t in benchmark]
    assert {c: categories.count(c) for c in set(categories)} == {
        "consumable_handling": 4,
        "hatch_control": 4,
        "placement_relocation": 4,
    }


def test_paper_thresholds_are_kept() -> None:
    """Appendix A.8 / A.6 numbers, pinned so an edit that drifts from the paper is noticed."""
    s = REGISTRY.get("pipette/PickUpTestTube-v1").success
    assert (s.min_height_gain, s.hold_s, s.max_tilt_deg, s.timeout_s) == (0.02, 0.5, 35, 7)
    s = REGISTRY.get("pipette/RemoveTubeFromBalance-v1").success
    assert (s.delta.y.min, s.delta.z.max, s.hold_s, s.max_tilt_deg, s.timeout_s) == (0.25, -0.12, 1.2, 10, 10)
    s = REGISTRY.get("pipette/PipetteToPetriDish-v1").success
    assert (s.max_xy_distance, s.min_z, s.timeout_s) == (0.12, 0.6, 12)
    s = REGISTRY.get("pipette/PlacePipetteInRack-v1").success
    assert (s.y.min, s.hold_s) == (0.14, 1.0)
    s = REGISTRY.get("pipette/OpenWaterBathLid-v1").success
    assert (s.delta.x.max, s.delta.z.min, s.hold_s) == (-0.30, 0.10, 0.3)
    s = REGISTRY.get("pipette/RemovePetriDishFromIncubator-v1").success
    assert (s.x.max, s.z.min, s.hold_s) == (0.6, 0.6, 0.5)
    s = REGISTRY.get("pipette/PlacePetriDishInIncubator-v1").success
    assert (s.x.min, s.y.max, s.z.min, s.max_dz_per_step, s.hold_s) == (0.55, 0.1, 0.6, 0.002, 0.5)
    s = REGISTRY.get("pipette/PlaceTubeOnBalance-v1").success
    assert (s.within.radius_scale, s.z.min, s.z.max, s.hold_s) == (0.5, 0.63, 0.73, 1.0)
    spec = REGISTRY.get("pipette/OpenCentrifugeLid-v1")
    mech = spec.scene.mechanisms[0]
    assert (mech.target_deg, mech.ramp_s, mech.max_force, mech.stiffness, mech.damping) == (-40, 2, 1000, 200, 20)
    assert spec.success.target.max == -39


@pytest.mark.parametrize("task_id", TASK_IDS, ids=TASK_IDS)
def test_contract_spec_round_trips(task_id: str) -> None:
    entry = REGISTRY.entry(task_id)
    # the file as a person wrote it survives a comment-preserving load/dump unchanged
    text = entry.path.read_text(encoding="utf-8")
    assert dump_yaml(read_yaml(entry.path)) == text
    # the validated spec dumps to YAML and reads back equal
    dumped = dump_yaml(entry.spec.model_dump(mode="json"))
    assert TaskSpec.model_validate(to_plain(parse_yaml(dumped))) == entry.spec
    # every task is fully specified for the runtime
    spec = entry.spec
    assert spec.instruction.strip() and spec.targets
    assert spec.success.timeout_s is not None, "every task needs a time limit"
    assert spec.cameras.wrist.mount == "end_effector"


def test_lookup_by_short_name_and_did_you_mean() -> None:
    assert REGISTRY.get("PickUpTestTube-v1").id == "pipette/PickUpTestTube-v1"
    assert REGISTRY.get("PickUpTestTube").id == "pipette/PickUpTestTube-v1"
    assert REGISTRY.get("pipette/PickUpTestTube").id == "pipette/PickUpTestTube-v1"
    with pytest.raises(TaskNotFound, match="did you mean .*PickUpTestTube"):
        REGISTRY.get("PickUpTestTub")


def test_a_short_name_in_two_namespaces_is_ambiguous(tmp_path: Path) -> None:
    text = (FIXTURES / "valid_pick.yaml").read_text().replace("testlab/PickUpMicrotube-v1", "mylab/PickUpTestTube-v1")
    (tmp_path / "pick.yaml").write_text(text)
    registry = load_registry([tmp_path])
    with pytest.raises(TaskNotFound, match="ambiguous: mylab/PickUpTestTube-v1, pipette/PickUpTestTube-v1"):
        registry.get("PickUpTestTube")
    assert registry.get("pipette/PickUpTestTube").id == "pipette/PickUpTestTube-v1"


def test_extra_folders_from_env_and_option(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PIPETTE_REGISTRY_PATH", str(FIXTURES / "dup"))
    with pytest.raises(SpecError, match="duplicate task id 'testlab/PickUpMicrotube-v1'"):
        load_registry()
    monkeypatch.delenv("PIPETTE_REGISTRY_PATH")
    extra = FIXTURES / "extra"
    extra.mkdir(exist_ok=True)
    (extra / "pick.yaml").write_text((FIXTURES / "valid_pick.yaml").read_text())
    try:
        registry = load_registry([extra])
    finally:
        (extra / "pick.yaml").unlink()
        extra.rmdir()
    assert "testlab/PickUpMicrotube-v1" in registry.tasks and len(registry.tasks) == len(TASK_IDS) + 1


def test_a_broken_file_refuses_the_whole_registry(tmp_path: Path) -> None:
    (tmp_path / "good.yaml").write_text((FIXTURES / "valid_pick.yaml").read_text())
    (tmp_path / "bad.yaml").write_text(
        (FIXTURES / "broken" / "unknown_key.yaml").read_text().replace("PickUpMicrotube", "Other")
    )
    with pytest.raises(SpecError) as info:
        load_registry([tmp_path])
    assert len(info.value.problems) == 1 and "bad.yaml:24" in info.value.problems[0]


def test_task_pack_entry_point(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A third-party package declares its task folder as a ``pipette.tasks`` entry point."""
    tasks = tmp_path / "mylab_tasks"
    tasks.mkdir()
    (tasks / "pick.yaml").write_text((FIXTURES / "valid_pick.yaml").read_text())
    (tmp_path / "mylab_pack.py").write_text(f"from pathlib import Path\nTASKS = Path({str(tasks)!r})\n")
    dist = tmp_path / "mylab_pack-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: mylab-pack\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\nmylab = mylab_pack:TASKS\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    registry = load_registry()
    assert registry.entry("testlab/PickUpMicrotube-v1").path == tasks / "pick.yaml"
    sys.modules.pop("mylab_pack", None)


PACK_WITH_EVALUATOR = """
from pathlib import Path
from typing import Literal

from pipette_cli.evaluators.base import Verdict, register
from pipette_cli.specs.evaluators import EvaluatorSpec, register_evaluator


@register_evaluator
class TouchSpec(EvaluatorSpec):
    type: Literal["mylab_touch"] = "mylab_touch"
    object: str


@register("mylab_touch")
class Touch:
    def __init__(self, spec):
        self.spec = spec

    def reset(self, state):
        pass

    def update(self, state):
        return Verdict()


TASKS = Path(__file__).parent / "mylab_tasks"
"""


def test_validating_one_file_knows_the_evaluator_types_of_task_packs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, run_cli
) -> None:
    """A pack that registers its own evaluator type (spec and runtime): `tasks validate FILE` imports it
    first, and builds the task's scene with it."""
    from pipette_cli.evaluators.base import EVALUATOR_RUNTIMES
    from pipette_cli.specs.evaluators import EVALUATORS

    (tmp_path / "mylab_tasks").mkdir()
    (tmp_path / "mylab_evalpack.py").write_text(PACK_WITH_EVALUATOR)
    dist = tmp_path / "mylab_evalpack-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: mylab-evalpack\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\nmylab = mylab_evalpack:TASKS\n")
    doc = read_yaml(FIXTURES / "valid_pick.yaml")
    doc["success"] = {"type": "mylab_touch", "object": "tube"}
    task_file = tmp_path / "touch.yaml"
    task_file.write_text(dump_yaml(doc))
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        result = run_cli("tasks", "validate", task_file)
        assert result.exit_code == 0, result.stderr
        assert "mylab_touch" in EVALUATORS
    finally:
        EVALUATORS._types.remove("mylab_touch")
        EVALUATOR_RUNTIMES._items.pop("mylab_touch", None)
        EVALUATOR_RUNTIMES._sources.pop("mylab_touch", None)
        sys.modules.pop("mylab_evalpack", None)
    assert run_cli("tasks", "validate", tmp_path / "missing.yaml").exit_code == 1


def test_a_command_line_selects_all_the_benchmark_or_a_list_of_tasks() -> None:
    registry = load_registry([])
    assert registry.select("all") == registry.ids() and len(registry.select("benchmark")) == 12
    assert registry.select("PickUpTestTube, pipette/OpenWaterBathLid-v1") == [
        "pipette/PickUpTestTube-v1",
        "pipette/OpenWaterBathLid-v1",
    ]
