"""`pipette train`: commands (paper defaults, offline flags), --if-exists, missing datasets, and
LeRobot's own config parser accepting the commands (config construction only, no weights)."""

from __future__ import annotations

import json
import shlex
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import pytest

from pipette_cli.lerobot.config import parse_train_config
from pipette_cli.lerobot.convert import DatasetVersion
from pipette_cli.lerobot.train import (
    DECODER,
    LAST_CHECKPOINT,
    IfExists,
    Policy,
    TrainError,
    TrainOptions,
    plan,
    run_job,
    train_argv,
    train_checkpoint,
    trained_steps,
)

TASK = "pipette/PickUpTestTube-v1"
NAME = "pipette_PickUpTestTube-v1"
OTHER = "pipette/OpenCentrifugeLid-v1"


def make_dataset(root: Path, task: str = NAME, version: str = "raw") -> Path:
    meta = root / task / version / "meta"
    meta.mkdir(parents=True)
    (meta / "info.json").write_text("{}")
    return meta.parent


@pytest.fixture
def workdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    make_dataset(tmp_path / "datasets")
    return tmp_path


def dry_run(run_cli, *args: str) -> list[dict]:
    result = run_cli("train", *args, "--dry-run", "--json")
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


def flags(argv: list[str]) -> dict[str, str]:
    return dict(a[2:].split("=", 1) for a in argv[1:])


def test_act_command_has_paper_defaults_and_needs_no_download(workdir: Path, run_cli) -> None:
    [job] = dry_run(run_cli, "--tasks", "PickUpTestTube", "--policy", "act")
    assert job["argv"][0] == "lerobot-train" and job["action"] == "train"
    assert flags(job["argv"]) == {
        "dataset.repo_id": f"local/{NAME}_raw",
        "dataset.root": f"datasets/{NAME}/raw",
        "dataset.video_backend": "pyav",
        "policy.type": "act",
        "policy.pretrained_backbone_weights": "null",
        "policy.push_to_hub": "false",
        "policy.repo_id": f"local/act_{NAME}_raw",
        "output_dir": f"outputs/train/act/{NAME}_raw",
        "job_name": f"act_{NAME}_raw",
        "batch_size": "32",
        "steps": "15000",
        "wandb.enable": "false",
    }
    assert job["log"] == f"outputs/train/act/{NAME}_raw.log" and job["env"] == {}


def test_act_backbone_weights_are_a_torchvision_name_never_a_file(workdir: Path, run_cli) -> None:
    weights = ("--act-backbone-weights", "ResNet18_Weights.IMAGENET1K_V1")
    [job] = dry_run(run_cli, "--tasks", "PickUpTestTube", "--policy", "act", *weights)
    assert flags(job["argv"])["policy.pretrained_backbone_weights"] == "ResNet18_Weights.IMAGENET1K_V1"
    result = run_cli("train", "--tasks", "PickUpTestTube", "--policy", "act", "--act-backbone-weights", "w/r18.pt")
    assert (
        result.exit_code != 0 and "torchvision weights name" in result.stderr and "--pretrained-path" in result.stderr
    )
    assert not (workdir / "outputs").exists()
    for name in ("IMAGENET1K_V1", "DEFAULT", "null"):  # what torchvision's verify and lerobot take
        assert TrainOptions(policy=Policy.act, act_backbone_weights=name).act_backbone_weights == name
    with pytest.raises(TrainError, match="'weights/resnet18.pth'"):
        TrainOptions(policy=Policy.act, act_backbone_weights="weights/resnet18.pth")


def test_smolvla_command_defaults_and_local_backbone(workdir: Path, run_cli) -> None:
    [job] = dry_run(run_cli, "--tasks", TASK, "--policy", "smolvla", "--vlm-path", "/models/smolvlm2", "--offline")
    f = flags(job["argv"])
    assert (f["policy.type"], f["batch_size"], f["steps"]) == ("smolvla", "8", "20000")
    assert f["policy.vlm_model_name"] == "/models/smolvlm2" and f["policy.push_to_hub"] == "false"
    assert "policy.path" not in f and "policy.pretrained_backbone_weights" not in f
    assert job["env"] == {"HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1"}


def test_pi0_command_has_paper_memory_settings(workdir: Path, run_cli) -> None:
    [job] = dry_run(run_cli, "--tasks", TASK, "--policy", "pi0", "--dataset-version", "raw")
    f = flags(job["argv"])
    assert {
        k: f[k]
        for k in (
            "policy.path",
            "policy.dtype",
            "policy.gradient_checkpointing",
            "policy.freeze_vision_encoder",
            "policy.train_expert_only",
            "batch_size",
            "steps",
        )
    } == {
        "policy.path": "lerobot/pi0_base",
        "policy.dtype": "bfloat16",
        "policy.gradient_checkpointing": "true",
        "policy.freeze_vision_encoder": "true",
        "policy.train_expert_only": "true",
        "batch_size": "4",
        "steps": "20000",
    }
    assert "policy.type" not in f  # lerobot refuses --policy.type together with --policy.path
    [local] = dry_run(run_cli, "--tasks", TASK, "--policy", "pi0", "--pretrained-path", "/models/pi0_base")
    assert flags(local["argv"])["policy.path"] == "/models/pi0_base"


def test_overrides_and_extra_flags_come_last(workdir: Path, run_cli) -> None:
    [job] = dry_run(
        run_cli,
        "--tasks",
        TASK,
        "--policy",
        "act",
        "--steps",
        "7",
        "--batch-size",
        "3",
        "--device",
        "cpu",
        "--extra",
        "--policy.dim_model=32",
        "--extra=--num_workers=0",
    )
    f = flags(job["argv"])
    assert (f["steps"], f["batch_size"], f["policy.device"]) == ("7", "3", "cpu")
    assert job["argv"][-2:] == ["--policy.dim_model=32", "--num_workers=0"]


def test_text_dry_run_prints_a_runnable_command(workdir: Path, run_cli) -> None:
    result = run_cli("train", "--tasks", TASK, "--policy", "act", "--offline", "--dry-run")
    assert result.exit_code == 0
    [command] = [line for line in result.stdout.splitlines() if "lerobot-train" in line]
    words = shlex.split(command)
    assert words[:3] == ["HF_HUB_OFFLINE=1", "HF_DATASETS_OFFLINE=1", "lerobot-train"]
    assert "--policy.pretrained_backbone_weights=null" in words and "--steps=15000" in words
    assert not (workdir / "outputs").exists()  # a dry run writes nothing


def test_augmented_version_uses_its_own_dataset(workdir: Path, run_cli) -> None:
    result = run_cli("train", "--tasks", TASK, "--policy", "act", "--dataset-version", "augmented")
    assert result.exit_code == 1 and f"datasets/{NAME}/augmented" in result.stderr
    make_dataset(workdir / "datasets", version="augmented")
    [job] = dry_run(run_cli, "--tasks", TASK, "--policy", "act", "--dataset-version", "augmented")
    f = flags(job["argv"])
    assert (
        f["dataset.root"] == f"datasets/{NAME}/augmented" and f["output_dir"] == f"outputs/train/act/{NAME}_augmented"
    )


def test_missing_dataset_is_one_line_error_before_anything_runs(workdir: Path, run_cli) -> None:
    result = run_cli("train", "--tasks", f"{TASK},{OTHER}", "--policy", "act")  # not a dry run
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "pipette_OpenCentrifugeLid-v1/raw" in lines[0] and "pipette convert" in lines[0]
    assert NAME not in lines[0].split("at ", 1)[1].split(";")[0]  # only the missing one is named
    assert not (workdir / "outputs").exists()


def test_dry_run_previews_commands_before_the_datasets_exist(workdir: Path, run_cli) -> None:
    result = run_cli("train", "--tasks", f"{TASK},{OTHER}", "--policy", "act", "--dry-run")
    assert result.exit_code == 0, result.stderr
    assert len([line for line in result.stdout.splitlines() if "lerobot-train" in line]) == 2
    [warning] = [line for line in result.stderr.splitlines() if line.startswith("warning: no LeRobot dataset")]
    assert "datasets/pipette_OpenCentrifugeLid-v1/raw" in warning and "pipette convert" in warning
    assert NAME not in result.stderr  # the dataset that exists is not listed
    jobs = dry_run(run_cli, "--tasks", OTHER, "--policy", "act")
    assert flags(jobs[0]["argv"])["dataset.root"] == "datasets/pipette_OpenCentrifugeLid-v1/raw"
    assert not (workdir / "outputs").exists()


def test_unknown_task_suggests_a_name(workdir: Path, run_cli) -> None:
    result = run_cli("train", "--tasks", "PickUpTestTub", "--policy", "act", "--dry-run")
    assert result.exit_code == 1 and "PickUpTestTube-v1" in result.stderr


def test_all_means_registered_tasks_with_a_dataset(workdir: Path, run_cli) -> None:
    make_dataset(workdir / "datasets", "pipette_OpenCentrifugeLid-v1")
    make_dataset(workdir / "datasets", "pipette_NotATask-v1")  # not registered: ignored
    jobs = dry_run(run_cli, "--tasks", "all", "--policy", "act")
    assert [j["task"] for j in jobs] == [OTHER, TASK]
    result = run_cli("train", "--tasks", "all", "--policy", "act", "--dataset-version", "augmented", "--dry-run")
    assert result.exit_code == 1 and "no augmented datasets" in result.stderr


def options(tmp: Path, if_exists: IfExists) -> TrainOptions:
    return TrainOptions(policy=Policy.act, datasets_root=tmp / "datasets", output_root=tmp / "out", if_exists=if_exists)


def fake_lerobot_train(tmp: Path, code: int = 0) -> str:
    """A stand-in for lerobot-train: prints its argv and writes a checkpoint under --output_dir."""
    script = tmp / "fake-lerobot-train"
    script.write_text(f"""#!{sys.executable}
import sys, pathlib
print("fake run", *sys.argv[1:])
print("to stderr", file=sys.stderr)
args = dict(a[2:].split("=", 1) for a in sys.argv[1:])
if "output_dir" in args:
    ckpt = pathlib.Path(args["output_dir"]) / "{LAST_CHECKPOINT}"
    ckpt.mkdir(parents=True)
    (ckpt / "config.json").write_text("{{}}")
    (ckpt / "train_config.json").write_text("{{}}")
sys.exit({code})
""")
    script.chmod(0o755)
    return str(script)


def test_run_tees_output_to_log_and_finds_checkpoint(tmp_path: Path, capsys) -> None:
    make_dataset(tmp_path / "datasets")
    [job] = plan([TASK], options(tmp_path, IfExists.skip), executable=fake_lerobot_train(tmp_path))
    result = run_job(job, echo=sys.stderr)
    assert result.returncode == 0 and result.checkpoint == tmp_path / "out/act" / f"{NAME}_raw" / LAST_CHECKPOINT
    log = job.log_file.read_text()
    assert "fake run --dataset.repo_id=" in log and "to stderr" in log
    assert "to stderr" in capsys.readouterr().err


def test_if_exists_skip_overwrite_continue(tmp_path: Path) -> None:
    make_dataset(tmp_path / "datasets")
    exe = fake_lerobot_train(tmp_path)
    [first] = plan([TASK], options(tmp_path, IfExists.skip), executable=exe)
    run_job(first)
    stale = first.output_dir / "stale.txt"
    stale.write_text("old")

    [skip] = plan([TASK], options(tmp_path, IfExists.skip), executable=exe)
    assert skip.action == "skip" and skip.argv == ()
    assert run_job(skip).returncode == 0 and stale.exists()

    [cont] = plan([TASK], options(tmp_path, IfExists.continue_), executable=exe)
    config = first.output_dir / LAST_CHECKPOINT / "train_config.json"
    assert cont.action == "continue" and list(cont.argv) == [exe, f"--config_path={config}", "--resume=true", DECODER]
    assert "--steps=30000" in train_argv(TASK, TrainOptions(policy=Policy.act, steps=30000), resume=True)

    [over] = plan([TASK], options(tmp_path, IfExists.overwrite), executable=exe)
    assert over.action == "overwrite"
    assert run_job(over).returncode == 0
    assert not stale.exists() and (first.output_dir / LAST_CHECKPOINT / "config.json").is_file()
    assert first.log_file.read_text().count("# pipette train") == 1  # the old log went with the old run


def test_skip_continues_a_run_stopped_before_its_steps(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pipette_cli.lerobot.train as train_module

    make_dataset(tmp_path / "datasets")
    exe = fake_lerobot_train(tmp_path)
    monkeypatch.setattr(train_module, "lerobot_train_executable", lambda: exe)
    [first] = plan([TASK], options(tmp_path, IfExists.skip), executable=exe)
    run_job(first)
    state = first.output_dir / LAST_CHECKPOINT.parent / "training_state"
    state.mkdir()
    (state / "training_step.json").write_text('{"step": 1000}')
    assert trained_steps(first.output_dir) == 1000
    started: list[str] = []
    opts = replace(options(tmp_path, IfExists.skip), steps=4000)
    train_checkpoint(TASK, opts, on_train=lambda job: started.append(job.action))
    assert started == ["continue"]  # stopped at 1000 of 4000: resumed, not skipped nor retrained
    assert "--resume=true" in first.log_file.read_text()
    (state / "training_step.json").write_text('{"step": 4000}')
    train_checkpoint(TASK, opts, on_train=lambda job: started.append(job.action))
    assert started == ["continue"]  # finished: skipped


def test_continue_without_checkpoint_and_overwrite_of_foreign_folder_are_refused(tmp_path: Path) -> None:
    make_dataset(tmp_path / "datasets")
    out = tmp_path / "out/act" / f"{NAME}_raw"
    out.mkdir(parents=True)
    (out / "notes.txt").write_text("mine")
    with pytest.raises(TrainError, match="no checkpoint to continue from"):
        plan([TASK], options(tmp_path, IfExists.continue_))
    with pytest.raises(TrainError, match="not a lerobot-train output"):
        plan([TASK], options(tmp_path, IfExists.overwrite))
    assert (out / "notes.txt").read_text() == "mine"


def test_failed_run_exits_1_naming_the_log(workdir: Path, run_cli, monkeypatch: pytest.MonkeyPatch) -> None:
    import pipette_cli.lerobot.train as train_module

    exe = fake_lerobot_train(workdir, code=3)
    monkeypatch.setattr(train_module, "lerobot_train_executable", lambda: exe)
    result = run_cli("-q", "train", "--tasks", TASK, "--policy", "act")
    assert result.exit_code == 1
    assert "1 of 1 training run failed" in result.stderr and f"{NAME}_raw.log" in result.stderr


# LeRobot's own parser (draccus) accepts the commands: config construction only, no weights.


@pytest.fixture(scope="module")
def pi0_config_dir(tmp_path_factory) -> Path:
    """A local stand-in for lerobot/pi0_base holding only its config.json (no weights)."""
    from lerobot.policies.pi0.configuration_pi0 import PI0Config

    path = tmp_path_factory.mktemp("pi0_base")
    PI0Config().save_pretrained(path)
    return path


@pytest.mark.parametrize("policy", list(Policy), ids=lambda p: p.value)
def test_lerobot_parser_accepts_the_command(policy: Policy, pi0_config_dir: Path) -> None:
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.pi0.configuration_pi0 import PI0Config
    from lerobot.policies.smolvla.configuration_smolvla import SmolVLAConfig

    out = Path(tempfile.mkdtemp()) / "out"
    opts = TrainOptions(
        policy=policy,
        output_root=out,
        device="cpu",
        dataset_version=DatasetVersion.augmented,
        pretrained_path=str(pi0_config_dir) if policy is Policy.pi0 else None,
        vlm_path="/models/smolvlm2" if policy is Policy.smolvla else None,
    )
    cfg = parse_train_config(train_argv(TASK, opts))
    assert cfg.dataset.repo_id == f"local/{NAME}_augmented" and cfg.dataset.root == f"datasets/{NAME}/augmented"
    assert cfg.output_dir == out / policy.value / f"{NAME}_augmented"
    assert cfg.policy.push_to_hub is False and cfg.policy.device == "cpu" and cfg.wandb.enable is False
    if policy is Policy.act:
        assert isinstance(cfg.policy, ACTConfig) and cfg.policy.pretrained_backbone_weights is None
        assert (cfg.batch_size, cfg.steps) == (32, 15000)
    elif policy is Policy.smolvla:
        assert isinstance(cfg.policy, SmolVLAConfig) and cfg.policy.vlm_model_name == "/models/smolvlm2"
        assert (cfg.batch_size, cfg.steps) == (8, 20000)
    else:
        assert isinstance(cfg.policy, PI0Config) and cfg.policy.pretrained_path == pi0_config_dir
        assert (cfg.policy.dtype, cfg.policy.gradient_checkpointing) == ("bfloat16", True)
        assert cfg.policy.freeze_vision_encoder and cfg.policy.train_expert_only
        assert (cfg.batch_size, cfg.steps) == (4, 20000)


def test_lerobot_parser_rejects_an_unknown_flag() -> None:
    """The check above can fail: a misspelt flag is refused by the same parser."""
    argv = train_argv(TASK, TrainOptions(policy=Policy.act, extra=("--policy.dim_modl=32",)))
    with pytest.raises(SystemExit) as exc:
        parse_train_config(argv)
    assert exc.value.code == 2


def test_threads_sets_the_training_process_threads(workdir: Path, run_cli) -> None:
    [job] = dry_run(run_cli, "--tasks", TASK, "--policy", "act", "--threads", "1", "--offline")
    assert job["env"] == {
        "HF_HUB_OFFLINE": "1",
        "HF_DATASETS_OFFLINE": "1",
        "OMP_NUM_THREADS": "1",
        "MKL_NUM_THREADS": "1",
    }
    assert not any("thread" in a for a in job["argv"])  # an environment setting, not a lerobot-train flag


def test_the_cpu_small_act_loads_in_one_worker_on_one_thread() -> None:
    """The small ACT of `pipette demo` and the CPU reproduction preset, as lerobot-train reads it:
    the settings docs/training.md measured (one dataloader worker, one torch thread)."""
    from pipette_cli.demo import FULL, SMALL_ACT, SMALL_ACT_THREADS

    options = TrainOptions(policy=Policy.act, device="cpu", batch_size=8, threads=FULL.threads, extra=FULL.act)
    cfg = parse_train_config(train_argv(TASK, options))
    assert FULL.act == SMALL_ACT and SMALL_ACT_THREADS == 1
    assert cfg.num_workers == 1 and cfg.persistent_workers  # the worker lives through the run, not one epoch
    assert (cfg.policy.dim_model, cfg.policy.n_encoder_layers, cfg.policy.chunk_size, cfg.policy.use_amp) == (
        128,
        2,
        20,
        False,
    )
    [job] = plan([TASK], options)
    assert job.env["OMP_NUM_THREADS"] == "1"


def test_a_long_training_on_the_cpu_is_warned_about(workdir: Path) -> None:
    from pipette_cli.lerobot.train import CPU_STEPS, cpu_warning

    long = plan([TASK], TrainOptions(policy=Policy.act, device="cpu"), executable="lerobot-train")
    assert "15000 steps on the CPU" in (cpu_warning(TrainOptions(policy=Policy.act, device="cpu"), long) or "")
    short = TrainOptions(policy=Policy.act, device="cpu", steps=CPU_STEPS, batch_size=8)
    assert cpu_warning(short, plan([TASK], short, executable="lerobot-train")) is None
    gpu = TrainOptions(policy=Policy.act, device="cuda")
    assert cpu_warning(gpu, plan([TASK], gpu, executable="lerobot-train")) is None
