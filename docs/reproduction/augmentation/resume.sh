#!/usr/bin/env bash
# Resume the augmentation experiment of docs/reproduction/plan.md on this machine, in the plan's order:
# the registered cells, amendment 8's training-seed replicates on the first two tasks, amendment 5, then
# (amendment 11) two lanes at once: amendment 10 (corrective noise) on PickUpTestTube then PlaceTubeOnBalance;
# amendment 6 on RemoveTubeFromBalance; then (amendments 12 and 13) two lanes: amendment 12 (drifting corrective
# noise) at S on three tasks; amendment 12 then amendment 10 at matched passes; then (amendment 15) amendment 10's
# matched-passes cell beside amendment 14 (drift beside aug_all's moved objects) on three tasks; then amendment 6's
# other cells and amendment 8 on the last two tasks, with (amendment 16) seed replicates of amendment 14's
# RemoveTubeFromBalance cell and of raw first, in two lanes. Each stage resumes where its work stopped
# (finished cells are reused; the kept episode logs are restored on a new machine), so this script can
# be started again after any interruption. It stops before anything when the CPU lacks AVX-512 (plan,
# "Machines": such a restart is written into the plan first).
#
#   bash docs/reproduction/augmentation/resume.sh            # start (in the background: setsid ... &)
#   DRY=1 bash docs/reproduction/augmentation/resume.sh      # print what it would run
#
# The code is the run's: 8739549 with the driver patches of this folder, in worktrees under $WT
# (exp2: exp-run.patch; seg: exp-run.patch + exp-seg.patch; dart: exp-run.patch + exp-dart.patch; drift:
# dart's + exp-drift.patch; plusdrift: drift's + exp-plusdrift.patch; each then exp-skip.patch; rep16: plusdrift's + exp-rep16.patch, which skips an evaluation kept from a policy trained on a
# lost machine, amendment 11); the Python environment is main's.
set -euo pipefail

MAIN=${MAIN:-$(git -C "$(dirname "$0")" rev-parse --show-toplevel)}
WT=${WT:-/work/wt}
RUN=${RUN:-/work/runs/augmentation}
MENAGERIE_ROOT=${MENAGERIE_ROOT:-$MAIN/../shared/menagerie}
RUN_CODE=8739549
HERE=$MAIN/docs/reproduction/augmentation

say() { if [ -n "${DRY:-}" ]; then echo "# $*"; else echo "[$(date -u +%H:%M:%S)] resume.sh: $*" | tee -a "$RUN/logs/run.log"; fi; }
do_() { if [ -n "${DRY:-}" ]; then echo "+ $*"; else "$@"; fi; }

if [ "$(grep -c avx512f /proc/cpuinfo || true)" = "0" ]; then
    echo "this CPU has no AVX-512: write the restart into plan.md (amendment 8, 'Machines') before going on" >&2
    exit 3
fi
do_ mkdir -p "$RUN/docs" "$RUN/logs"
[ -f "$RUN/docs/pilot.json" ] || do_ cp "$HERE/pilot.json" "$RUN/docs/"

worktree() {  # worktree NAME PATCH...: the run's code with these patches, made once
    local dir=$WT/$1
    shift
    if [ ! -d "$dir" ]; then
        do_ git -C "$MAIN" worktree add --detach "$dir" "$RUN_CODE"
        for patch in "$@"; do do_ git -C "$dir" am "$HERE/$patch"; done
    fi
}

main_stage() {  # main_stage DRIVER-STAGE ...: a check by main's driver (it changes no data)
    local cmd=(env MUJOCO_GL=egl MENAGERIE_ROOT="$MENAGERIE_ROOT" "$MAIN/.venv/bin/python" benchmarks/augmentation_experiment.py
        "$@" --work "$RUN" --docs "$RUN/docs" --keep "$HERE/episodes")
    if [ -n "${DRY:-}" ]; then
        echo "+ (cd $MAIN && ${cmd[*]})"
        return
    fi
    say "main's $*"
    (cd "$MAIN" && "${cmd[@]}" >> "$RUN/logs/run.log" 2>&1) || say "main's $* exited with $?; going on"
}

stage() {  # stage WORKTREE DRIVER-STAGE [--settings ...]: one stage of the driver from that worktree
    local dir=$WT/$1 what=$2
    shift 2
    local cmd=(env PYTHONPATH="$dir" MUJOCO_GL=egl MENAGERIE_ROOT="$MENAGERIE_ROOT" PATH="$MAIN/.venv/bin:$PATH"
        nice -n 15 "$MAIN/.venv/bin/python" benchmarks/augmentation_experiment.py "$what" --work "$RUN"
        --docs "$RUN/docs" --keep "$HERE/episodes" --workers 1 --jobs 2 "$@")
    if [ -n "${DRY:-}" ]; then
        echo "+ (cd $dir && ${cmd[*]})"
        return
    fi
    say "$what from $dir $*"
    # a stage that fails (its log says why) does not stop the others; a restart runs it again
    (cd "$dir" && "${cmd[@]}" >> "$RUN/logs/run.log" 2>&1) || say "stage $what $* exited with $?; going on"
}

# exp2: the run's code with all three driver commits (the registered settings' commands are the
# first commit's; the other two only add opt-in settings). On the machine of stops 47-49, exp holds
# the first commit only and exp2 all three.
worktree exp2 exp-run.patch exp-skip.patch
stage exp2 run                                                             # registered cells
A8=raw_seed1001,aug_all_seed1001,raw_seed1002,aug_all_seed1002
PICK=pipette/PickUpTestTube-v1 PLACE=pipette/PlaceTubeOnBalance-v1
REMOVE=pipette/RemoveTubeFromBalance-v1 CLOSE=pipette/CloseCentrifugeLid-v1
stage exp2 run --settings $A8 --tasks $PICK,$PLACE                          # amendment 8, first two tasks
worktree seg exp-run.patch exp-seg.patch exp-skip.patch
worktree dart exp-run.patch exp-dart.patch exp-skip.patch
worktree drift exp-run.patch exp-dart.patch exp-drift.patch exp-skip.patch
worktree plusdrift exp-run.patch exp-dart.patch exp-drift.patch exp-plusdrift.patch exp-skip.patch
worktree rep16 exp-run.patch exp-dart.patch exp-drift.patch exp-plusdrift.patch exp-skip.patch exp-rep16.patch
stage seg run --settings aug_all_seg,aug_object_seg --tasks $PLACE          # amendment 5 (done: restored)
# amendment 11's lanes: amendment 10 at S on PickUpTestTube, PlaceTubeOnBalance; amendment 6 on RemoveTubeFromBalance
lane1() {  # each task's raw demonstrations made by the run's code first
    for task in $PICK $PLACE; do
        stage exp2 data --settings raw --tasks $task
        stage dart run --settings aug_all_dart --tasks $task --jobs 1
    done
}
lane2() { stage exp2 run --settings more_demos_ep,aug_all_ep --tasks $REMOVE --jobs 1; }  # amendment 6
# then amendment 13's order: amendment 12 first (at S on RemoveTubeFromBalance then PlaceTubeOnBalance; at
# matched passes on RemoveTubeFromBalance), amendment 10 at matched passes on PickUpTestTube after it
lane3() {
    stage exp2 data --settings raw --tasks $REMOVE
    stage drift run --settings aug_all_drift_ep --tasks $REMOVE --jobs 1             # amendment 12, matched passes
}
lane4() {
    for task in $PICK $REMOVE $PLACE; do  # PickUpTestTube's cells are done (part 6): restored and skipped
        stage exp2 data --settings raw --tasks $task
        stage drift run --settings aug_all_drift --tasks $task --jobs 1              # amendment 12 at S
    done
}
if [ -n "${DRY:-}" ]; then
    lane1; lane2; lane3; lane4
else
    lane1 &
    lane2 &
    wait
    # both lanes train on RemoveTubeFromBalance's aug_all_drift data: made once, before they start (two
    # augmentations writing the same file at once fail)
    stage exp2 data --settings raw --tasks $REMOVE
    stage drift data --settings aug_all_drift --tasks $REMOVE
    lane3 &
    lane4 &
    wait
fi
# amendment 15: amendment 10 at matched passes on PickUpTestTube beside amendment 14 at S on three tasks
lane5() { stage dart run --settings aug_all_dart_ep --tasks $PICK --jobs 1; }
lane6() {
    for task in $PICK $REMOVE $PLACE; do
        stage exp2 data --settings raw --tasks $task
        stage plusdrift data --settings aug_all_plus_drift --tasks $task
        main_stage contained --tasks $task                    # aug_all's replays inside, unchanged (amendment 15)
        stage plusdrift run --settings aug_all_plus_drift --tasks $task --jobs 1
    done
}
# amendment 16: training-seed replicates of aug_all_plus_drift, and amendment 8's of raw, on RemoveTubeFromBalance
rep16() {  # rep16 SEED: one seed's pair
    stage exp2 run --settings raw_seed$1 --tasks $REMOVE --jobs 1
    stage rep16 run --settings aug_all_plus_drift_seed$1 --tasks $REMOVE --jobs 1
}
if [ -n "${DRY:-}" ]; then
    lane5; lane6; rep16 1002; rep16 1001
else
    { lane5; lane6; rep16 1002; } &
    rep16 1001 &
    wait
fi
stage exp2 run --settings more_demos_ep,aug_all_ep --tasks $PICK,$CLOSE,$PLACE --jobs 2   # amendment 6, the rest
stage exp2 run --settings $A8 --tasks $REMOVE,$CLOSE                        # amendment 8, last two tasks
say "all stages done: run main's report (benchmarks/augmentation_experiment.py report)"
