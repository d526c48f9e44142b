"""The agent's mechanisms found by batch fifteen (tests/fixtures/agent/batch_fifteen_draft.yaml), each
tested on other wordings than the batch's: a topic clause, a path option named by the cue's object, an
optional asset by its id, paths listed pairwise, relations in instructions, refusals of what no
command does."""

from __future__ import annotations

import pytest

from pipette_cli.agent.catalog import AgentError, Unsupported
from pipette_cli.agent.offline import OfflineAgent, one_path_each
from pipette_cli.agent.plan import StepRef
from pipette_cli.cli.main import load_catalog
from pipette_cli.registry import load_registry

CATALOG = load_catalog()
REGISTRY = load_registry()
AGENT = OfflineAgent(CATALOG, REGISTRY)


def commands(request: str) -> list[tuple[str, dict]]:
    plan = AGENT.plan(request)
    assert plan.unused == [], plan.unused
    return [(s.command, s.args) for s in plan.steps]


def test_a_topic_clause_with_a_file_joins_the_request_that_follows_it() -> None:
    [(command, args)] = commands(
        "for the demos in data/rack.h5 of the pipette stand task, make two light draws per demo"
    )
    assert command == "augment" and args["input"] == "data/rack.h5" and args["variants"] == "light*2"
    [(command, args)] = commands("take the tube pick-up demos in data/t.h5, and make speed variants at 2x")
    assert command == "augment" and args["input"] == "data/t.h5" and args["speed"] == 2.0
    counted = commands("take 20 demos of the tube pick-up task into a.h5, and convert them")
    assert [c for c, _ in counted] == ["collect", "convert"]  # a count: demos to record, no topic


def test_a_length_after_a_named_option_is_read_in_metres_and_degrees_are_the_yaw() -> None:
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task with object variants, moved by up to 25 mm")
    assert args["object_xy"] == pytest.approx(0.025)
    [(_, args)] = commands(
        "augment data/t.h5 of the tube pick-up task with object variants rotated by up to 20 degrees"
    )
    assert args["object_yaw"] == 20


def test_the_cue_naming_a_path_option_of_the_step_before_continues_it() -> None:
    [(command, args)] = commands("check the scripted expert of the tube pick-up task, and put the table in out/t.md")
    assert command == "experts check" and args["markdown"] == "out/t.md"
    # a strong separator still starts a step of its own
    assert [c for c, _ in commands("check the tube pick-up expert, then tabulate evals/a into out/r")] == [
        "experts check",
        "eval report",
    ]


def test_an_optional_asset_option_takes_an_asset_id_written_out_only() -> None:
    [(_, args)] = commands("make mylab/PickUpBeaker-v1 from the pick template with beaker_50ml as the main object")
    assert args["asset"] == "beaker_50ml"
    [(_, args)] = commands("make mylab/PickUpThing-v1 from the pick template")
    assert "asset" not in args


def test_a_flag_after_not_or_rather_than_is_off() -> None:
    [(_, args)] = commands("convert data/a.h5 of the tube pick-up task with png frames rather than video")
    assert args["video"] is False
    [(_, args)] = commands("run the demo pipeline on the tube pick-up task, not the smoke run")
    assert args.get("fast") is False


def test_a_task_file_made_by_a_step_is_what_validate_then_reads() -> None:
    steps = commands("copy pipette/PickUpTestTube-v1 as lab/PickUpGently-v1 into my_tasks/, then validate the copy")
    assert steps[1] == ("tasks validate", {"paths": [StepRef(from_step=1)]})
    assert commands("validate every task") == [("tasks validate", {})]  # nothing made: the registry


def test_tied_tasks_are_told_apart_by_a_relation_their_instructions_say() -> None:
    [(_, args)] = commands("collect 5 demos of the tube off the balance")
    assert args["task_id"] == "pipette/RemoveTubeFromBalance-v1"
    with pytest.raises(AgentError, match="several tasks"):
        AGENT.plan("collect 5 demos of the centrifuge lid task")  # no relation said: still ambiguous


def test_paths_listed_pairwise_make_one_step_per_pair_labelled_by_their_folders() -> None:
    steps = commands(
        "evaluate runs/act/pipette_PickUpTestTube-v1_raw and runs/act/pipette_PickUpTestTube-v1_augmented on the "
        "tube pick-up task, into evals/r and evals/a"
    )
    assert [(a["policy"], a["out"], a.get("dataset_version")) for _, a in steps] == [
        ("runs/act/pipette_PickUpTestTube-v1_raw", "evals/r", "raw"),
        ("runs/act/pipette_PickUpTestTube-v1_augmented", "evals/a", "augmented"),
    ]
    assert one_path_each("evaluate a/ and b/ into c/ and d/ and e/", []) == []  # lists of different lengths
    assert one_path_each("evaluate a/ and b/ on it", []) == ["evaluate a/ on it", "evaluate b/ on it"]


def test_a_suite_is_named_by_all_its_words_apart_and_a_model_name_is_no_task() -> None:
    [(_, args)] = commands("evaluate runs/p on the paper benchmark, the paraphrased one")
    assert args["suite_id"] == "pipette/PaperBenchmarkParaphrased-v1"
    [(_, args)] = commands("evaluate runs/p on the nominal suite of the augmentation experiment")  # its name's words
    assert args["suite_id"] == "pipette/AugmentationNominal-v1"
    [(_, args)] = commands("train smolvla on the tube pick-up task with the SmolVLM2 backbone from /m/smolvlm2")
    assert args["vlm_path"] == "/m/smolvlm2"


def test_numbers_inside_a_quoted_description_or_a_compound_word_are_no_options() -> None:
    [(_, args)] = commands('new task: "put 3 tubes in the 24-well rack", check it on 5 seeds')
    assert args["episodes"] == 5 and args["description"] == "put 3 tubes in the 24-well rack"


def test_what_no_command_does_is_refused_with_the_reason() -> None:
    with pytest.raises(Unsupported, match="Hugging Face Hub"):
        AGENT.plan("upload data/a.h5 converted to the hugging face hub")


def test_work_no_task_does_is_refused_with_the_new_task_command() -> None:
    with pytest.raises(AgentError, match="no registered task does 'closing the fume hood sash'"):
        AGENT.plan("record 4 demos of closing the fume hood sash")


# --- batch sixteen (tests/fixtures/agent/batch_sixteen_draft.yaml), on other wordings


def test_a_file_of_a_kind_no_input_reads_is_where_the_step_writes() -> None:
    steps = commands(
        "record 3 demos of the tube pick-up task into data/a.h5, then make a gif of episode 1 at out/e1.gif"
    )
    assert steps[1] == (
        "data video",
        {"episode": [1], "out": "out/e1.gif", "video_format": "gif", "file": StepRef(from_step=1)},
    )


def test_option_names_are_no_task_words_and_joined_atoms_are_one_variant() -> None:
    [(_, args)] = commands("augment data/a.h5 of the water bath lid task, object+light variant only, light scale 0.8")
    assert args["task_id"] == "pipette/OpenWaterBathLid-v1"  # "scale" of "light scale" is no balance
    assert args["variants"] == "object+light" and args["light_scale"] == 0.8


def test_tool_names_and_new_ids_are_no_task_names() -> None:
    [(command, args)] = commands("open the MuJoCo viewer on the tube pick-up task")
    assert command == "sim view" and args["task_id"] == "pipette/PickUpTestTube-v1"
    [(command, args)] = commands('new task "put the 15 mL tube in the rack", id lab/TubeInRack-v1')
    assert command == "new-task" and args["task_id"] == "lab/TubeInRack-v1"


def test_a_question_about_what_was_recorded_is_answered() -> None:
    [(command, args)] = commands("have we collected any demos of the tube pick-up task so far?")
    assert command == "answer demos" and args["task_id"] == "pipette/PickUpTestTube-v1"


@pytest.mark.parametrize(
    "request_text",
    ["run the pick-up policy on a real UR5e in our lab", "connect the served policy via ROS 2 to the arm"],
)
def test_driving_hardware_or_ros_is_refused_with_what_pipette_offers(request_text: str) -> None:
    with pytest.raises(Unsupported, match="ZeroMQ endpoint"):
        AGENT.plan(request_text)
    [(command, _)] = commands("serve ckpt/a so my real robot can connect from other machines")  # a client: fine
    assert command == "serve"


def test_words_for_offline_steps_reliability_and_remote_clients_are_accounted() -> None:
    [(_, args)] = commands("train act on the tube pick-up task, the machine is air-gapped")
    assert args["offline"] is True
    [(_, args)] = commands("time 300 control steps of the tube pick-up scene")
    assert args["steps"] == 300
    assert commands("how reliable is the scripted expert of the tube pick-up task?")[0][0] == "experts check"
    [(_, args)] = commands("serve ckpt/a on tcp://0.0.0.0:6000, remote clients are welcome")
    assert args["allow_remote"] is True


def test_a_listing_asked_as_json_is_tasks_list_with_a_registered_tag() -> None:
    assert commands("print the piper tasks in json") == [("tasks list", {"tag": "piper", "as_json": True})]
    assert commands("list the protocols as json") == [("tasks list", {"tag": "protocol", "as_json": True})]
    assert commands("list the protocols")[0][0] == "answer tasks"  # no JSON asked: answered


def test_a_flag_said_with_alternatives_is_read_in_any_of_their_forms() -> None:
    # the flag's words are stemmed inside (a|b) alternatives as the request's are ("labels" -> "label")
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task adding joint noise with dart labels")
    assert args["variants"] == "noise" and args["noise_corrective"] is True
    [(_, args)] = commands(
        "augment data/t.h5 of the tube pick-up task: 3 noise draws per demo, keeping the clean actions"
    )
    assert args["variants"] == "noise*3" and args["noise_corrective"] is True
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task using illumination")
    assert args["variants"] == "light" and "noise_corrective" not in args
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task adding joint noise averaged over 20 steps")
    assert args["variants"] == "noise" and args["noise_window"] == 20


def test_a_number_hyphened_to_its_unit_is_read_and_other_compounds_stay() -> None:
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task with 20-step drifting joint noise")
    assert args["variants"] == "noise" and args["noise_window"] == 20
    [(_, args)] = commands("train ACT on the tube pick-up task for a 3k-step run")
    assert args["steps"] == 3000
    plan = AGENT.plan("record 4 demos of the 96-well plate task")
    assert plan.steps[0].args["episodes"] == 4 and "96-well" in plan.unused  # a compound, not 96 of anything


def test_a_duration_counts_the_tasks_control_steps_for_an_option_counted_in_them() -> None:
    # 30 Hz control (every registered task): 0.25 s is 7.5 -> 8 steps, 2 s 60, 400 ms 12
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task, joint noise smoothed over 2 seconds")
    assert args["noise_window"] == 60 and args["variants"] == "noise"
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task with a 400 ms drift window")
    assert args["noise_window"] == 12
    [(_, args)] = commands("collect 3 demos of the tube pick-up task, capped at 12 s each")
    assert args["max_steps"] == 360 and args["episodes"] == 3
    [(_, args)] = commands("collect 2 demos of the tube pick-up task, none more than 5 seconds long")
    assert args["max_steps"] == 150
    [(_, args)] = commands("collect 2 demos of the tube pick-up task with a 250-step limit")
    assert args["max_steps"] == 250
    # a duration no option counts is no number of steps (training steps are no time): listed, not read
    assert AGENT.plan("train ACT on the tube pick-up task for 30 seconds").unused == ["30"]


def test_a_noise_option_brings_the_noise_variants_it_acts_on() -> None:
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task with dart labels and a 10-step window")
    assert args["variants"] == "noise" and args["noise_corrective"] is True and args["noise_window"] == 10
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task with camera jitter and noise sigma 0.02")
    assert args["variants"] == "cam,noise" and args["noise_sigma"] == 0.02
    [(_, args)] = commands("augment data/t.h5 of the tube pick-up task with 2 light+noise draws and dart labels")
    assert args["variants"] == "light+noise*2"  # noise already in a variant: nothing added


def test_the_option_named_with_the_most_words_takes_the_path_and_checks_it_as_the_cli_does() -> None:
    # "weights" alone would be --pretrained-path; "backbone weights" name --act-backbone-weights, which
    # takes a torchvision name: the plan stops with the CLI's reason instead of fine-tuning from a file
    with pytest.raises(AgentError, match=r"--act-backbone-weights 'w/r18\.pt'.*torchvision.*--pretrained-path"):
        AGENT.plan("train ACT on the datasets in runs/d with the backbone weights in w/r18.pt")
    [(_, args)] = commands("train ACT on the datasets in runs/d starting from the weights in w/r18")
    assert args["pretrained_path"] == "w/r18" and not args.get("act_backbone_weights")


def test_a_value_of_the_command_names_no_option_before_a_path() -> None:
    # "ACT" is the policy, not --act-backbone-weights: the folder's role is asked for
    with pytest.raises(AgentError, match="cannot tell what 'runs/d' is for in 'pipette train'"):
        AGENT.plan("train ACT on runs/d")


def test_a_count_said_once_for_several_perturbations_is_each_or_combined_or_asked() -> None:
    # "camera jitter" is the cam variants' words: its "jitter" never takes the count for light's --light-jitter
    [(_, args)] = commands("augment data/a.h5 with lighting and camera jitter, 3 draws each")
    assert args["variants"] == "light*3,cam*3" and "light_jitter" not in args
    [(_, args)] = commands("augment data/a.h5 with 4 draws each of object shifts and camera poses")
    assert args["variants"] == "object*4,cam*4"
    [(_, args)] = commands("augment data/a.h5 with object shifts and camera poses combined, 4 variants per demo")
    assert args["variants"] == "object+cam*4"
    with pytest.raises(AgentError, match=r"say '4 of each' \(object\*4,cam\*4\) or '4 combining them'"):
        AGENT.plan("augment data/a.h5 with object shifts and camera poses, 4 variants per demo")
    [(_, args)] = commands("augment data/a.h5 with the originals and lighting, 3 draws per demo")
    assert args["variants"] == "original,light*3"  # the CLI repeats no original
    [(_, args)] = commands("augment data/a.h5 with two object draws and lighting, 4 draws per demo")
    assert args["variants"] == "object*2,light*4"  # a count of its own stays


def test_the_longest_words_next_to_a_number_choose_its_option_and_leading_words_are_used() -> None:
    plan = AGENT.plan("augment data/a.h5 by moving the objects within 2x the task range")
    [(_, args)] = [(s.command, s.args) for s in plan.steps]
    assert args["object_range"] == 2.0 and "speed" not in args  # "x the task range", not speed's "x"
    assert plan.unused == []  # "within" leads to the number


def test_an_options_words_name_no_task() -> None:
    # "scale" alone is the balance's; "lighting scale" is --light-scale, also where "lighting" is a value's word
    [(_, args)] = commands("augment data/a.h5 of the tube pick-up task with lighting scale 0.5")
    assert args["task_id"] == "pipette/PickUpTestTube-v1" and args["light_scale"] == 0.5


def test_the_first_n_episodes_are_indices_from_zero() -> None:
    [(command, args)] = commands("make videos of the first 3 demos in data/ur5.h5")
    assert command == "data video" and args["episode"] == [0, 1, 2]
    assert AGENT.plan("make a gif of the first two episodes of data/ur5.h5").unused == []


def test_two_words_of_a_task_name_written_as_one_are_read_apart() -> None:
    [(_, args)] = commands("collect 5 demos of opening the waterbath lid")  # was the centrifuge's lid
    assert args["task_id"] == "pipette/OpenWaterBathLid-v1"
    [(_, args)] = commands("collect 5 demos for the testtube pickup")
    assert args["task_id"] == "pipette/PickUpTestTube-v1"


def test_a_value_given_twice_through_a_shared_noun_makes_a_step_each() -> None:
    plan = AGENT.plan("evaluate runs/act/PickUpTestTube_raw on the nominal and shifted augmentation suites")
    assert [s.args["suite_id"] for s in plan.steps] == [
        "pipette/AugmentationNominal-v1",
        "pipette/AugmentationShifted-v1",
    ]
    assert plan.unused == []
    [(command, args)] = commands("compare evals/raw and evals/aug as a table")
    assert command == "eval report" and args["folders"] == ["evals/raw", "evals/aug"]


def test_a_multiplier_before_augmentation_counts_draws_and_one_with_speed_words_is_the_speed() -> None:
    plan = AGENT.plan("collect 15 demos of the tube pick-up task, then a 2x augmentation with light only")
    assert plan.steps[1].args["variants"] == "light*2" and "speed" not in plan.steps[1].args and plan.unused == []
    [(_, args)] = commands("augment data/a.h5 at 2x speed")
    assert args["speed"] == 2.0 and "variants" not in args
    [(_, args)] = commands("augment data/a.h5 by moving the objects within 2x the task range")
    assert args["variants"] == "object" and args["object_range"] == 2.0  # its number is the range's, no count


def test_the_last_checkpoint_of_a_run_folder_is_what_serve_and_eval_load() -> None:
    # both take a training run folder as its last checkpoint (lerobot.layout.policy_folder)
    serve = AGENT.plan("take the last checkpoint in runs/act/x and serve it on port 5600")
    assert serve.steps[0].command == "serve" and serve.steps[0].args["policy"] == "runs/act/x"
    assert serve.unused == ["take"]
    evaluate = AGENT.plan("evaluate the latest checkpoint of runs/act/x on the tube pick-up task, 5 episodes")
    assert [s.command for s in evaluate.steps] == ["eval"] and evaluate.steps[0].args["policy"] == "runs/act/x"
    assert evaluate.unused == []


def test_the_served_policy_is_the_endpoint_an_eval_plan_reads() -> None:
    served = AGENT.plan("evaluate the served policy at localhost:5600 on the tube pick-up task for 5 episodes")
    assert served.steps[0].args["endpoint"] == ["tcp://localhost:5600"] and served.unused == []


def test_a_word_that_names_another_option_does_not_name_a_path_option() -> None:
    # "variants" is --variants' name, though --rejected's "rejected variants" holds it: "into" the output
    plan = AGENT.plan("augment demos/a.h5 for PickUpTestTube with lighting changes, 4 variants each, into demos/b.h5")
    args = plan.steps[0].args
    assert args["output"] == "demos/b.h5" and "rejected" not in args and args["variants"] == "light*4"
    named = AGENT.plan(
        "augment demos/a.h5 for PickUpTestTube with lighting and save the rejected variants to demos/r.h5"
    )
    assert named.steps[0].args["rejected"] == "demos/r.h5"


def test_replays_as_a_noun_ask_for_no_replay_and_radians_are_joint_noise() -> None:
    plan = AGENT.plan(
        "augment demos/a.h5 for PickUpTestTube with joint noise of 0.02 rad, keep only successful replays"
    )
    assert [s.command for s in plan.steps] == ["augment"] and plan.unused == []
    assert plan.steps[0].args["noise_sigma"] == 0.02


def test_comparing_eval_folders_is_a_report_and_suite_evals_get_an_output_a_report_can_read() -> None:
    report = AGENT.plan("compare evals/raw and evals/aug")
    assert [s.command for s in report.steps] == ["eval report"]
    assert report.steps[0].args["folders"] == ["evals/raw", "evals/aug"]
    with pytest.raises(AgentError, match="'pipette eval report' does not read 'data/a.h5'"):
        AGENT.plan("compare data/a.h5 and data/b.h5")  # demos, not evaluation folders
    listed = AGENT.plan("show the episodes in demos/pick.h5")
    assert [(s.command, s.args) for s in listed.steps] == [("data inspect", {"file": "demos/pick.h5"})]
    both = AGENT.plan("evaluate runs/act/raw and runs/act/aug on the shifted suite and compare them")
    assert [s.command for s in both.steps] == ["eval", "eval", "eval report"] and both.unused == []
    # no task: the suite names the folder; the second is told apart by its policy folder's name
    assert [s.args["out"] for s in both.steps[:2]] == ["evals/AugmentationShifted", "evals/AugmentationShifted_aug"]


def test_saving_checkpoints_somewhere_is_the_output_and_data_from_a_folder_the_datasets() -> None:
    plan = AGENT.plan(
        "please train ACT on PickUpTestTube for 3000 steps on data from datasets/pick, batch 32, and save "
        "checkpoints to runs/pick"
    )
    args = plan.steps[0].args
    assert args["datasets_root"] == "datasets/pick" and args["output_root"] == "runs/pick"
    assert "pretrained_path" not in args and plan.unused == []  # "checkpoints" is what it saves, not a start


def test_how_well_a_policy_does_is_an_eval_and_copies_of_every_demo_an_augmentation() -> None:
    how = AGENT.plan("how well does runs/pick do on 30 episodes of PickUpTestTube")
    assert [(s.command, s.args["policy"], s.args["episodes"]) for s in how.steps] == [("eval", "runs/pick", 30)]
    copies = AGENT.plan("make 5 copies of every demo in data/pick.h5 of PickUpTestTube with light changes")
    assert [s.command for s in copies.steps] == ["augment"] and copies.steps[0].args["variants"] == "light*5"
    frames = AGENT.plan("how many frames does the dataset at datasets/pick have")
    assert [(s.command, s.args) for s in frames.steps] == [("data stats", {"root": "datasets/pick"})]


def test_a_training_run_folder_in_trains_layout_says_which_run_to_continue() -> None:
    plan = AGENT.plan("continue training outputs/train/act/pipette_PickUpTestTube-v1_raw up to 4000 steps")
    args = plan.steps[0].args
    assert (args["output_root"], args["policy"], args["tasks"], args["dataset_version"]) == (
        "outputs/train",
        "act",
        "pipette/PickUpTestTube-v1",
        "raw",
    )
    assert args["if_exists"] == "continue" and "datasets_root" not in args and plan.unused == []


def test_on_each_robot_is_one_step_per_robot() -> None:
    plan = AGENT.plan("collect 10 demos of CloseCentrifugeLid on each robot")
    robots = sorted(s.args["robot"] for s in plan.steps)
    assert [s.command for s in plan.steps] == ["collect"] * 3 and plan.unused == []
    assert robots == sorted(AGENT.vocab.values["robot"]) and len({s.args["out"] for s in plan.steps}) == 3


def test_raw_and_augmented_alone_ask_for_no_comparison_and_each_follows_the_steps_before() -> None:
    plan = AGENT.plan(
        "record 10 demos of PlaceTubeOnBalance, augment them with lighting, convert both raw and augmented to "
        "datasets, then train ACT on each"
    )
    assert [s.command for s in plan.steps] == ["collect", "augment", "convert", "convert", "train", "train"]
    assert [s.args["dataset_version"] for s in plan.steps[4:]] == ["raw", "augmented"] and plan.unused == []


def test_a_range_of_seeds_is_the_first_seed_and_a_count() -> None:
    plan = AGENT.plan("evaluate runs/a on PickUpTestTube with seeds 100 to 149")
    assert (plan.steps[0].args["seed"], plan.steps[0].args["episodes"]) == (100, 50) and plan.unused == []
    short = AGENT.plan("collect demos of PickUpTestTube for seeds 0-9")
    assert (short.steps[0].args["seed"], short.steps[0].args["episodes"]) == (0, 10) and short.unused == []


def test_the_whole_clause_decides_its_command_and_a_crashed_file_is_packed() -> None:
    video = AGENT.plan("export episode 2 and 5 of data/x.h5 as mp4")
    assert [(s.command, s.args["episode"]) for s in video.steps] == [("data video", [2, 5])] and video.unused == []
    fixed = AGENT.plan("the collect writing data/x.h5 crashed, fix the file")
    assert [(s.command, s.args) for s in fixed.steps] == [("data pack", {"file": "data/x.h5"})]
    timeout = AGENT.plan("evaluate against tcp://gpu-box:5555 on the clutter suite with a 60 second connect timeout")
    assert timeout.steps[0].args["connect_timeout"] == 60 and "episodes" not in timeout.steps[0].args
    free = AGENT.plan("gather 12 teleop-free expert demos of the balance placing task")
    assert "source" not in free.steps[0].args and free.unused == ["without-teleop"]  # never --source teleop
